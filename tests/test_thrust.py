"""Finite burns (emorbit.effects.thrust): the rocket equation to round-off, the convergence of
the position, the low-thrust spiral against Edelbaum's, the energy balance through a burn, the
landing of steps on its window, resume across it, and the errors naming their keys."""

from __future__ import annotations

import math

import numpy as np
import pytest
from astropy.constants import g0

import emorbit
from emorbit import orbits
from emorbit.errors import InputError

EARTH = emorbit.CentralField(body="earth")
G0 = float(g0.si.value)
BURN = {"body": "craft", "thrust": "1000 N", "isp": "300 s", "start": "100 s", "duration": "500 s"}


def _free(dt=10.0, order=2, **burn):
    """A 1000 kg craft drifting at 100 m/s along x in free space under one burn (inertial,
    along y)."""
    sim = emorbit.Simulation(None, dt=dt, order=order)
    keys = {**BURN, "frame": "inertial", "direction": [0, 2, 0], **burn}
    sim.add_effect("thrust", **{k: v for k, v in keys.items() if v is not None})
    sim.add_point("craft", mass=1000.0, position=[0.0, 0.0, 0.0], velocity=[100.0, 0.0, 0.0])
    return sim


def _rocket(t, m0=1000.0, thrust=1000.0, isp=300.0, start=100.0, end=600.0):
    """The rocket equation's speed and distance along the burn at times t (closed forms)."""
    ve, q = isp * G0, thrust / (isp * G0)
    tau = np.clip(np.asarray(t, float) - start, 0.0, end - start)
    m = m0 - q * tau
    v = ve * np.log(m0 / m)
    s = ve * (tau + (m / q) * np.log(m / m0))
    return v, s + v * (np.asarray(t, float) - start - tau)


def test_the_velocity_follows_the_rocket_equation_to_round_off():
    """dv = isp g0 ln(m0 / m(t)) at every record, within 4 ulp of the 1634 m/s it reaches
    (measured 1 ulp), at orders 2 and 8; the burn's work on the initial mass is m0 v^2 / 2 and
    the energy balance stays within 2 eps of it; without isp dv = T t / m exactly."""
    for order in (2, 8):
        res = _free(order=order).run(t_end="1000 s", every=1, progress=False)
        t = res.si.time
        v = res.si.velocities["craft"]
        exact, _ = _rocket(t)
        assert np.abs(v[:, 1] - exact).max() <= 4 * math.ulp(exact[-1])
        assert np.all(v[:, 0] == 100.0) and np.all(v[:, 2] == 0.0)
        assert res.si.work["thrust"][-1] == pytest.approx(500.0 * exact[-1] ** 2, rel=1e-14)
        assert np.abs(res.si.energy_balance).max() <= 4 * np.finfo(float).eps * 500.0 * exact[-1] ** 2
    sim = emorbit.Simulation(None, dt=10.0)
    sim.add_effect("thrust", body="craft", thrust="20 N", start="0 s", end="300 s", frame="inertial")
    sim.add_point("craft", mass=1000.0, position=[0.0, 0.0, 0.0], velocity=[0.0, 100.0, 0.0])
    res = sim.run(t_end="500 s", every=10, progress=False)
    assert res.si.velocities["craft"][-1, 0] == pytest.approx(20.0 * 300.0 / 1000.0, rel=4 * np.finfo(float).eps)
    (burn,) = [e for e in sim.effects if e.kind == "thrust"]
    assert burn.mass_start == burn.mass_end == 1000.0


def test_the_position_converges_at_the_methods_order():
    """The distance after the burn against the closed form: halving dt from 20 s divides the
    error by 2^order within 0.3 (the window's edges are steps' ends, so the switch costs no
    order), at orders 2 and 4."""
    for order in (2, 4):
        errors = []
        for dt in (20.0, 10.0, 5.0):
            res = _free(dt=dt, order=order).run(t_end="1000 s", every=int(1000 / dt), progress=False)
            _, s = _rocket(res.si.time[-1])
            errors.append(abs(res.si.positions["craft"][-1, 1] - s))
        rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
        assert np.all(np.abs(rates - order) <= 0.3), rates


