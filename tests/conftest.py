"""Shared set-ups: the paper's orbit (Goettlicher & Schweizerhof)."""

import numpy as np
import pytest

import emorbit
from emorbit import orbits

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


@pytest.fixture(scope="session")
def paper_kepler_period():
    a = orbits.semi_major_axis(PAPER_X0, PAPER_V0, PAPER_GM)
    return float(orbits.kepler_period(a, PAPER_GM))
