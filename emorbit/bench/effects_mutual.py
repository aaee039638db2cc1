"""Mutual gravity of many point masses: em against REBOUND's leapfrog on a Plummer sphere.

1000 stars of one solar mass (scale radius 1 pc, velocities scaled to virial equilibrium
2K = |W|, no softening; G of astropy, SI) in free space, dt = 1e-4 sqrt(a^3 / (G M)): em's
time per step (``add_effect("mutual")``, the effect step with the set compiled) against
REBOUND's leapfrog with direct summation (``gravity = "basic"``, the same G and initial
conditions), and each one's relative energy error over the steps it took. Part of the
``effects`` section (:mod:`.effects`). Reference: S. J. Aarseth, M. Henon, R. Wielen,
Astron. Astrophys. 37 (1974) 183-187.
"""

from __future__ import annotations

import math

import numpy as np

from .common import ReboundRunner, SystemRunner, points_of
from .timing import CPU, calibrate, paired_ratio

__all__ = ["plummer", "mutual_rows"]


def plummer(n: int, seed: int = 8):
    """A Plummer sphere of n stars of one solar mass, scale radius 1 pc, in virial equilibrium.

    Positions and speeds are drawn from Plummer's distribution function (Aarseth, Henon and
    Wielen 1974; radii out to the one enclosing 99 % of the mass), isotropic directions,
    moved to the centre of mass at rest; the velocities are then scaled so that 2K = |W|.

    Parameters
    ----------
    n : int
        Number of stars (at least 2).
    seed : int
        Seed of numpy's default generator.

    Returns
    -------
    m : ndarray
        (n,) masses, kg.
    x, v : ndarray
        (3, n) positions (m) and velocities (m/s).
    a, total : float
        The scale radius (m) and the total mass (kg).
    """
    import astropy.constants as const
    import astropy.units as u

    from ..effects.mutual import G

    rng = np.random.default_rng(seed)
    msun, a = float(const.M_sun.si.value), float((1 * u.pc).si.value)
    m = np.full(n, msun)
    total = float(m.sum())
    r = a / np.sqrt(rng.uniform(0.0, 0.99, n) ** (-2.0 / 3.0) - 1.0)
    q = np.empty(n)
    k = 0
    while k < n:  # von Neumann rejection for q = v / v_escape: g(q) = q^2 (1 - q^2)^3.5
        s, y = rng.uniform(0.0, 1.0), rng.uniform(0.0, 0.1)
        if y < s * s * (1.0 - s * s) ** 3.5:
            q[k] = s
            k += 1
    speed = q * np.sqrt(2.0 * G * total / np.sqrt(r * r + a * a))

    def directions():
        c, phi = rng.uniform(-1.0, 1.0, n), rng.uniform(0.0, 2 * np.pi, n)
        s = np.sqrt(1.0 - c * c)
        return np.array([s * np.cos(phi), s * np.sin(phi), c])

    x, v = r * directions(), speed * directions()
    x -= (x @ m / total)[:, None]
    v -= (v @ m / total)[:, None]
    kinetic, potential = _nbody_energy(m, x, v)
    v *= math.sqrt(-potential / (2.0 * kinetic))
    return m, np.ascontiguousarray(x), np.ascontiguousarray(v), a, total


def _nbody_energy(m, x, v) -> tuple:
    """Kinetic and mutual potential energy of point masses, J (the mutual effect's own
    potential, from its compiled set in free space; each point a body of its own)."""
    from ..bodies.effect_binding import EffectBinding
    from ..effects.effectset import EffectSet

    effects = EffectSet(None)
    effects.add({"kind": "mutual"}, "mutual")
    n = m.size
    x, m = np.ascontiguousarray(x, float)[None], np.ascontiguousarray(m, float)
    potentials = EffectBinding(effects, "point").potentials(x, None, m, np.arange(n, dtype=np.int64), np.ones((1, n)))
    kinetic = 0.5 * float(np.einsum("kn,kn,n->", v, v, m))
    return kinetic, float(potentials["potential_mutual"][0])