def test_the_low_thrust_spiral_reaches_edelbaums_radius():
    """The shipped scene: 30 days of 0.1 N along the velocity from a 7000 km circle. The final
    a is Edelbaum's radius from sqrt(mu / r0) - sqrt(mu / r1) = isp g0 ln(m0 / m1) within
    1e-5 of the 512 km it climbs (measured 1.9e-6: 0.95 m), the averaging theory's own error,
    of the order of the eccentricity the thrust forces, a_T / (n^2 a) = 1.2e-5. The energy
    balance stays within 1e-13 of E0 (measured 9e-15)."""
    scene = emorbit.load_scene("low-thrust-spiral")
    sim = scene.build()
    res = sim.run(t_end=scene.t_end, every=scene.output_every, progress=False)
    (burn,) = [e for e in sim.effects if e.kind == "thrust"]
    assert burn.mass_end == pytest.approx(1000.0 - 0.1 / (1500.0 * G0) * 30 * 86400, rel=1e-14)
    dv = 1500.0 * G0 * math.log(burn.mass_start / burn.mass_end)
    r0, mu = 7000e3, EARTH.gm
    r1 = mu / (math.sqrt(mu / r0) - dv) ** 2
    a = res.elements("craft", si=True).a
    assert abs(a[-1] - r1) <= 1e-5 * (r1 - r0)
    assert np.abs(res.si.relative_energy_balance()).max() <= 1e-13


def test_rsw_and_vnc_push_where_they_say():
    """1e-4 m/s^2 for an orbit from a 7000 km circle. rsw's along-track [0, 1, 0] and vnc's
    [1, 0, 0] differ only by the flight-path angle the burn makes (of order e, 1e-6): their
    runs agree within 1e-5 of the 5.1 km the burn moves the craft (measured 7.7e-6). vnc's
    normal [0, 1, 0] tilts the orbit (2.3e-6 rad) and leaves a within 1e-14 (measured 1e-16);
    rsw's radial [1, 0, 0] leaves a within 1e-10 (5e-12) and makes it eccentric."""
    r = 7000e3
    x, v = [r, 0.0, 0.0], [0.0, math.sqrt(EARTH.gm / r), 0.0]

    def run(frame=None, direction=None):
        sim = emorbit.Simulation(EARTH, dt=10.0, order=4)
        sim.add_point("craft", mass=100.0, position=x, velocity=v)
        if frame is not None:
            sim.add_effect("thrust", body="craft", thrust="0.01 N", start="0 s", duration="6000 s", frame=frame,
                           direction=direction)  # fmt: skip
        return sim.run(t_end="6000 s", every=600, progress=False)

    plain = run().si.positions["craft"]
    along = run("rsw", [0, 1, 0]).si.positions["craft"]
    velocity = run("vnc", [1, 0, 0]).si.positions["craft"]
    assert np.abs(along - velocity).max() <= 1e-5 * np.abs(along - plain).max()
    normal = run("vnc", [0, 1, 0])
    el = normal.elements("craft", si=True)
    assert el.i[-1] > 2e-6 and abs(el.a[-1] / r - 1) <= 1e-14
    assert np.abs(normal.si.relative_energy_balance()).max() <= 1e-14
    el = run("rsw", [1, 0, 0]).elements("craft", si=True)
    assert abs(el.a[-1] / r - 1) <= 1e-10 and el.e[-1] > 2e-6


def test_a_burn_with_adaptive_steps_and_the_midpoint_rule():
    """A 0.5 N burn for 3000 s on an orbit of e = 0.1, against em order 8 at dt = 10 s: adaptive
    em (order 4, eta 0.01; steps land on the window's ends, the records' grid) raises a by the
    same 33 km within 1e-5 of it (measured 8.6e-7) and keeps the balance within 1e-13; the
    midpoint rule within 1 % (0.30 %), its energy balance off by the rule's own error, above
    1e-6 (4.5e-4), not round-off."""
    x, v = orbits.state_from_elements((8000e3, 0.1, 0.3, 0.2, 0.1, 0.0), EARTH.gm)
    runs = {}
    for name, keys in (("reference", {"order": 8, "dt": 10.0}), ("adaptive", {"adaptive": 0.01, "order": 4}),
                       ("midpoint", {"method": "midpoint"})):  # fmt: skip
        sim = emorbit.Simulation(EARTH, **{"dt": 60.0, **keys})
        sim.add_point("craft", mass=100.0, position=x, velocity=v)
        sim.add_effect("thrust", body="craft", thrust="0.5 N", start="600 s", end="3600 s")
        res = sim.run(t_end="7200 s", every=10, progress=False)
        runs[name] = (res.elements("craft", si=True).a[-1] - 8000e3, np.abs(res.si.relative_energy_balance()).max())
    climb = runs["reference"][0]
    assert climb > 3e4 and runs["reference"][1] <= 1e-13
    assert abs(runs["adaptive"][0] / climb - 1) <= 1e-5 and runs["adaptive"][1] <= 1e-13
    assert abs(runs["midpoint"][0] / climb - 1) <= 1e-2 and runs["midpoint"][1] >= 1e-6


