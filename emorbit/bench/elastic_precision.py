"""A coupled structure's work against precision: em's compositions beside the time finite element.

The case: a 500 kg box (2 x 1.5 x 1 m) with a 4 m boom of tetrahedra (2 x 1 x 1 cells, 0.2 m
x 0.2 m, E = 1e4 Pa, nu = 0.3, 1000 kg/m3, 160 kg) clamped to its +x face, tumbling at (0.3,
0.5, 2) rad/s in free space for 1 s: a rigid body's axes, the clamp and large elastic motion
together (:func:`bus_boom`). Each method and order runs at several dt; a point's error is the
largest difference of any slot (nodes, the box's centre and axes) from ``method = "tfe"`` at
order 6 and dt = 0.625 ms, in m (the axes' entries weigh as metres), beside the box's angular
velocity error (rad/s), the energy error and the CPU time of the run (after a one-step run of
the same configuration has compiled its kernels). For each precision in :data:`PRECISIONS`
the section gives the least CPU time of em (any order) and of tfe that reaches it, and their
ratio, both measured in the same run. Part of the ``elastic`` section (:mod:`.elastic`).
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["CONFIGS", "PRECISIONS", "bus_boom", "run", "table"]

#: the box's angular velocity at the start, rad/s (space frame)
SPIN = (0.3, 0.5, 2.0)
#: the position errors (m) the summary asks each method for
PRECISIONS = (1e-5, 1e-7)
#: (method, order, dts in s) per configuration; ``reference`` is tfe order 6's dt, ``t`` the span
CONFIGS = {
    "tiny": {"t": 0.2, "reference": 0.005, "series": (("em", 2, (0.02,)), ("tfe", 4, (0.02,)))},
    "quick": {
        "t": 1.0,
        "reference": 0.000625,
        "series": (
            ("em", 2, (0.01, 0.005, 0.0025)),
            ("em", 4, (0.02, 0.01, 0.005)),
            ("em", 6, (0.02, 0.01, 0.005)),
            ("tfe", 4, (0.02, 0.01, 0.005)),
            ("tfe", 6, (0.04, 0.02, 0.01, 0.005)),
            ("tfe", 8, (0.04, 0.02, 0.01)),
        ),
    },
    "full": {
        "t": 1.0,
        "reference": 0.000625,
        "series": (
            ("em", 2, (0.01, 0.005, 0.0025, 0.00125)),
            ("em", 4, (0.02, 0.01, 0.005, 0.0025)),
            ("em", 6, (0.02, 0.01, 0.005, 0.0025)),
            ("tfe", 4, (0.02, 0.01, 0.005, 0.0025)),
            ("tfe", 6, (0.04, 0.02, 0.01, 0.005, 0.0025)),
            ("tfe", 8, (0.04, 0.02, 0.01, 0.005)),
        ),
    },
}


def bus_boom(dt, order, young=1e4, method="tfe", **kw):
    """The case's simulation (module notes); ``young`` in Pa (at 1e4 its fastest elastic mode
    is resolved by steps of 10 ms, at 1e6 it is not), ``kw`` to :class:`emorbit.Simulation`."""
    import emorbit

    w = np.array(SPIN)
    sim = emorbit.Simulation(None, method=method, dt=dt, order=order, **kw)
    sim.add_rigid(
        "bus", "box", size=[2, 1.5, 1], mass=500.0, position=[0, 0, 0], velocity=[0, 0, 0], angular_velocity=w,
        angular_velocity_frame="space",
    )  # fmt: skip
    sim.add_elastic(
        "boom", "beam", size=[4.0, 0.2, 0.2], elements=[2, 1, 1], young=young, poisson=0.3, density=1000.0,
        position=[3.0, 0, 0], velocity=np.cross(w, [3.0, 0, 0]), angular_velocity=w, angular_velocity_frame="space",
    )  # fmt: skip
    face = np.flatnonzero(np.isclose(sim.structure._body("boom")["spec"].ref[:, 0], -2.0))
    sim.attach("boom", face, "bus")
    return sim


def end_state(method, order, dt, t):
    """Run the case for ``t`` s: (slots (n, 3), the box's angular velocity (3,) rad/s, the
    energy error, CPU s of the run)."""
    steps = int(round(t / dt))
    bus_boom(dt, order, method=method).run(steps=1, every=1, progress=False)  # compile
    sim = bus_boom(dt, order, method=method)
    t0 = time.process_time()
    res = sim.run(steps=steps, every=steps, progress=False)
    cpu = time.process_time() - t0
    st = sim.structure
    omega = res.angular_velocities["bus"][-1].value
    return st.u - st.cu, omega, float(np.abs(res.relative_energy_error()).max()), cpu


def run(config: str = "quick") -> dict:
    """Measure the case.

    Parameters
    ----------
    config : str
        ``"full"``, ``"quick"`` or ``"tiny"`` (a smoke run for the tests).

    Returns
    -------
    dict
        JSON-ready: ``case``, ``reference``, ``points`` (method, order, dt, CPU s, position,
        angular velocity and energy errors) and ``summary`` (per precision, the least CPU
        time of em and of tfe that reach it, and em's over tfe's; None where one does not).
    """
    cfg = CONFIGS[config]
    ref_u, ref_w, _, _ = end_state("tfe", 6, cfg["reference"], cfg["t"])
    points = []
    for method, order, dts in cfg["series"]:
        for dt in dts:
            u, w, energy, cpu = end_state(method, order, dt, cfg["t"])
            points.append(
                {
                    "method": method,
                    "order": order,
                    "dt": dt,
                    "cpu_s": cpu,
                    "position_error": float(np.abs(u - ref_u).max()),
                    "omega_error": float(np.abs(w - ref_w).max()),
                    "energy_error": energy,
                }
            )
    summary = []
    for eps in PRECISIONS:
        best = {}
        for m in ("em", "tfe"):
            cpus = [p["cpu_s"] for p in points if p["method"] == m and p["position_error"] <= eps]
            best[m] = min(cpus) if cpus else None
        ratio = best["em"] / best["tfe"] if best["em"] and best["tfe"] else None
        summary.append({"precision_m": eps, "em_cpu_s": best["em"], "tfe_cpu_s": best["tfe"], "em_over_tfe": ratio})
    case = (
        f"a 500 kg box with a 4 m boom of tetrahedra clamped to it (E = 1e4 Pa), tumbling at {SPIN} rad/s in free "
        f"space for {cfg['t']:g} s, against tfe order 6 at dt = {1e3 * cfg['reference']:g} ms"
    )
    return {"case": case, "reference_dt": cfg["reference"], "points": points, "summary": summary}


def table(section: dict) -> list[str]:
    """The measured points and the summary as printable lines."""
    lines = [
        "coupled structure, work against precision: " + section["case"],
        f"{'method':>8} {'order':>5} {'dt, ms':>7} {'CPU s':>7} {'pos err, m':>11} {'omega err':>10} {'|dE/E|':>8}",
    ]
    for p in section["points"]:
        lines.append(
            f"{p['method']:>8} {p['order']:>5} {1e3 * p['dt']:>7.3g} {p['cpu_s']:>7.2f} {p['position_error']:>11.2e} "
            f"{p['omega_error']:>10.2e} {p['energy_error']:>8.1e}"
        )
    for s in section["summary"]:
        em = "-" if s["em_cpu_s"] is None else f"{s['em_cpu_s']:.2f} s"
        tfe = "-" if s["tfe_cpu_s"] is None else f"{s['tfe_cpu_s']:.2f} s"
        ratio = "" if s["em_over_tfe"] is None else f", em / tfe = {s['em_over_tfe']:.2f}x"
        lines.append(f"to {s['precision_m']:g} m: em {em}, tfe {tfe}{ratio}")
    return lines
