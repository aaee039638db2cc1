"""Third bodies: the Sun's and the Moon's geocentric positions (astropy's builtin ephemeris,
and a JPL kernel through jplephem), the interpolated table, the Kepler body, the GM values,
and the errors naming key and value.

The builtin positions are checked against ERFA's series called directly (the same model by
another path: time scale, axes and units), and against the Sun's and the Moon's distance
ranges. The kernel path reads a small SPK file written here (type 2 segments, linear in
time), so that no ephemeris needs to be downloaded.
"""

from __future__ import annotations

import math
import struct
import sys

import astropy.units as u
import erfa
import numpy as np
import pytest
from astropy.constants import GM_earth, GM_sun
from astropy.time import Time, TimeDelta

from emorbit.effects.ephemeris import (
    GM,
    GM_MOON,
    GM_SUN,
    EphemerisTable,
    kepler_third_body,
    sun_moon_positions,
    sun_moon_states,
)
from emorbit.errors import InputError

AU = 149597870700.0
#: an epoch, TDB (Julian date)
JD0 = 2460371.5


def _times(days, step_days, start=JD0):
    return Time(start, format="jd", scale="tdb") + TimeDelta(np.arange(0.0, days, step_days) * 86400.0, format="sec")


# --- positions ---------------------------------------------------------------------------------


def test_sun_distance_is_one_au_within_the_eccentricity():
    r = np.linalg.norm(sun_moon_positions(_times(366, 1.0), "sun"), axis=1) / AU
    assert r.shape == (366,)
    assert 0.9832 < r.min() < 0.9834 and 1.0166 < r.max() < 1.0168  # perihelion, aphelion


def test_moon_distance_is_within_its_range():
    r = np.linalg.norm(sun_moon_positions(_times(400, 0.25), "moon"), axis=1)
    assert 356e6 < r.min() < 370e6 and 400e6 < r.max() < 407e6
    assert abs(r.mean() - 384.4e6) < 2e6


@pytest.mark.parametrize("body", ["sun", "moon"])
def test_positions_are_erfa_series_in_tdb(body):
    """The builtin model called directly: ``moon98`` (geocentric) and ``-epv00``'s heliocentric
    Earth. The difference of barycentric positions loses ~1 AU * eps = 3e-5 m."""
    t = _times(30, 0.37)
    got = sun_moon_positions(t, body)
    helio, _ = erfa.epv00(t.tdb.jd1, t.tdb.jd2)
    want = erfa.moon98(t.tdb.jd1, t.tdb.jd2)["p"] * AU if body == "moon" else -helio["p"] * AU
    assert got.dtype == np.float64 and got.shape == (len(t), 3)
    assert np.abs(got - want).max() < 1e-3
    # the same instants in another scale give the same positions
    assert np.abs(sun_moon_positions(t.utc, body) - got).max() < 1e-3


@pytest.mark.parametrize("body", ["sun", "moon"])
def test_builtin_states_are_astropys_bit_for_bit(body):
    """ERFA's series called as astropy's builtin ephemeris calls them give astropy's bits, over
    fifty years, from times in TT (so the shipped scenes' datasets do not move)."""
    from astropy.coordinates import get_body_barycentric_posvel

    t = Time(2451545.0 + np.random.default_rng(1).uniform(-9000.0, 9000.0, 2000), format="jd", scale="tt")
    pb, vb = get_body_barycentric_posvel(body, t.tdb, ephemeris="builtin")
    pe, ve = get_body_barycentric_posvel("earth", t.tdb, ephemeris="builtin")
    p, v = sun_moon_states(t, body)
    assert np.array_equal(p, (pb.xyz - pe.xyz).to_value(u.m).T)
    assert np.array_equal(v, (vb.xyz - ve.xyz).to_value(u.m / u.s).T)


