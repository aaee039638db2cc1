"""Shared set-ups: the paper's orbit (Goettlicher & Schweizerhof)."""

import numpy as np
import pytest

import emorbit
from emorbit import orbits
from emorbit.analysis import relative_energy_change_exact

#: the paper's data: GM = g(r_max) r_max^2, start at aphelion r_max = 10 m with v0
PAPER_GM = 3.9478
PAPER_X0 = np.array([10.0, 0.0, 0.0])
PAPER_V0 = np.array([0.0, 0.36276, 0.0])
#: the paper's period; the rounded v0 gives a Kepler period of 46.47620 s (see test_orbits)
PAPER_T = 46.4758


def paper_sim(method="em", order=2, dt=PAPER_T / 100, center=(0.0, 0.0, 0.0)):
    sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM, center=center), method=method, order=order, dt=dt)
    sim.add_point("satellite", mass=1.0, position=PAPER_X0 + np.asarray(center), velocity=PAPER_V0)
    return sim


def energy_drift_z(roundoff, dt=PAPER_T / 100, steps=1_000_000, members=64, seed=0, device="cpu"):
    """Perturbed copies of the paper's orbit (speeds scaled by 1 + 1e-9 N(0, 1)), one packed
    ensemble, ``steps`` em steps of ``dt``: the ensemble mean of the relative energy error at
    the end in standard errors of that mean (a random walk gives |z| ~ 1; a drift grows like
    sqrt(steps) in these units), and that mean per step. ``device="gpu"`` runs the points
    on a CUDA device (emorbit.sweep.use_device)."""
    rng = np.random.default_rng(seed)
    sim = emorbit.Simulation(emorbit.CentralField(gm=PAPER_GM), method="em", dt=dt, roundoff=roundoff)
    for i in range(members):
        sim.add_point(f"p{i}", mass=1.0, position=PAPER_X0, velocity=PAPER_V0 * (1 + 1e-9 * rng.normal()))
    if device != "cpu":
        from emorbit.sweep import use_device

        use_device(sim, device)
    res = sim.run(steps=steps, every=steps, keep=False)
    x = np.stack([res.si.positions[n] for n in res.names])
    v = np.stack([res.si.velocities[n] for n in res.names])
    # exact: E0 evaluated in float64 carries the same rounding of GM / |x0| in every copy
    rel = relative_energy_change_exact(x[:, 0].T, v[:, 0].T, x[:, -1].T, v[:, -1].T, PAPER_GM)
    return rel.mean() / (rel.std() / np.sqrt(members)), rel.mean() / steps


@pytest.fixture(scope="session")
def paper_kepler_period():
    a = orbits.semi_major_axis(PAPER_X0, PAPER_V0, PAPER_GM)
    return float(orbits.kepler_period(a, PAPER_GM))
