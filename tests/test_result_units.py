"""A run's :class:`~emorbit.Result` speaks units: its times, invariants, states, field, masses and
elements are astropy Quantities in SI units, for point masses, rigid bodies and elastic bodies,
in memory and read back from the file; ``.value`` and ``result.si`` give the plain SI numbers
the file holds; ratios and counts stay plain; ``energy_range`` defaults to the energy and its
relative error brackets the records' relative error; the plot shades it."""

from __future__ import annotations

import astropy.units as u
import h5py
import numpy as np
import pytest

import emorbit
from emorbit.result import DATASET_UNITS, Result, ResultSI

#: the accessor, the file's dataset and the unit of each recorded quantity
RECORDS = [
    ("time", "time", u.s),
    ("energy", "invariants/energy", u.J),
    ("momentum", "invariants/momentum", u.kg * u.m / u.s),
    ("angular_momentum", "invariants/angular_momentum", u.kg * u.m**2 / u.s),
]

#: a short run of a shipped scene per kind of body: (scene, t_end, body, every)
KINDS = {
    "point": ("paper-ellipse", "9.29516 s", "satellite", 5),
    "rigid": ("rigid-tumbling-box", "20 s", None, 4),
    "elastic": ("elastic-bar-tumbling", None, None, 2),
}


def _run(tmp_path, kind: str, method: str | None = None):
    """The in-memory Result of a few steps of a shipped scene, the Result read from its file,
    and the file's path."""
    name, t_end, _, every = KINDS[kind]
    scene = emorbit.load_scene(name)
    overrides = {"output_every": every}
    if method is not None:
        overrides["method"] = method
    scene = scene.with_overrides(**overrides)
    sim = scene.build()
    path = tmp_path / f"{kind}.h5"
    steps = 8 if t_end is None else None
    res = sim.run(t_end if steps is None else None, steps=steps, every=every, output=path, progress=False)
    return res, emorbit.read(path), path


@pytest.fixture(scope="module", params=list(KINDS))
def runs(request, tmp_path_factory):
    kind = request.param
    res, back, path = _run(tmp_path_factory.mktemp(kind), kind)
    return kind, res, back, path


def _is_quantity(value, unit) -> bool:
    return isinstance(value, u.Quantity) and value.unit == unit


def test_records_are_quantities_in_si_units(runs):
    kind, res, back, path = runs
    assert res.kinds and set(res.kinds.values()) >= {kind}
    for r in (res, back):
        assert len(r) >= 3
        for attr, _, unit in RECORDS:
            assert _is_quantity(getattr(r, attr), unit), attr
        assert _is_quantity(r.energy_range, u.J) and r.energy_range.shape == (len(r), 2)
        assert _is_quantity(r.dt, u.s) and r.dt.isscalar
        assert _is_quantity(r.gm, u.m**3 / u.s**2) and r.gm.isscalar
        assert _is_quantity(r.center, u.m) and r.center.shape == (3,)
        assert set(r.masses) == set(r.names)
        assert all(_is_quantity(m, u.kg) and m.isscalar and m.value > 0 for m in r.masses.values())
        for name in r.names:
            assert _is_quantity(r.positions[name], u.m)
            assert _is_quantity(r.velocities[name], u.m / u.s)
            assert _is_quantity(r.bodies[name]["position"], u.m)
            assert _is_quantity(r.bodies[name]["velocity"], u.m / u.s)
        for name, om in r.angular_velocities.items():
            assert r.kinds[name] == "rigid" and _is_quantity(om, u.rad / u.s)
        for q in r.attitudes.values():  # quaternions have no unit: plain arrays
            assert type(q) is np.ndarray and q.shape == (len(r), 4)
            np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, rtol=1e-12)


def test_body_datasets_carry_their_units(runs):
    kind, res, back, path = runs
    for r in (res, back):
        for name, sets in r.bodies.items():
            for q, a in sets.items():
                if q in DATASET_UNITS:
                    assert _is_quantity(a, DATASET_UNITS[q]), (name, q)
                else:  # quaternions and mesh indices
                    assert not isinstance(a, u.Quantity), (name, q)
    if kind == "rigid":
        assert any("angular_velocity" in s for s in res.bodies.values())
        assert any(_is_quantity(s.get("mass_points/mass"), u.kg) for s in back.bodies.values())
    if kind == "elastic":
        elastic = [n for n, k in back.kinds.items() if k == "elastic"]
        assert elastic
        for n in elastic:
            assert _is_quantity(back.bodies[n]["nodes/position"], u.m)
            assert _is_quantity(back.bodies[n]["nodes/time"], u.s)
            assert _is_quantity(back.bodies[n]["mesh/reference_nodes"], u.m)