def test_a_run_resumes_through_a_burn_bit_for_bit(tmp_path):
    """Stopped in the middle of a burn and resumed, the run ends on the bits of an unbroken one."""
    text = emorbit.load_scene("low-thrust-spiral").text.replace('t_end = "30 d"', 't_end = "1 d"')
    unbroken = emorbit.parse_scene(text).build().run(t_end="1 d", every=60, progress=False)
    part = tmp_path / "part.h5"
    emorbit.parse_scene(text).build().run(t_end="10 h", every=60, output=str(part), progress=False)
    emorbit.resume(str(part), "1 d", progress=False)
    again = emorbit.read(str(part))
    assert np.array_equal(again.si.positions["craft"][-1], unbroken.si.positions["craft"][-1])


@pytest.mark.parametrize(
    "keys, where, says",
    [
        ({"end": "50 s", "duration": None}, "effect[0].end", "not after its start"),
        ({"isp": "-300 s"}, "effect[0].isp", ""),
        ({"body": "nobody"}, "body", "nobody"),
        ({"thrust": "0 N"}, "effect[0].thrust", ""),
        ({"thrust": "1e12 N"}, "effect[0].thrust", "at most"),
        ({"frame": "ecef"}, "effect[0].frame", "inertial"),
        ({"direction": [0, 0, 0]}, "effect[0].direction", "other than 0"),
        ({"duration": "5000 s"}, "effect[0].duration", "expels"),
        ({"end": "700 s"}, "effect[0]", "its duration or its end_event"),
        ({"start": "105 s"}, "effect[0]", "between two steps"),
        ({"start_event": "nothing", "start": None}, "effect[0].start_event", "no event labelled"),
        ({"start_event": "x"}, "effect[0]", "start or its start_event"),
        ({"start_event": "x", "start": None, "end": "700 s", "duration": None}, "effect[0].end", "end_event"),
    ],
)
def test_bad_burns_are_refused_naming_the_key(keys, where, says):
    sim = emorbit.Simulation(None, dt=10.0)
    with pytest.raises(InputError) as err:
        sim.add_effect("thrust", **{k: v for k, v in {**BURN, **keys}.items() if v is not None})
        sim.add_point("craft", mass=1000.0, position=[0.0, 0.0, 0.0], velocity=[100.0, 0.0, 0.0])
        sim.run(t_end="1000 s", progress=False)
    assert where in str(err.value) and says in str(err.value)


def test_burns_of_one_body_follow_one_another():
    """A second burn that overlaps the first is refused naming its start; one after it starts
    from the mass the first left."""
    sim = _free()
    sim.add_effect("thrust", **{**BURN, "start": "400 s"})
    with pytest.raises(InputError, match=r"start.*overlaps"):
        sim.run(t_end="1000 s", progress=False)
    sim = _free()
    sim.add_effect("thrust", **{**BURN, "start": "700 s", "duration": "100 s"})
    sim.run(t_end="1000 s", progress=False)
    first, second = sorted((e for e in sim.effects if e.kind == "thrust"), key=lambda e: e.start)
    assert second.mass_start == first.mass_end


def _cube(dt=1.0, order=4, **burn):
    """A 1 m cube of 100 kg drifting at 100 m/s and spinning at 0.01 rad/s about z in free
    space, a 0.1 N thruster at [0.5, 0, 0] m pushing along body y: the torque is along z."""
    sim = emorbit.Simulation(None, dt=dt, order=order)
    burn = {"point": ["0.5 m", "0 m", "0 m"], "direction": [0, 1, 0], **burn}
    sim.add_effect("thrust", body="box", thrust="0.1 N", start="0 s", end="100 s", **burn)
    sim.add_rigid("box", "box", size=[1.0, 1.0, 1.0], mass=100.0, position=[0.0, 0.0, 0.0],
                  velocity=[100.0, 0.0, 0.0], angular_velocity=[0.0, 0.0, 0.01])  # fmt: skip
    return sim


