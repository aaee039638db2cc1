"""A run's epoch (emorbit.epochs) read from a string without a time scale: UTC, as astropy reads
the same string and as the docs say, through ``Simulation(epoch=...)``, a scene's
``[integrator] epoch`` and the run file that stores it.

UTC and TDB differ by 69.18 s in 2026 (37 leap seconds, TT - TAI = 32.184 s, TDB - TT within
1.7 ms): a date read in the wrong scale puts the Sun and the Moon of every third-body,
radiation-pressure and NRLMSIS run 69 s off."""

from __future__ import annotations

import numpy as np
import pytest
from astropy.time import Time

import emorbit
from emorbit.scene import parse_scene

#: dates without a scale and astropy's reading of each (its default for ISO and JD is UTC)
DATES = [
    ("2026-03-05T12:00:00", Time("2026-03-05T12:00:00")),
    ("2026-01-01 00:00:00.25", Time("2026-01-01 00:00:00.25")),
    ("JD 2461041.5", Time(2461041.5, format="jd")),
]

SCENE = """
[field]
body = "earth"

[integrator]
method = "em"
dt = "10 s"
t_end = "20 s"
epoch = "{epoch}"

[[body]]
name = "sat"
kind = "point"
mass = "1 kg"
position = ["7000 km", "0 km", "0 km"]
velocity = ["0 km/s", "7.546 km/s", "0 km/s"]
"""


def _seconds(a, b) -> float:
    """a - b in seconds (TDB)."""
    return float((a.tdb - b.tdb).sec)


@pytest.mark.parametrize("text, astropy_time", DATES, ids=["iso", "iso-space", "jd"])
def test_an_epoch_without_a_scale_is_utc_as_astropy_reads_it(text, astropy_time, tmp_path):
    """The epoch of a Simulation, of a scene and of its run file is astropy's reading of the
    string, to the nanosecond an epoch is rounded to (measured 3.6e-10 to 4.6e-10 s); read as TDB
    it would be 69.18 s early."""
    assert astropy_time.scale == "utc"
    sim = emorbit.Simulation(emorbit.CentralField(body="earth"), method="em", dt=10.0, epoch=text)
    assert sim.epoch.scale == "tdb"
    assert abs(_seconds(sim.epoch, astropy_time)) <= 1e-9, f"{text!r} read {_seconds(sim.epoch, astropy_time)} s off"
    assert _seconds(sim.epoch, Time(astropy_time.value, format=astropy_time.format, scale="tdb")) == pytest.approx(
        69.184, abs=2e-3
    )
    scene = parse_scene(SCENE.format(epoch=text)).build()
    assert abs(_seconds(scene.epoch, astropy_time)) <= 1e-9
    path = tmp_path / "run.h5"
    scene.run(t_end=20.0, output=path, progress=False)
    stored = emorbit.read(path).attrs["epoch"]
    assert stored.endswith(" TDB") and abs(_seconds(Time(stored[: -len(" TDB")], scale="tdb"), astropy_time)) <= 1e-9


@pytest.mark.parametrize("scale", ["UTC", "TDB", "TT", "TAI"])
def test_an_epoch_with_a_scale_is_read_in_that_scale(scale):
    """A scale written after the date is the one used: the four readings of one date span the
    69.18 s from UTC to TDB, each equal to astropy's in that scale."""
    sim = emorbit.Simulation(
        emorbit.CentralField(body="earth"), method="em", dt=10.0, epoch=f"2026-03-05T12:00:00 {scale}"
    )
    want = Time("2026-03-05T12:00:00", scale=scale.lower())
    assert abs(_seconds(sim.epoch, want)) <= 1e-9
    utc = Time("2026-03-05T12:00:00", scale="utc")
    offsets = {"UTC": 0.0, "TAI": -37.0, "TT": -69.184, "TDB": -69.184}
    assert np.isclose(_seconds(sim.epoch, utc), offsets[scale], atol=2e-3)