def test_value_and_si_are_the_files_numbers(runs):
    kind, res, back, path = runs
    with h5py.File(path, "r") as f:
        for r in (res, back):
            assert isinstance(r.si, ResultSI)
            for attr, dataset, unit in RECORDS:
                stored = f[dataset][()]
                assert u.Unit(f[dataset].attrs["unit"]) == getattr(r, attr).unit == unit, attr
                np.testing.assert_array_equal(getattr(r, attr).value, stored)
                np.testing.assert_array_equal(getattr(r.si, attr), stored)
                assert type(getattr(r.si, attr)) is np.ndarray
            assert r.si.dt == f.attrs["dt"] == r.dt.value and type(r.si.dt) is float
            assert r.si.gm == f.attrs["gm"] == r.gm.value
            np.testing.assert_array_equal(r.si.center, f.attrs["center"])
            if "invariants/energy_range" in f:
                np.testing.assert_array_equal(r.si.energy_range, f["invariants/energy_range"][()])
                np.testing.assert_array_equal(r.energy_range.to_value(u.J), f["invariants/energy_range"][()])
            for name, g in f["bodies"].items():
                assert r.si.masses[name] == g.attrs["mass"] == r.masses[name].to_value(u.kg)
                for q, ds in g.items():
                    if isinstance(ds, h5py.Dataset):
                        np.testing.assert_array_equal(np.asarray(r.bodies[name][q]), ds[()])
                        np.testing.assert_array_equal(r.si.bodies[name][q], ds[()])
                        assert not isinstance(r.si.bodies[name][q], u.Quantity)
                np.testing.assert_array_equal(r.positions[name].value, g["position"][()])
                np.testing.assert_array_equal(r.si.positions[name], g["position"][()])
                np.testing.assert_array_equal(r.si.velocities[name], g["velocity"][()])
                if "angular_velocity" in g:
                    np.testing.assert_array_equal(
                        r.angular_velocities[name].to_value(u.rad / u.s), g["angular_velocity"]
                    )
                    np.testing.assert_array_equal(r.si.attitudes[name], g["attitude"][()])
                if "nodes" in g:
                    np.testing.assert_array_equal(back.si.bodies[name]["nodes/position"], g["nodes/position"][()])


def test_quantities_convert(runs):
    kind, res, back, path = runs
    name = res.names[0]
    np.testing.assert_allclose(res.positions[name].to_value(u.km), res.si.positions[name] / 1000, rtol=1e-15)
    np.testing.assert_allclose(res.time.to_value(u.min), res.si.time / 60, rtol=1e-15)
    np.testing.assert_allclose(res.energy.to_value(u.erg), res.si.energy * 1e7, rtol=1e-15)
    with pytest.raises(u.UnitConversionError):
        res.energy.to(u.m)


def test_ratios_and_counts_stay_plain(runs):
    kind, res, back, path = runs
    for r in (res, back):
        for value in (
            r.relative_energy_error(),
            r.relative_energy_error_range(),
            r.relative_angular_momentum_error(),
            r.newton_iterations,
            r.split_steps,
            r.stalled_solves,
            r.invariant_drift,
            r.drift_bound,
        ):
            assert type(value) is np.ndarray
        assert type(r.mean_newton_iterations()) is float
        assert isinstance(r.method, str) and isinstance(r.order, int)
        np.testing.assert_array_equal(r.relative_energy_error(), r.si.relative_energy_error())
        np.testing.assert_array_equal(r.relative_energy_error_range(), r.si.relative_energy_error_range())


def test_elements_are_quantities(tmp_path):
    res, back, _ = _run(tmp_path, "point")
    for r in (res, back):
        el = r.elements("satellite")
        assert _is_quantity(el.a, u.m) and el.a.shape == (len(r),)
        assert _is_quantity(el.e, u.dimensionless_unscaled)
        for angle in ("i", "raan", "argp", "nu", "M"):
            assert _is_quantity(getattr(el, angle), u.rad), angle
        plain = r.si.elements("satellite")
        for x, y in zip(plain, r.elements("satellite", si=True)):
            np.testing.assert_array_equal(x, y)
        for q, p in zip(el, plain):
            assert type(p) is np.ndarray
            np.testing.assert_array_equal(q.value, p)
        # the paper's ellipse: a = 6 m, e = 2/3
        np.testing.assert_allclose(el.a.to(u.km).value, 0.006, rtol=1e-5)
        assert el.a.to(u.km).unit == u.km
        np.testing.assert_allclose(el.e, 2 / 3, rtol=1e-5)
        np.testing.assert_allclose(el.i.to_value(u.deg), 0.0, atol=1e-12)