def _timed_slow(runners: dict, cfg) -> dict:
    """:func:`.timing.timed` for engines whose step may take longer than a call should: calls
    of at least one step (not twenty)."""
    steps = {name: calibrate(fn, cfg.repeat_s, min_steps=1) for name, fn in runners.items()}
    samples = {name: [] for name in runners}
    for _ in range(cfg.repeats):
        for name, fn in runners.items():
            samples[name].append(np.array(fn(steps[name])) / steps[name] * 1e6)
    out = {}
    for name, us in samples.items():
        wall, cpu = np.array(us).T
        out[name] = {
            "us_per_step": float(np.median(wall)),
            "cpu_us_per_step": float(np.median(cpu)),
            "steps": steps[name],
            "repeats": len(us),
            "samples_us": [round(float(s), 4) for s in wall],
            CPU: [round(float(s), 4) for s in cpu],
        }
    return out


def _rebound_nbody(m, x, v, dt: float):
    """REBOUND's leapfrog with direct summation (no softening) of the same bodies, G of astropy."""
    import rebound

    from ..effects.mutual import G

    sim = rebound.Simulation()
    sim.G = G
    for i in range(m.size):
        sim.add(m=float(m[i]), x=x[0, i], y=x[1, i], z=x[2, i], vx=v[0, i], vy=v[1, i], vz=v[2, i])
    sim.integrator = "leapfrog"
    sim.gravity = "basic"
    sim.softening = 0.0
    sim.dt = dt
    return sim


def _rebound_xv(sim):
    n = sim.N
    xyz, vel = np.empty((n, 3)), np.empty((n, 3))
    sim.serialize_particle_data(xyz=xyz, vxvyvz=vel)
    return np.ascontiguousarray(xyz.T), np.ascontiguousarray(vel.T)


def mutual_rows(cfg, n: int) -> dict:
    """em against REBOUND's leapfrog (direct summation) for n mutually attracting point masses.

    Parameters
    ----------
    cfg : Config
        ``repeat_s`` and ``repeats`` (:data:`emorbit.bench.common.CONFIGS`).
    n : int
        Bodies.

    Returns
    -------
    dict
        ``rows`` ({"em", "rebound leapfrog"}: ms per step in CPU and wall time, steps,
        relative energy error over those steps; REBOUND's ``{"status": "skipped: ..."}``
        where it is not installed), ``em_over_rebound_leapfrog`` (None without REBOUND),
        the virial ratio and the case.
    """
    import emorbit

    from ..effects.mutual import G

    m, x, v, a, total = plummer(n)
    t_dyn = math.sqrt(a**3 / (G * total))
    dt = 1e-4 * t_dyn
    sim = emorbit.Simulation(None, method="em", dt=dt)
    sim.add_effect("mutual")
    points = points_of(sim, x, v)
    points.masses = m.copy()
    runners = {"em": SystemRunner(points, 0.0, np.zeros(3), dt)}
    rows = {}
    try:
        runners["rebound leapfrog"] = ReboundRunner(_rebound_nbody(m, x, v, dt))
    except ImportError as exc:
        rows["rebound leapfrog"] = {"status": f"skipped: {type(exc).__name__}: {exc}"}
    kinetic, potential = _nbody_energy(m, x, v)
    e0 = kinetic + potential
    times = _timed_slow(runners, cfg)
    for name, r in runners.items():
        xs, vs = (points.x, points.v) if name == "em" else _rebound_xv(r.sim)
        stats = times[name]
        rows[name] = {
            "ms_per_step": 1e-3 * stats["cpu_us_per_step"],
            "ms_per_step_wall": 1e-3 * stats["us_per_step"],
            "steps": r.steps,
            "energy_error": abs(sum(_nbody_energy(m, xs, vs)) / e0 - 1.0),
            "samples_cpu_us": stats[CPU],
            "steps_per_call": stats["steps"],
        }
    rows["em"]["newton_sweeps_per_substep"] = float(np.median(runners["em"].sweeps))
    ratio = paired_ratio(times["em"], times["rebound leapfrog"]) if "rebound leapfrog" in times else None
    return {
        "case": (
            f"{n} stars of 1 solar mass in a Plummer sphere (a = 1 pc, 2K/|W| = 1, no softening), free space, "
            f"G = {G:.5e} m^3/(kg s^2), dt = 1e-4 sqrt(a^3/(G M)) = {dt:.4g} s; "
            'em: add_effect("mutual"); REBOUND: leapfrog, gravity = "basic"'
        ),
        "n": n,
        "dt": dt,
        "virial_ratio": 2 * kinetic / abs(potential),
        "rows": rows,
        "em_over_rebound_leapfrog": ratio,
    }
