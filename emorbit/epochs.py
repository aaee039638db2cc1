"""The epoch of a run: the instant its time 0 stands for, as an astropy ``Time``.

A run's clock counts seconds of TDB from its epoch (``[integrator] epoch``, or
``Simulation(epoch=...)``), so the effects that follow the calendar, the Sun's and the
Moon's positions from an ephemeris, know where the bodies are. An epoch is given as an
astropy ``Time`` or as a string: an ISO 8601 date and time followed by its time scale,
``"2000-01-01T12:00:00 TDB"`` (scales: TDB, TT, TAI, UTC, TCB, TCG, UT1; UTC where none
is written), or a Julian date ``"JD 2451545.0 TDB"``. It is kept, written to scenes and
stored in run files in TDB with nine decimals of the second (:func:`epoch_text`): an epoch
is rounded to the nanosecond when it is read, so the text reads back to the same instant.
"""

from __future__ import annotations

import warnings

from .errors import EpochWarning, InputError

__all__ = ["SCALES", "to_epoch", "epoch_text"]

#: the time scales an epoch string may end with
SCALES = ("tdb", "tt", "tai", "utc", "tcb", "tcg", "ut1")


def to_epoch(value, key: str = "epoch"):
    """An epoch as a scalar astropy ``Time`` in TDB.

    Parameters
    ----------
    value : astropy.time.Time or str
        A scalar Time, or ``"<ISO date and time> [scale]"``, or ``"JD <number> [scale]"``.
    key : str
        Its name in errors.

    Returns
    -------
    astropy.time.Time
        The instant, scale TDB.

    Raises
    ------
    InputError
        Not a Time or a string, an array of times, an unknown scale or a date that does not
        parse, naming the key and the value.
    """
    from astropy.time import Time

    if isinstance(value, Time):
        if not value.isscalar:
            raise InputError(key, f"one instant expected, got {len(value)} times")
        return _rounded(value)
    if not isinstance(value, str) or not value.strip():
        raise InputError(key, f'a date such as "2000-01-01T12:00:00 TDB" or an astropy Time expected, got {value!r}')
    words = value.split()
    scale = "utc"
    if len(words) > 1 and words[-1].lower() in SCALES:
        scale = words.pop().lower()
    elif len(words) > 1 and words[-1].isalpha():
        raise InputError(
            key, f"unknown time scale {words[-1]!r} in {value!r}; known: {', '.join(s.upper() for s in SCALES)}"
        )
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if words[0].upper() == "JD" and len(words) == 2:
                t = Time(float(words[1]), format="jd", scale=scale)
            elif len(words) == 1:
                t = Time(words[0], scale=scale)
            else:
                t = Time(" ".join(words), scale=scale)
            if t.isscalar:
                t = _rounded(t)
    except (ValueError, TypeError) as exc:
        raise InputError(key, f"{value!r} is not a date and time astropy reads ({_reason(exc)})") from None
    if not t.isscalar:
        raise InputError(key, f"one instant expected, got {value!r}")
    said = " ".join(str(w.message) for w in caught)
    if "after end of day" in said:
        raise InputError(key, f"{value!r} is not a time of that day: second 60 exists only in a leap second")
    if "dubious year" in said:
        warnings.warn(
            f"{key}: {value!r} lies outside the years of the leap-second table, so its offset "
            "between UTC and TDB is extrapolated and may be off by a minute or more",
            EpochWarning,
            stacklevel=2,
        )
    return t


def _rounded(t):
    """The instant in TDB rounded to the nanosecond, as :func:`epoch_text` writes it: the epoch a
    run holds is then exactly the one its file and scene give back (a resumed run samples the
    Sun and the Moon at the same instants)."""
    from astropy.time import Time

    return Time(epoch_text(t)[: -len(" TDB")], scale="tdb")


def epoch_text(epoch) -> str:
    """An epoch as the string that :func:`to_epoch` reads back: ISO 8601 in TDB to 1e-9 s.

    Parameters
    ----------
    epoch : astropy.time.Time
        A scalar time.

    Returns
    -------
    str
        E.g. ``"2000-01-01T12:00:00.000000000 TDB"``.
    """
    t = epoch.tdb.replicate()
    t.precision = 9
    return f"{t.isot} TDB"


def _reason(exc: BaseException) -> str:
    """Why astropy did not read a time, in one line: ERFA's reason ("bad month") where it gave
    one, else the first line of the message (astropy lists every format it tried)."""
    import re

    text = str(exc)
    found = re.search(r'ERFA function "\w+" yielded \d+ of "([^"]+)"', text)
    return found.group(1) if found else (text.strip().splitlines() or [type(exc).__name__])[0].rstrip(":")