def test_energy_range_defaults_to_the_energy():
    n = 4
    energy = np.array([-2.0, -1.9, -2.1, -2.0])
    kw = dict(
        time=np.arange(n, dtype=float),
        energy=energy,
        momentum=np.zeros((n, 3)),
        angular_momentum=np.ones((n, 3)),
        newton_iterations=np.zeros(n),
        bodies={"p": {"position": np.ones((n, 3)), "velocity": np.ones((n, 3))}},
        masses={"p": 2.0},
        kinds={"p": "point"},
        method="em",
        order=2,
        dt=0.5,
        gm=1.0,
        center=np.zeros(3),
    )
    res = Result(**kw)
    np.testing.assert_array_equal(res.si.energy_range, np.stack([energy, energy], axis=1))
    assert _is_quantity(res.energy_range, u.J)
    np.testing.assert_array_equal(res.energy_range.value, res.si.energy_range)
    rel = res.relative_energy_error()
    np.testing.assert_array_equal(res.relative_energy_error_range(), np.stack([rel, rel], axis=1))
    np.testing.assert_allclose(rel, [0.0, 0.05, -0.05, 0.0])
    wider = np.stack([energy - 0.2, energy + 0.4], axis=1)
    res = Result(**kw, energy_range=wider)
    np.testing.assert_allclose(res.relative_energy_error_range(), (wider + 2.0) / 2.0)
    assert res.masses["p"] == 2 * u.kg and res.dt == 500 * u.ms and res.si.dt == 0.5
    with pytest.raises(ValueError, match="energy_range"):
        Result(**kw, energy_range=np.zeros((n, 3)))


def test_relative_energy_error_range_brackets_the_records(tmp_path):
    """The midpoint rule's energy moves between records: the range holds every record's error,
    and it is wider than the records somewhere."""
    res, back, path = _run(tmp_path, "point", method="midpoint")
    for r in (res, back):
        err = r.relative_energy_error()
        band = r.relative_energy_error_range()
        assert band.shape == (len(r), 2)
        assert np.all(band[:, 0] <= err) and np.all(err <= band[:, 1])
        assert np.all(r.energy_range[:, 0] <= r.energy) and np.all(r.energy <= r.energy_range[:, 1])
        np.testing.assert_array_equal(band[0], [0.0, 0.0])
        assert np.any(band[:, 1] - band[:, 0] > 0), "no record interval has a range beyond its record"


def test_plot_shades_the_extremes_between_records(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from emorbit.plot import BAND_LABEL, _plot_energy

    decimated, *_ = _run(tmp_path, "point", method="midpoint")
    every_step = emorbit.load_scene("paper-ellipse-midpoint").build().run("9.29516 s", every=1, progress=False)
    for runs, shaded in (([("a.h5", decimated.si)], True), ([("b.h5", every_step.si)], False)):
        fig, (ax_lin, ax_log) = plt.subplots(1, 2)
        _plot_energy(runs, ax_lin, ax_log, 1e-17)
        for ax in (ax_lin, ax_log):
            labels = ax.get_legend_handles_labels()[1]
            assert (BAND_LABEL in labels) is shaded, labels
            bands = [c for c in ax.collections if c.get_label() != BAND_LABEL]
            assert len(bands) == (1 if shaded else 0)
            if shaded:  # behind the records' line
                assert bands[0].get_zorder() < ax.lines[0].get_zorder()
        plt.close(fig)


def test_analysis_takes_the_quantities_of_a_result():
    """The measurements take a Result's Quantities as they come, in any unit of their kind,
    and give what they give for the plain SI arrays."""
    from emorbit.analysis import apse_times, period_from_apses, period_from_crossings

    res = emorbit.load_scene("paper-ellipse").build().run("150 s", every=1, progress=False)
    x, v = res.positions["satellite"], res.velocities["satellite"]
    plain = period_from_apses(res.si.time, res.si.positions["satellite"], res.si.velocities["satellite"], res.si.gm)
    assert plain[1] >= 2
    assert period_from_apses(res.time, x, v, res.gm, res.center) == plain
    in_km = period_from_apses(res.time.to(u.min), x.to(u.km), v.to(u.km / u.h), res.gm.to(u.km**3 / u.s**2))
    assert in_km[1] == plain[1] and in_km[0] == pytest.approx(plain[0], rel=1e-12)
    np.testing.assert_allclose(
        apse_times(res.time, x.to(u.cm), v, res.gm, apse="periapsis"),
        apse_times(
            res.si.time, res.si.positions["satellite"], res.si.velocities["satellite"], res.si.gm, apse="periapsis"
        ),
        rtol=1e-12,
    )
    sidereal = period_from_crossings(res.time, x.to(u.km), v, res.center)
    assert sidereal[0] == pytest.approx(
        period_from_crossings(res.si.time, res.si.positions["satellite"], res.si.velocities["satellite"])[0], rel=1e-12
    )
    with pytest.raises(u.UnitConversionError):
        period_from_apses(res.time, v, x, res.gm)  # velocities where positions belong


def test_a_simulations_elements_are_quantities_as_a_results():
    """``Simulation.elements`` gives the units ``Result.elements`` gives, and the same values at
    the first record; ``si=True`` gives the plain floats of both."""
    sim = emorbit.load_scene("paper-ellipse").build()
    now, plain = sim.elements("satellite"), sim.elements("satellite", si=True)
    res = sim.run("0.929516 s", every=1, progress=False)
    recorded = res.elements("satellite")
    for name, q in now._asdict().items():
        r = getattr(recorded, name)
        assert isinstance(q, u.Quantity) and q.unit == r.unit and q.isscalar, name
        assert q.value == r.value[0] == getattr(plain, name) and isinstance(getattr(plain, name), float), name
    assert now.a.unit == u.m and now.i.unit == u.rad and now.e.unit == u.dimensionless_unscaled