def test_a_thruster_off_a_rigid_bodys_centre_turns_it_by_r_cross_f():
    """A 0.1 N thruster 0.5 m off the centre of a 100 kg cube spins it up about z for 100 s:
    the spin converges to that of the torque r x F, 0.01 + r m0 dv / I_zz (I from its mass
    points; dv = T t / m0, or with isp the rocket equation's, the body losing mass evenly), at
    the method's order (halving dt from 1 s: rates within 0.1 of 2 and 4; measured 1.98-4.00).
    Its spin stays about z, and E - E0 - W stays within 1e-14 of the kinetic energy (measured
    2e-16)."""
    for burn in ({}, {"isp": "200 s"}):
        for order in (2, 4):
            errors = []
            for dt in (1.0, 0.5, 0.25):
                sim = _cube(dt=dt, order=order, **burn)
                res = sim.run(t_end="100 s", every=int(100 / dt), progress=False)
                E = sim.rigid.E[0]
                izz = float(np.trace(E) - E[2, 2])
                (b,) = [e for e in sim.effects if e.kind == "thrust"]
                dv = 0.1 * 100.0 / 100.0 if not burn else 200.0 * G0 * math.log(b.mass_start / b.mass_end)
                w = res.si.angular_velocities["box"]
                errors.append(abs(w[-1, 2] - (0.01 + 0.5 * 100.0 * dv / izz)))
                assert np.abs(w[:, :2]).max() <= 1e-14
                assert np.abs(res.si.relative_energy_balance()).max() <= 1e-14
            rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
            assert np.all(np.abs(rates - order) <= 0.1), rates


def test_a_rigid_bodys_burn_in_orbit_beside_drag_and_in_a_structure():
    """A 0.5 N burn at isp 300 s through a thruster 1 mm off the centre of a box in LEO, with
    drag on its faces, and again with mutual gravity towards a point mass (the box then steps
    in a structure): E - E0 - W within 1e-14 (measured 3e-16) on both paths, the spin-up
    about z the same within 1e-6 (the paths' solvers differ in their iterations)."""
    runs = []
    for pair in ("drag", "mutual"):
        sim = emorbit.Simulation(EARTH, dt=10.0, order=2)
        sim.add_effect(pair, **({"atmosphere": "ussa1976"} if pair == "drag" else {}))
        sim.add_effect("thrust", body="box", thrust="0.5 N", isp="300 s", start="100 s", end="1000 s",
                       point=["0.001 m", "0.0002 m", "0 m"], direction=[0, 1, 0])  # fmt: skip
        sim.add_rigid("box", "box", size=[1.0, 1.0, 1.0], mass=100.0, position=[6778e3, 0.0, 0.0],
                      velocity=[0.0, 7668.0, 0.0], angular_velocity=[0.0, 0.0, 0.001])  # fmt: skip
        sim.add_point("p", mass=10.0, position=[6778e3, 1e3, 0.0], velocity=[0.0, 7668.0, 0.0],
                      **({"ballistic_coefficient": 0.01} if pair == "drag" else {}))  # fmt: skip
        res = sim.run(t_end="1500 s", every=10, progress=False)
        assert np.abs(res.si.relative_energy_balance()).max() <= 1e-14
        assert res.si.work["thrust"][-1] > 0.0
        runs.append(res.si.angular_velocities["box"][-1, 2])
    assert runs[0] == pytest.approx(runs[1], rel=1e-6) and runs[0] > 0.02


