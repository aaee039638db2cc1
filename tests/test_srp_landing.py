"""Radiation pressure's ``land``: steps land on the shadow's edges (emorbit.effects.srp adds the
eclipse events of emorbit.events that split their steps), so that the force is smooth within
every step: compositions keep their order across a cylindrical shadow, the energy balance
stays at round-off, and the edges are logged; the key is checked and stays the effect's own."""

from __future__ import annotations

import numpy as np
import pytest

import emorbit
from emorbit import orbits
from emorbit.errors import InputError

EARTH = emorbit.CentralField(body="earth")
EPOCH = "2026-03-20T00:00:00 TDB"
ELEMENTS = (7000e3, 0.001, 0.3, 0.2, 0.1, 0.5)


def _sim(dt, order, land, shadow="cylindrical", bodies=1):
    sim = emorbit.Simulation(EARTH, dt=dt, order=order, epoch=EPOCH)
    sim.add_effect("srp", shadow=shadow, land=land)
    _points(sim, bodies)
    return sim


def _points(sim, bodies):
    x, v = orbits.state_from_elements(ELEMENTS, EARTH.gm)
    for i in range(bodies):
        sim.add_point(f"sat{i}" if i else "sat", mass=1.0, position=x * (1 + 1e-3 * i), velocity=v,
                      radiation_coefficient=1.0)  # fmt: skip


def _end(dt, order, land, shadow="cylindrical", output=None):
    """A 6000 s run (an orbit and its eclipse) with a radiation coefficient of 1 m^2/kg."""
    res = _sim(dt, order, land, shadow).run(t_end="6000 s", every=int(round(6000 / dt)), progress=False, output=output)
    return res.si.positions["sat"][-1], res


def test_steps_land_on_the_cylindrical_shadows_edges(tmp_path):
    """Against order 8 at 5 s with landing: order 4 at 60, 30, 15 s converges at 4 within 0.3
    with landing (measured 3.99, 3.99) and falls below 2.5 without (measured 1.47: the jump
    inside a step); order 8 at 60 s is within 1e-6 m with landing (measured 1.4e-8 m) and off
    by more than 0.1 m without (0.86 m). The entry and exit are logged as the effect's events,
    and E - E0 - W stays within 1e-14 of E0 (measured 1.8e-16)."""
    ref, _ = _end(5.0, 8, True)
    for land, check in ((True, lambda r: np.all(np.abs(r - 4.0) <= 0.3)), (False, lambda r: r[-1] < 2.5)):
        errors = [np.linalg.norm(_end(dt, 4, land)[0] - ref) for dt in (60.0, 30.0, 15.0)]
        rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
        assert check(rates), (land, rates)
    x, res = _end(60.0, 8, True, output=tmp_path / "land.h5")
    assert np.linalg.norm(x - ref) <= 1e-6
    assert np.linalg.norm(_end(60.0, 8, False)[0] - ref) >= 0.1
    assert [e["label"] for e in res.si.events] == ["srp.cylindrical.sat"] * 2
    assert np.abs(res.si.energy_balance).max() <= 1e-14 * abs(res.si.energy[0])
    assert [e["label"] for e in emorbit.read(tmp_path / "land.h5").si.events] == ["srp.cylindrical.sat"] * 2


def test_the_conical_shadow_lands_on_its_contacts():
    """The penumbra's and the umbra's edges split the steps (its visible fraction still goes as
    delta^(3/2) next to a contact, so a composition converges no faster than h^(5/2) there):
    order 8 at 60 s is 5x closer to the reference with landing (measured 0.073 m against 0.60
    m), and at each logged edge the effect's own shadow function reads 1 (penumbra) or 0."""
    from emorbit.kernels.effects.radiation import shadow_conical

    ref, _ = _end(5.0, 8, True, "conical")
    x, res = _end(60.0, 8, True, "conical")
    assert np.linalg.norm(x - ref) * 5 <= np.linalg.norm(_end(60.0, 8, False, "conical")[0] - ref)
    sim = _sim(60.0, 8, True, "conical")
    (srp,) = [e for e in sim.effects if e.kind == "srp"]
    srp.prepare(0.0, 6000.0, sim.epoch)
    for e in res.si.events:
        edge = e["label"].split(".")[1]
        sun = srp.positions(e["time"])[0]
        nu = shadow_conical(*e["position"], *sun, float(srp.p[2]), float(srp.p[3]))
        assert abs(nu - (1.0 if edge == "penumbra" else 0.0)) <= 1e-6, (e["label"], nu)


@pytest.mark.parametrize(
    "keys, bodies, message",
    [({"land": "yes"}, 1, "true or false"), ({"land": True, "shadow": "none"}, 1, "shadow is none"),
     ({"land": True}, 17, "at most 16")],
)  # fmt: skip
def test_land_is_checked_and_stays_the_effects_own(keys, bodies, message):
    """A land that is not a boolean, land without a shadow, or more bodies than its events allow:
    an error naming effect[0].land. A simulation written back as a scene keeps land and leaves
    out the events the effect adds."""
    with pytest.raises(InputError, match=message) as info:
        sim = emorbit.Simulation(EARTH, dt=60.0, order=2, epoch=EPOCH)
        sim.add_effect("srp", **{"shadow": "cylindrical", **keys})
        _points(sim, bodies)
        sim.run(t_end="60 s", progress=False)
    assert info.value.key == "effect[0].land"
    sim = _sim(60.0, 2, True)
    sim.run(t_end="60 s", progress=False)
    text = sim.to_toml()
    assert "land = true" in text and "[[event]]" not in text