def test_builtin_states_do_not_import_astropy_coordinates():
    """astropy.coordinates costs about 0.2 s of a run's start; the builtin path does without."""
    import subprocess

    code = (
        "import sys; from astropy.time import Time; from emorbit.effects.ephemeris import sun_moon_states; "
        "sun_moon_states(Time(2460371.5, format='jd', scale='tdb'), 'moon'); "
        "print('astropy.coordinates' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_scalar_time_and_body_names():
    t = Time(JD0, format="jd", scale="tdb")
    assert sun_moon_positions(t, "Moon").shape == (1, 3)
    assert np.array_equal(sun_moon_positions(t, " SUN "), sun_moon_positions(t, "sun"))
    p, v = sun_moon_states(t, "moon")
    assert p.shape == v.shape == (1, 3) and 900.0 < np.linalg.norm(v) < 1100.0


# --- the interpolated table --------------------------------------------------------------------


@pytest.mark.parametrize(
    "body, step, limit",
    [("moon", 3600.0, 0.05), ("moon", 7200.0, 0.5), ("sun", 6 * 3600.0, 1.0)],
)
def test_table_interpolates_within_its_measured_bound(body, step, limit):
    """Measured over 10 days: the Moon 1.5 cm (1 h) and 0.25 m (2 h), the Sun 0.38 m (6 h)."""
    t0 = Time(JD0, format="jd", scale="tdb")
    table = EphemerisTable(body, t0, t0 + 10 * u.day, step * u.s)
    assert table.error_bound < limit
    rng = np.random.default_rng(11)
    s = rng.uniform(table.start, table.end, 4000)
    direct = sun_moon_positions(table.epoch + TimeDelta(s, format="sec"), body)
    err = np.linalg.norm(table.position(s) - direct, axis=1)
    assert err.max() < 1.0
    assert err.max() <= 1.05 * table.error_bound + 1e-3


def test_table_layout_and_nodes():
    t0 = Time(JD0, format="jd", scale="tdb")
    table = EphemerisTable("moon", t0 + 1 * u.h, t0 + 1 * u.day + 30 * u.min, "1 h", epoch=t0)
    assert table.step == 3600.0 and table.start == pytest.approx(3600.0, abs=1e-9) and table.end >= 86400.0 + 1800.0
    assert table.times.shape == (25,) and table.positions.shape == table.velocities.shape == (25, 3)
    assert np.array_equal(table(table.times), table.positions)  # the nodes are the samples
    assert table.position(5000.0).shape == (3,) and table.position(np.full((2, 4), 5000.0)).shape == (2, 4, 3)
    assert np.allclose(table.position(5000.0 * u.s), table.position(5000.0 / 3600.0 * u.h), rtol=0, atol=1e-6)
    # the velocities are the positions' derivative (the builtin series' own differ by mm/s)
    _, v = sun_moon_states(t0 + TimeDelta(table.times, format="sec"), "moon")
    assert np.abs(table.velocities - v).max() < 0.01
    with pytest.raises(InputError, match="outside") as err:
        table.position(table.end + 1.0)
    assert err.value.key == "t" and repr(table.end + 1.0) in str(err.value)
    assert math.isnan(EphemerisTable("sun", t0, t0 + 1 * u.day, 3600.0, check=False).error_bound)


# --- the Kepler body ---------------------------------------------------------------------------


def test_kepler_body_returns_after_a_period():
    body = kepler_third_body(
        3.986004415e14 * u.m**3 / u.s**2,
        {"a": "384400 km", "e": 0.0549, "i": "5.145 deg", "raan": "10 deg", "argp": "20 deg", "nu": "30 deg"},
        epoch=100.0 * u.s,
        gm_body=GM_MOON,
    )
    assert body.gm == 3.986004415e14 + GM_MOON
    assert body.period == pytest.approx(2 * math.pi * math.sqrt(384400e3**3 / body.gm), rel=1e-12)
    start = body.position(100.0)
    assert np.allclose(start, body.position0, rtol=0, atol=1e-6)
    back = body.position([100.0 + body.period, 100.0 + 7 * body.period])
    assert np.abs(back - start).max() < 1e-10 * 384400e3  # measured: 2e-6 m after 1 period, 1.4e-5 m after 7
    half = body.position(100.0 + 0.5 * body.period)
    assert np.linalg.norm(half) != pytest.approx(np.linalg.norm(start), rel=1e-3)


def test_kepler_body_from_a_tuple_matches_the_table_form():
    gm = 3.986004415e14
    a, e, i, raan, argp, nu = 7000e3, 0.01, 0.5, 1.0, 2.0, 3.0
    one = kepler_third_body(gm, (a, e, i, raan, argp, nu))
    two = kepler_third_body(gm, {"a": a * u.m, "e": e, "i": i * u.rad, "raan": raan, "argp": argp, "nu": nu})
    t = np.linspace(0.0, 20000.0, 7)
    assert np.allclose(one.position(t), two.position(t), rtol=1e-13, atol=0.0)
    assert math.isinf(kepler_third_body(gm, (-7000e3, 1.5, 0.0, 0.0, 0.0, 0.0)).period)


@pytest.mark.parametrize(
    "kwargs, key, shown",
    [
        ({"gm_central": -1.0}, "gm_central", "-1.0"),
        ({"gm_central": "1 km"}, "gm_central", "km"),
        ({"elements": (1.0, 2.0)}, "elements", "(1.0, 2.0)"),
        ({"elements": (7e6, 1.2, 0, 0, 0, 0)}, "elements", "1.2"),
        ({"elements": {"a": "7000 km", "q": 1}}, "elements.q", "not an orbital element"),
        ({"elements": "a=7000 km"}, "elements", "a=7000 km"),
        ({"epoch": "3 m"}, "epoch", "3.0 m"),
        ({"gm_body": -5.0}, "gm_body", "-5.0"),
    ],
)
def test_kepler_body_errors_name_key_and_value(kwargs, key, shown):
    args = {"gm_central": 3.986004415e14, "elements": (7000e3, 0.0, 0.0, 0.0, 0.0, 0.0)} | kwargs
    gm, elements = args.pop("gm_central"), args.pop("elements")
    with pytest.raises(InputError) as err:
        kepler_third_body(gm, elements, **args)
    assert err.value.key == key and shown in str(err.value)


# --- GM values ---------------------------------------------------------------------------------


def test_gm_values():
    assert GM_SUN == GM_sun.si.value == GM["sun"]
    assert GM_MOON == GM["moon"] == 4.902800118e12
    # DE440's Earth/Moon mass ratio, 81.3005682..., from the nominal GM of the Earth
    assert GM_earth.si.value / GM_MOON == pytest.approx(81.30057, rel=1e-6)


# --- errors --------------------------------------------------------------------------------------


def test_errors_name_key_and_value(tmp_path, monkeypatch):
    t0 = Time(JD0, format="jd", scale="tdb")
    cases = [
        (lambda: sun_moon_positions(t0, "mars"), "body", "'mars'"),
        (lambda: sun_moon_positions(JD0, "sun"), "times", str(JD0)),
        (lambda: sun_moon_positions(t0, "sun", ephemeris=str(tmp_path / "de440.bsp")), "ephemeris", "de440.bsp"),
        (lambda: sun_moon_positions(t0, "sun", ephemeris=3), "ephemeris", "3"),
        (lambda: EphemerisTable("venus", t0, t0 + 1 * u.day, 60.0), "body", "'venus'"),
        (lambda: EphemerisTable("sun", t0, t0 - 1 * u.day, 60.0), "t1", "not after"),
        (lambda: EphemerisTable("sun", t0, t0 + 1 * u.day, 0.0), "step", "0.0"),
        (lambda: EphemerisTable("sun", t0, t0 + 1 * u.day, "1 m"), "step", "1.0 m"),
        (lambda: EphemerisTable("sun", JD0, t0 + 1 * u.day, 60.0), "t0", str(JD0)),
        (lambda: EphemerisTable("sun", t0, t0 + 1 * u.day, 60.0, epoch=5.0), "epoch", "5.0"),
    ]
    for call, key, shown in cases:
        with pytest.raises(InputError) as err:
            call()
        assert err.value.key == key and shown in str(err.value), (key, str(err.value))
    # a kernel file without jplephem
    path = tmp_path / "kernel.bsp"
    path.write_bytes(b"\0" * 1024)
    monkeypatch.setitem(sys.modules, "jplephem", None)
    monkeypatch.setitem(sys.modules, "jplephem.spk", None)  # found first where another test imported it
    with pytest.raises(InputError, match="jplephem") as err:
        sun_moon_positions(t0, "moon", ephemeris=path)
    assert err.value.key == "ephemeris" and "kernel.bsp" in str(err.value)


# --- a JPL kernel --------------------------------------------------------------------------------

#: (center, target): constant and linear Chebyshev coefficients (km) over the segment
_SEGMENTS = {
    (0, 3): ([1.0e8, 2.0e7, -3.0e6], [-1.0e6, 2.0e6, 3.0e5]),
    (3, 399): ([-4000.0, 1000.0, 300.0], [100.0, -200.0, 50.0]),
    (3, 301): ([3.0e5, -1.0e5, 2.0e4], [-5.0e3, 8.0e3, 1.0e3]),
    (0, 10): ([-1.0e5, 5.0e5, 2.0e5], [10.0, 20.0, 30.0]),
}


def _write_spk(path, start, end, segments=None):
    """An SPK file (DAF, little-endian) with one type-2 record per segment (``_SEGMENTS``)."""
    from jplephem.daf import DAF, FTPSTR

    record = struct.pack(
        "<8sII60sIII8s603s28s297s",
        *(b"DAF/SPK ", 2, 6, b"emorbit test kernel".ljust(60), 2, 2, 385, b"LTL-IEEE"),
        *(b"\0" * 603, FTPSTR, b"\0" * 297),
    )
    path.write_bytes(record + b"\0" * 1024 + b" " * 1024)
    with open(path, "r+b") as f:
        daf = DAF(f)
        for (center, target), (c0, c1) in (_SEGMENTS if segments is None else segments).items():
            coef = np.stack([c0, c1, np.zeros(3)], axis=1).ravel()
            data = np.concatenate([[0.5 * (start + end), 0.5 * (end - start)], coef, [start, end - start, 11.0, 1.0]])
            daf.add_array(b"emorbit", (start, end, target, center, 1, 2), data)


def _linear(key, s):
    c0, c1 = (np.array(c) for c in _SEGMENTS[key])
    return (c0 + s[:, None] * c1) * 1e3


def test_positions_from_a_jpl_kernel(tmp_path, monkeypatch):
    pytest.importorskip("jplephem")
    start, end = 7.6e8, 7.6e8 + 20 * 86400.0  # s from J2000 (TDB)
    # a name that astropy would read as one to download: the module makes the path absolute
    monkeypatch.chdir(tmp_path)
    _write_spk(tmp_path / "de430.bsp", start, end)
    sec = start + np.array([0.5, 3.0, 10.0, 19.5]) * 86400.0
    t = Time(2451545.0, format="jd", scale="tdb") + TimeDelta(sec, format="sec")
    s = (sec - 0.5 * (start + end)) / (0.5 * (end - start))
    earth = _linear((3, 399), s)
    moon = sun_moon_positions(t, "moon", ephemeris="de430.bsp")
    sun = sun_moon_positions(t, "sun", ephemeris=tmp_path / "de430.bsp")
    assert np.abs(moon - (_linear((3, 301), s) - earth)).max() < 1e-3
    assert np.abs(sun - (_linear((0, 10), s) - _linear((0, 3), s) - earth)).max() < 1e-3
    # positions linear in time: the table interpolates them exactly (to round-off)
    table = EphemerisTable("moon", t[0], t[-1], 6 * 3600.0, ephemeris=tmp_path / "de430.bsp")
    assert table.error_bound < 1e-3
    with pytest.raises(InputError) as err:
        sun_moon_positions(t[0] + 60 * u.day, "moon", ephemeris=tmp_path / "de430.bsp")
    assert err.value.key == "times" and "de430.bsp" in str(err.value)
    # not an SPK file; an SPK file without the Moon
    (tmp_path / "empty.bsp").write_bytes(b"\0" * 1024)
    with pytest.raises(InputError, match="not a JPL kernel") as err:
        sun_moon_positions(t, "moon", ephemeris=tmp_path / "empty.bsp")
    assert err.value.key == "ephemeris" and "empty.bsp" in str(err.value)
    _write_spk(tmp_path / "no-moon.bsp", start, end, {k: v for k, v in _SEGMENTS.items() if k != (3, 301)})
    with pytest.raises(InputError, match="no segments for moon") as err:
        sun_moon_positions(t, "moon", ephemeris=tmp_path / "no-moon.bsp")
    assert err.value.key == "ephemeris"
    assert sun_moon_positions(t, "sun", ephemeris=tmp_path / "no-moon.bsp").shape == (4, 3)


def test_the_third_body_effect_follows_a_jpl_kernel(tmp_path):
    """``[[effect]] kind = "third_body"`` with ``ephemeris`` the path of a kernel takes the
    Moon from it: the path the run samples is the kernel's (linear in time here, which the
    cubic table reproduces to 1e-3 m), not the builtin series', and the balance closes."""
    pytest.importorskip("jplephem")
    import emorbit

    start, end = 7.6e8, 7.6e8 + 20 * 86400.0
    _write_spk(tmp_path / "test.bsp", start, end)
    epoch = Time(2451545.0, format="jd", scale="tdb") + TimeDelta(start + 86400.0, format="sec")
    sim = emorbit.Simulation(emorbit.CentralField(body="earth"), method="em", dt=600.0, epoch=epoch)
    sim.add_effect("third_body", body="moon", ephemeris=str(tmp_path / "test.bsp"))
    sim.add_point("geo", mass=1000.0, position=[42164e3, 0, 0], velocity=[0, 3074.66, 0])
    res = sim.run(steps=144, every=12, progress=False)
    sec = (epoch - Time(2451545.0, format="jd", scale="tdb")).sec + res.time.value
    s = (sec - 0.5 * (start + end)) / (0.5 * (end - start))
    kernel = _linear((3, 301), s) - _linear((3, 399), s)
    path = sim.effects[1].positions(res.time.value)
    assert np.abs(path - kernel).max() < 1e-3
    builtin = sun_moon_positions(epoch + TimeDelta(res.time.value, format="sec"), "moon")
    assert np.linalg.norm(builtin - kernel, axis=1).min() > 1e7  # the synthetic Moon is elsewhere
    assert np.abs(res.energy_balance.value).max() / abs(res.energy[0].value) < 1e-14