def test_a_burn_between_two_events():
    """A burn that starts at an event and lasts a duration: its step is split at the event
    (1003.7 s, between steps' ends) and at its end (the added time event ``go.end``), the
    velocity follows the rocket equation within 8 ulp (measured 4). In orbit, a burn from the apoapsis to
    the next periapsis: it starts at the apoapsis's logged time, ends at the periapsis's, and
    E - E0 - W stays within 1e-13 of E0."""
    sim = _free(start_event="go", duration="500 s", start=None)
    sim.add_event("time", value="1003.7 s", label="go")
    res = sim.run(t_end="2000 s", every=10, progress=False)
    (b,) = [e for e in sim.effects if e.kind == "thrust"]
    assert [(e["label"], e["time"]) for e in res.si.events] == [("go", 1003.7), ("go.end", 1003.7 + 500.0)]
    assert (b.start, b.end) == (1003.7, 1503.7)
    exact = 300.0 * G0 * math.log(b.mass_start / b.mass_end)
    assert abs(res.si.velocities["craft"][-1, 1] - exact) <= 8 * math.ulp(exact)
    sim = emorbit.Simulation(EARTH, dt=20.0, order=4)
    x, v = orbits.state_from_elements((8000e3, 0.1, 0.3, 0.2, 0.1, 0.5), EARTH.gm)
    sim.add_point("craft", mass=100.0, position=x, velocity=v)
    sim.add_event("apoapsis", body="craft", label="apo")
    sim.add_event("periapsis", body="craft", label="peri", after="apo")
    sim.add_effect("thrust", body="craft", thrust="1 N", isp="220 s", start_event="apo", end_event="peri")
    res = sim.run(t_end="12000 s", every=10, progress=False)
    (b,) = [e for e in sim.effects if e.kind == "thrust"]
    times = {e["label"]: e["time"] for e in res.si.events}
    assert (b.start, b.end) == (times["apo"], times["peri"]) and b.mass_end < b.mass_start
    assert np.abs(res.si.relative_energy_balance()).max() <= 1e-13


def test_a_run_resumes_through_a_burn_started_by_an_event(tmp_path):
    """Stopped after an event started a burn, the resumed run (its log replayed: the burn
    starts again at the logged time, its end event added) ends on an unbroken run's bits."""

    def build():
        sim = _free(start_event="go", duration="500 s", start=None)
        sim.add_event("time", value="1003.7 s", label="go")
        return sim

    unbroken = build().run(t_end="2000 s", every=10, progress=False)
    part = tmp_path / "part.h5"
    build().run(t_end="1200 s", every=10, output=str(part), progress=False)
    emorbit.resume(str(part), "2000 s", progress=False)
    again = emorbit.read(str(part))
    assert np.array_equal(again.si.positions["craft"][-1], unbroken.si.positions["craft"][-1])
    assert [e["label"] for e in again.si.events] == ["go", "go.end"]


def _beam(**burn):
    """A soft 2 m beam of tetrahedra drifting at 100 m/s in free space, a 1 N burn on node 0
    from 0 to 10 s along inertial y."""
    sim = emorbit.Simulation(None, dt=0.5, order=2)
    sim.add_effect("thrust", **{"body": "beam", "thrust": "1 N", "start": "0 s", "end": "10 s", "node": 0,
                                "frame": "inertial", "direction": [0, 1, 0], **burn})  # fmt: skip
    sim.add_elastic("beam", "beam", size=[2.0, 0.5, 0.5], elements=[2, 1, 1], young=1e6, poisson=0.3,
                    density=100.0, position=[0.0, 0.0, 0.0], velocity=[100.0, 0.0, 0.0])  # fmt: skip
    return sim


def test_a_burn_pushes_an_elastic_body_at_its_node():
    """1 N on node 0 of a beam for 10 s: its momentum grows by exactly 10 N s along y (within
    1e-12 relative; measured 2e-15), the burn's work is the energy it gains (E - E0 - W within
    1e-14 of E0)."""
    res = _beam().run(t_end="20 s", every=4, progress=False)
    p = res.si.momentum
    assert p[-1, 1] == pytest.approx(10.0, rel=1e-12) and abs(p[-1, 0] - p[0, 0]) <= 1e-12 * abs(p[0, 0])
    assert np.abs(res.si.relative_energy_balance()).max() <= 1e-14
    assert res.si.work["thrust"][-1] > 0.0


@pytest.mark.parametrize(
    "burn, where",
    [({"node": 99}, "effect[0].node"), ({"isp": "300 s"}, "effect[0].isp"), ({"node": -1}, "effect[0].node"),
     ({"frame": "body"}, "effect[0].frame")],
)  # fmt: skip
def test_bad_burns_on_an_elastic_body_name_the_key(burn, where):
    with pytest.raises(InputError) as err:
        _beam(**burn).run(t_end="1 s", progress=False)
    assert where in str(err.value)


