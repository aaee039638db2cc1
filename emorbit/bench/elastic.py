"""Elastic bodies: cost per step against degrees of freedom (the rows ``emorbit bench`` shows).

A free beam of tetrahedra (cross-section 3 x 3 elements, 0.3 m x 0.3 m, length 0.1 m per
element, E = 70 GPa, nu = 0.3, 2700 kg/m3) tumbling at 1 rad/s, dt = 1e-4 s, from about 140
to 10,000 degrees of freedom. Each size is warmed up (compilation, the Jacobian's pattern,
the first factorisation) and then timed over several steps; the section reports the median
CPU time per step, Newton iterations, factorisations and energy error, and (full
configuration) the time for 100 steps of the largest body against the bench's target for
it: a 10,000-DOF body, 100 steps in <= 10 s. The section ends with a coupled structure's work
against precision, em's compositions beside the time finite element (:mod:`.elastic_precision`).
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["run", "table", "CONFIGS"]

#: elements along the beam for each configuration (DOF = 3 * 16 * (n + 1))
CONFIGS = {
    "tiny": {"lengths": [2, 7], "steps": 3, "repeats": 1, "hundred": False},
    "quick": {"lengths": [2, 7, 20, 62, 207], "steps": 5, "repeats": 3, "hundred": False},
    "full": {"lengths": [2, 7, 20, 62, 207], "steps": 10, "repeats": 3, "hundred": True},
}


def _beam(n: int):
    import emorbit

    sim = emorbit.Simulation(None, method="em", dt=1e-4)
    sim.add_elastic(
        "beam",
        "beam",
        size=[0.1 * n, 0.3, 0.3],
        elements=[n, 3, 3],
        young=7e10,
        poisson=0.3,
        density=2700.0,
        position=[0, 0, 0],
        velocity=[0, 0, 0],
        angular_velocity=[0.0, 0.3, 1.0],
    )
    return sim


def _cpu(fn):
    t0 = time.process_time()
    w0 = time.perf_counter()
    out = fn()
    return out, time.process_time() - t0, time.perf_counter() - w0


def run(quick: bool = True, *, config: str | None = None) -> dict:
    """Measure the section.

    Parameters
    ----------
    quick : bool
        The quick configuration instead of the full one.
    config : str, optional
        ``"full"``, ``"quick"`` or ``"tiny"`` (a smoke run for the tests); overrides ``quick``.

    Returns
    -------
    dict
        JSON-ready: one row per beam length (DOF, tetrahedra, Jacobian nonzeros, Newton
        mode, CPU and wall s per step, iterations, factorisations per step, energy error),
        ``precision`` (:func:`.elastic_precision.run`) and, in the full configuration,
        ``hundred_steps_largest``.
    """
    from . import elastic_precision

    name = config or ("quick" if quick else "full")
    cfg = CONFIGS[name]
    rows = []
    for n in cfg["lengths"]:
        sim = _beam(n)
        sim.run(steps=2, every=2)  # warm-up: compile, build the pattern, first factorisation
        st = sim.structure
        dof = 3 * st.u.shape[0]
        cpu, wall, its = [], [], []
        f0 = st.factorizations
        for _ in range(cfg["repeats"]):
            res, c, w = _cpu(lambda sim=sim: sim.run(steps=cfg["steps"], every=cfg["steps"]))
            cpu.append(c / cfg["steps"])
            wall.append(w / cfg["steps"])
            its.append(res.mean_newton_iterations())
        rows.append(
            {
                "elements_along": n,
                "dof": int(dof),
                "tetrahedra": int(st.tet_node.shape[0]),
                "nnz_jacobian": int(st.J.nnz),
                "newton": st.newton,
                "cpu_s_per_step": float(np.median(cpu)),
                "wall_s_per_step": float(np.median(wall)),
                "newton_iterations": float(np.mean(its)),
                "factorizations_per_step": (st.factorizations - f0) / (cfg["steps"] * cfg["repeats"]),
                "energy_error": float(abs(res.relative_energy_error()).max()),
            }
        )
    out = {
        "name": "elastic",
        "case": "free tumbling beam of tetrahedra, 3 x 3 elements across, dt = 1e-4 s",
        "rows": rows,
        "precision": elastic_precision.run(name),
    }
    if cfg["hundred"]:
        sim = _beam(cfg["lengths"][-1])
        sim.run(steps=1, every=1)
        res, c, w = _cpu(lambda: sim.run(steps=100, every=100))
        out["hundred_steps_largest"] = {
            "dof": rows[-1]["dof"],
            "cpu_s": c,
            "wall_s": w,
            "target_s": 10.0,
            "energy_error": float(abs(res.relative_energy_error()).max()),
        }
    return out


def table(section: dict) -> str:
    """The section as printable rows.

    Parameters
    ----------
    section : dict
        What :func:`run` returned.

    Returns
    -------
    str
        The table, one row per line.
    """
    lines = [
        "elastic bodies: " + section["case"],
        f"{'DOF':>7} {'tets':>6} {'nnz(J)':>9} {'newton':>6} {'ms/step':>9} {'iters':>6} {'factor/step':>11} "
        f"{'|dE/E|':>9}",
    ]
    for r in section["rows"]:
        lines.append(
            f"{r['dof']:>7} {r['tetrahedra']:>6} {r['nnz_jacobian']:>9} {r['newton']:>6} "
            f"{1e3 * r['cpu_s_per_step']:>9.2f} {r['newton_iterations']:>6.2f} "
            f"{r['factorizations_per_step']:>11.2f} {r['energy_error']:>9.1e}"
        )
    h = section.get("hundred_steps_largest")
    if h:
        lines.append(
            f"100 steps at {h['dof']} DOF: {h['cpu_s']:.2f} s CPU ({h['wall_s']:.2f} s wall), "
            f"target <= {h['target_s']:.0f} s"
        )
    if "precision" in section:
        from .elastic_precision import table as precision_table

        lines += precision_table(section["precision"])
    return "\n".join(lines)
