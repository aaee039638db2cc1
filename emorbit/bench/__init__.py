"""``emorbit bench``: what accuracy costs in time, measured beside REBOUND (and heyoka, when
installed) in one process, on the machine it runs on.

Sections (``--only`` / ``--skip`` pick them):

single          the paper's orbit at dt = T/100: ns per step of em, midpoint and leapfrog at
                orders 2-8, and of REBOUND's leapfrog, WHFast and IAS15 (:mod:`.single`)
ensemble        1e5 test particles (a in [5, 10] m, e in [0, 0.9], random planes and
                time-uniform phases, GM = 3.9478, dt = T/1000 of a 6 m orbit): particle-steps
                per second of em on one thread and on all threads, against REBOUND's leapfrog
                and WHFast (N_active = 1), with each one's max energy error; the bound from
                division and square-root throughput measured in the same run, and the floor
                of the kernel's state (the most of that bound any kernel keeping it can
                reach); and a point-mass scene's throughput against the bare kernel's
                (:mod:`.ensemble`, :mod:`.limits`)
work-precision  final position error (against the analytic Kepler solution) and max energy
                error against CPU time over 100 orbits, for the paper's orbit and an e = 0.9
                orbit: every method and order at several dt, REBOUND IAS15 at several epsilons,
                WHFast and leapfrog, heyoka's Taylor integrator at tolerances 1e-6 ... eps
                (:mod:`.workprecision`)
startup         wall time of ``emorbit run paper-ellipse`` with an empty Numba cache (cold)
                and with it filled (warm) (:mod:`.startup`)
rigid           the rigid-body rows of :mod:`emorbit.bench.rigid`
rigid-precision attitude, omega and energy errors against CPU time for rigid bodies: em and
                midpoint at orders 2-8 beside Exudyn (generalized-alpha, RK44) and Basilisk
                (RK4, RKF78), torque-free and in orbit (:mod:`.rigid_precision`)
elastic         the elastic-body rows of :mod:`emorbit.bench.elastic` (cost per step against
                degrees of freedom, up to a 10,000-DOF beam) and a coupled structure's work
                against precision, em beside tfe (:mod:`.elastic_precision`)
effects         effects beyond the central field (:mod:`.effects`): central + J2 against
                central only per particle-step (1000 Earth orbits), 1000 mutually attracting
                point masses against REBOUND's leapfrog with direct summation (time per step,
                energy errors), the compile time of each effect set and the warm start-up of
                ``emorbit run`` (fresh processes, an empty cache, then a filled one), and the
                central-only path against the bare kernel
gravity-field   a rotating Earth's EGM2008 field (:mod:`.gravity_field`): cost per step of one
                LEO point at degree 2, 20, 70, 120 against the central field alone; 1 day of
                LEO at 20 x 20, em fixed and adaptive against heyoka's Taylor integrator
                (CPU time to 1e-6 and 1e-9 of a, heyoka's compile time, the Jacobi integral's
                drift), against heyoka in long double; "skipped" without heyoka
perturbed       work against precision on perturbed orbits (:mod:`.perturbed`): LEO (J2..J6,
                drag, radiation pressure with a cylindrical shadow, the Moon and the Sun),
                Molniya (J2..J4, Moon, Sun) and GEO (J2, Moon, Sun, radiation pressure); em
                fixed and adaptive beside heyoka, REBOUND IAS15 and scipy DOP853 on the same
                force model, against heyoka in long double; "skipped" rows without a peer
gpu             point-mass ensembles on an NVIDIA GPU (:mod:`.gpu`): the kernel alone, the
                path that copies the state every chunk, the resident path ``Simulation``
                uses, the CPU ensemble, with the card's name; "skipped" without a GPU

Ratios are always taken within the run, and the targets are ratios (:mod:`.runner`). The
JSON (``--json``) records the CPU model, the core count, the load average and package
versions beside every figure; ``--plots DIR`` writes the work-precision figures. How it
times is :mod:`.timing`; what the sections share is :mod:`.common`. Only this module is
imported to build the command line; the sections import what they need when they run.
"""

from __future__ import annotations

#: the sections, in the order they run
SECTIONS = (
    "single",
    "ensemble",
    "work-precision",
    "startup",
    "rigid",
    "rigid-precision",
    "elastic",
    "effects",
    "gravity-field",
    "perturbed",
    "gpu",
)

__all__ = ["SECTIONS", "add_arguments", "run"]


def add_arguments(parser) -> None:
    """Add ``emorbit bench``'s options to its sub-command parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser of the ``bench`` sub-command.
    """
    parser.add_argument(
        "--quick",
        action="store_true",
        help="fewer repeats and step sizes: a shorter, noisier run",
    )
    parser.add_argument("--json", metavar="FILE", help="write every figure, with the machine, as JSON")
    parser.add_argument("--plots", metavar="DIR", help="write the work-precision figures (PNG) into DIR")
    parser.add_argument(
        "--only",
        nargs="+",
        choices=SECTIONS,
        metavar="SECTION",
        help=f"run only these sections ({', '.join(SECTIONS)})",
    )
    parser.add_argument(
        "--skip", nargs="+", choices=SECTIONS, default=(), metavar="SECTION", help="leave these sections out"
    )


def run(args) -> int:
    """Run ``emorbit bench`` with parsed arguments.

    Parameters
    ----------
    args : argparse.Namespace
        The options of :func:`add_arguments`.

    Returns
    -------
    int
        The exit code (0).
    """
    from .runner import run_bench

    sections = [s for s in (args.only or SECTIONS) if s not in args.skip]
    return run_bench(sections, quick=args.quick, json_path=args.json, plots_dir=args.plots)