def test_a_burn_on_a_rigid_body_is_fixed_in_it():
    """A rigid body's burn takes frame "body" (its default); rsw is refused naming frame, and
    a point mass refuses body axes and a thruster point."""
    sim = _cube(frame="rsw")
    with pytest.raises(InputError, match="frame"):
        sim.run(t_end="10 s", progress=False)
    sim = emorbit.Simulation(EARTH, dt=10.0)
    sim.add_point("craft", mass=100.0, position=[7e6, 0.0, 0.0], velocity=[0.0, 7.5e3, 0.0])
    sim.add_effect("thrust", **{**BURN, "point": ["1 m", "0 m", "0 m"]})
    with pytest.raises(InputError, match=r"effect\[0\]\.point"):
        sim.run(t_end="1000 s", progress=False)


def test_the_plot_draws_the_altitude_of_a_burn(tmp_path):
    """emorbit plot of a run whose effects do work (a burn, no events) adds the altitude against
    time: one day of the spiral climbs by 17 km (Edelbaum's rate, 2 a_T sqrt(a^3 / mu) a day)."""
    import matplotlib.pyplot as plt

    from emorbit.plot import draw_runs

    text = emorbit.load_scene("low-thrust-spiral").text
    scene = emorbit.parse_scene(text)
    scene.build().run(t_end="1 d", every=10, output=str(tmp_path / "climb.h5"), progress=False)
    fig = draw_runs([("climb.h5", emorbit.read(str(tmp_path / "climb.h5")).si)])
    titles = [ax.get_title() for ax in fig.axes]
    ax = fig.axes[titles.index("altitude above the field's radius; dotted: events")]
    h = ax.lines[0].get_ydata()
    rate = 2 * 1e-4 * math.sqrt(7000e3**3 / EARTH.gm) * 86400 / 1e3  # km a day
    assert h[-1] - h[0] == pytest.approx(rate, rel=0.05)
    plt.close(fig)


def test_a_burn_that_would_outlast_its_mass_stops_the_run_naming_end_event(tmp_path):
    """A burn that ends at an event expels mass until then: where 99.9 % of the body's mass is
    gone first (the time event ``thrust.empty``), the run stops with an error naming end_event,
    and the file keeps its records, marked failed."""
    sim = _free(start=None, duration=None, isp="30 s", start_event="go", end_event="never")
    sim.add_event("time", value="100 s", label="go")
    sim.add_event("time", value="1e6 s", label="never")
    with pytest.raises(InputError, match=r"effect\[0\]\.end_event: the burn has expelled 99\.9 %"):
        sim.run(t_end="2000 s", every=10, output=str(tmp_path / "empty.h5"), progress=False)
    res = emorbit.read(str(tmp_path / "empty.h5"))
    assert res.attrs["status"] == "failed" and res.time[-1].to_value("s") == 300.0


def _ledger_exact(t_burn, m0=1000.0, thrust=1000.0, isp=300.0, drift=100.0, spin=0.0):
    """The ledger of a burn in free space from rest along its direction (closed forms), with a
    drift speed across it and a specific spin energy that the expelled mass takes along: the
    body's energy m v^2 / 2, the thrust's work T int v dt and the expelled energy q int eps dt."""
    ve, q = isp * G0, thrust / (isp * G0)
    mu = (m0 - q * t_burn) / m0
    v = ve * math.log(1.0 / mu)
    along = 0.5 * ve**2 * m0 * (2.0 - mu * math.log(mu) ** 2 + 2.0 * mu * math.log(mu) - 2.0 * mu)
    expelled = along + (m0 - mu * m0) * (0.5 * drift**2 + spin)
    work = thrust * (ve * m0 / q) * (1.0 - mu + mu * math.log(mu))
    return mu * m0 * (0.5 * (v * v + drift**2) + spin), work, expelled


