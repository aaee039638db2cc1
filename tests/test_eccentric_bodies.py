"""Rigid, elastic and coupled bodies in the field on an eccentric orbit at large steps.

On a circular orbit the potential hardly changes, so a wrong g_em changes the energy by
nothing measurable. Here the orbit has e = 0.3 (perigee 7000 km, apogee 13000 km): over an
orbit the potential swings by 0.66 GM/a, so g_em off by a relative 1e-12 (the mutants M3
and R1 of ``scripts/mutants.py``) moves the energy by 1.3e-12 of |E|, a hundred times the
limits below, and 1e-8 (M5) by 1.3e-8. The step is T/100 (99.5 s: 3.6 degrees of orbit at
perigee), a large step for bodies whose elastic modes are far faster than the orbit.
"""

import astropy.constants as const
import numpy as np
import pytest

import emorbit

GM = const.GM_earth.si.value
E = 0.3
RP = 7.0e6
A = RP / (1 - E)
T = 2 * np.pi * np.sqrt(A**3 / GM)
VP = np.sqrt(GM * (1 + E) / RP)
WP = VP / RP  # the orbit's angular rate at perigee


def _sim():
    return emorbit.Simulation(emorbit.CentralField(body="earth"), method="em", dt=T / 100)


def elastic_chain():
    """Two 100 kg point masses joined by a chain of four bars, 100 m along the radius."""
    m, L, n = 100.0, 100.0, 4
    sim = _sim()
    for name, x in (("a", RP - L / 2), ("b", RP + L / 2)):
        sim.add_point(name, mass=m, position=[x, 0, 0], velocity=[0, WP * x, 0])
    sim.add_elastic(
        "tether", "chain", start=[-L / 2, 0, 0], end=[L / 2, 0, 0], elements=n, young=1e9, area=1e-4,
        density=1000.0, position=[RP, 0, 0], velocity=[0, VP, 0], angular_velocity=[0, 0, WP],
        angular_velocity_frame="space",
    )  # fmt: skip
    sim.attach("tether", [0], "a")
    sim.attach("tether", [n], "b")
    return sim


def elastic_block():
    """A soft 2 x 1 x 0.5 m block of 12 tetrahedra, turned 0.3 rad and tumbling slowly."""
    sim = _sim()
    sim.add_elastic(
        "block", "beam", size=[2.0, 1.0, 0.5], elements=[2, 1, 1], young=1e3, poisson=0.3, density=500.0,
        position=[RP, 0, 0], velocity=[0, VP, 0], rotation_vector=[0, 0, 0.3],
        angular_velocity=[0.001, 0.002, WP], angular_velocity_frame="space",
    )  # fmt: skip
    return sim


def coupled_hub_and_boom():
    """A 500 kg rigid box with a 4 m boom of tetrahedra clamped to it, turning a little
    faster than the orbit."""
    sim = _sim()
    w = np.array([0.0, 0.0, WP + 0.001])
    sim.add_rigid(
        "bus", "box", size=[2, 2, 2], mass=500.0, position=[RP, 0, 0], velocity=[0, VP, 0],
        angular_velocity=w, angular_velocity_frame="space",
    )  # fmt: skip
    sim.add_elastic(
        "boom", "beam", size=[4.0, 0.2, 0.2], elements=[4, 1, 1], young=1e3, poisson=0.3, density=1000.0,
        position=[RP + 3.0, 0, 0], velocity=np.array([0, VP, 0]) + np.cross(w, [3.0, 0, 0]),
        angular_velocity=w, angular_velocity_frame="space",
    )  # fmt: skip
    sim.attach("boom", np.flatnonzero(np.isclose(sim.structure._body("boom")["spec"].ref[:, 0], -2.0)), "bus")
    return sim


def rigid_box():
    """A 30 x 2 x 1 m, 1000 kg box, turned and tumbling."""
    sim = _sim()
    sim.add_rigid(
        "box", "box", size=[30.0, 2.0, 1.0], mass=1000.0, position=[RP, 0, 0], velocity=[0, VP, 0],
        rotation_vector=[0.1, 0.2, 0.5], angular_velocity=[0.001, 0.002, 0.01], angular_velocity_frame="space",
    )  # fmt: skip
    return sim


@pytest.mark.parametrize("build", [elastic_chain, elastic_block, coupled_hub_and_boom, rigid_box])
def test_energy_and_angular_momentum_on_an_eccentric_orbit(build):
    """One orbit of 100 em steps. Measured on every body: |dE|/|E0| from 1.1e-15 to 1.5e-15,
    |dL|/|L0| from 3e-16 to 1e-15; limits 1.5e-14 and 1e-14 (10x). With g_em off by 1e-12
    every body reaches 1.32e-12."""
    res = build().run(steps=100, every=1)
    first = res.names[0]
    r = np.linalg.norm(res.si.positions[first], axis=1)
    assert r.max() / r.min() > 1.8, "the run must swing between perigee and apogee"  # 13000 / 7000
    dE = np.abs(res.relative_energy_error()).max()
    dL = res.relative_angular_momentum_error().max()
    assert dE <= 1.5e-14, f"|dE|/|E0| = {dE:.3g}: measured at most 1.5e-15; a g_em off by 1e-12 gives 1.3e-12"
    assert dL <= 1e-14, f"|dL|/|L0| = {dL:.3g}: measured at most 1e-15"