def test_the_mass_ledger_splits_the_energy_a_burn_moves():
    """A burn that expels 170 kg of a 1000 kg craft in free space: the run's ledger gives the
    craft's energy at its true mass to 1e-14 of the closed form, the thrust's work on it and the
    energy the propellant carries away (its kinetic energy as it leaves: 8.96 MJ, the craft keeping
    128.8 MJ)
    converging to theirs at the method's order (halving dt from 20 s: rates within 0.3 of 2),
    and E_b - E_b0 - W_b + X within 4 eps of E_b (measured 2.3e-16)."""
    energy, work, expelled = _ledger_exact(500.0)
    errors = []
    for dt in (20.0, 10.0, 5.0):
        res = _free(dt=dt).run(t_end="1000 s", every=int(100 / dt), progress=False)
        ledger = res.si.ledger
        assert ledger["energy"][-1] == pytest.approx(energy, rel=1e-14)
        assert np.abs(ledger["balance"]).max() <= 4 * np.finfo(float).eps * energy
        assert ledger["energy"][0] == pytest.approx(0.5 * 1000.0 * 100.0**2, rel=1e-15)
        errors.append([abs(ledger["work"][-1] - work), abs(ledger["expelled"][-1] - expelled)])
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(rates - 2.0) <= 0.3), rates
    assert errors[-1][1] <= 1e-4 * expelled


def test_the_mass_ledger_read_back_and_beside_drag(tmp_path):
    """The ledger in the run file (``invariants/ledger_*``) as in memory; a craft under drag
    and J2 in LEO with a 2 N burn at isp 220 s, beside a point mass that no burn lightens: the
    balance within 1e-14 of the energy (measured 6e-16), the work on the craft at its true mass
    below the work at its initial mass, and its energy raised by the mass it lost (bound, the
    propellant leaves with negative energy: -54 MJ)."""
    sim = emorbit.Simulation(EARTH, dt=10.0, order=4)
    sim.add_effect("drag", atmosphere="ussa1976")
    sim.add_effect("zonal", model="earth", degree=2)
    sim.add_effect("thrust", body="craft", thrust="2 N", isp="220 s", start="300 s", end="2300 s", frame="vnc")
    x, v = orbits.state_from_elements((6778e3, 0.001, 0.9, 0.2, 0.1, 0.5), EARTH.gm)
    for name in ("craft", "other"):
        sim.add_point(name, mass=50.0, position=x * (1.0 if name == "craft" else 1.001), velocity=v,
                      ballistic_coefficient=0.01)  # fmt: skip
    res = sim.run(t_end="3000 s", every=30, progress=False, output=tmp_path / "run.h5")
    back = emorbit.read(tmp_path / "run.h5")
    for name, value in res.si.ledger.items():
        assert np.array_equal(back.si.ledger[name], value), name
    ledger = res.si.ledger
    assert np.abs(ledger["balance"]).max() <= 1e-14 * abs(res.si.energy[0])
    assert np.abs(res.si.energy_balance).max() <= 1e-14 * abs(res.si.energy[0])
    (burn,) = [e for e in sim.effects if e.kind == "thrust"]
    lost = (burn.mass_start - burn.mass_end) / 50.0
    assert 0.0 < ledger["work"][-1] < sum(w[-1] for w in res.si.work.values())
    assert ledger["energy"][-1] - res.si.energy[-1] == pytest.approx(-lost * res.si.energy[-1] / 2, rel=0.01)


def test_the_mass_ledger_of_a_rigid_body():
    """A cube spinning at 0.01 rad/s pushed along its spin axis through its centre at isp 200 s
    in free space: it
    loses its mass evenly, so the expelled mass takes its share of the spin energy too; the
    ledger's energy, work and expelled energy against the closed forms within 1e-4 at dt =
    0.25 s (measured 6e-11), the balance within 4 eps (measured 2e-17)."""
    sim = _cube(dt=0.25, order=2, isp="200 s", point=[0, 0, 0], direction=[0, 0, 1])
    res = sim.run(t_end="100 s", every=400, progress=False)
    E = sim.rigid.E[0]
    spin = 0.5 * 0.01**2 * float(np.trace(E) - E[2, 2]) / 100.0
    energy, work, expelled = _ledger_exact(100.0, m0=100.0, thrust=0.1, isp=200.0, spin=spin)
    ledger = res.si.ledger
    assert ledger["energy"][-1] == pytest.approx(energy, rel=1e-12)
    assert ledger["work"][-1] == pytest.approx(work, rel=1e-4)
    assert ledger["expelled"][-1] == pytest.approx(expelled, rel=1e-4)
    assert np.abs(ledger["balance"]).max() <= 4 * np.finfo(float).eps * energy
