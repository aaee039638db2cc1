"""Physical values at the edge: astropy Quantities, strings such as ``"3.9478 m3 / s2"`` and
plain SI floats become SI floats, or a clear :class:`~emorbit.errors.InputError` naming the key.

Scenes (TOML) must carry units on every dimensional value (``strict=True``); the Python API
also accepts plain numbers, read as SI (m, s, kg, m/s, m^3/s^2) and, for sizes of
information, bytes (``"10 GB"``, ``"2 GiB"``). A value is finite and at most
:data:`MAX_MAGNITUDE` in magnitude in SI units, so that its square is finite too.
"""

from __future__ import annotations

import math
import numbers

import astropy.units as u
import numpy as np

from .errors import InputError

__all__ = ["to_si", "vector_to_si", "to_count", "information_text", "SI", "MAX_MAGNITUDE"]

#: the largest magnitude of a value in SI units: a square of it stays finite in float64
#: (1e150 m is 1e123 times the size of the observable universe)
MAX_MAGNITUDE = 1e150

#: the SI unit emorbit uses inside, per kind of value
SI = {
    "length": u.m,
    "time": u.s,
    "mass": u.kg,
    "speed": u.m / u.s,
    "acceleration": u.m / u.s**2,
    "force": u.N,
    "gm": u.m**3 / u.s**2,
    "energy": u.J,
    "momentum": u.kg * u.m / u.s,
    "angular_momentum": u.kg * u.m**2 / u.s,
    "angle": u.rad,
    "angular_speed": u.rad / u.s,
    "density": u.kg / u.m**3,
    "area": u.m**2,
    "area_per_mass": u.m**2 / u.kg,
    "pressure": u.Pa,
    "information": u.byte,
    "dimensionless": u.dimensionless_unscaled,
}


def _parse_string(key: str, text: str) -> u.Quantity:
    try:
        return u.Quantity(text)
    except (TypeError, ValueError) as exc:
        raise InputError(key, f"cannot read {text!r} as a number with a unit ({exc})") from None


def to_si(
    value, kind: str, key: str, *, strict: bool = False, positive: bool = False, nonnegative: bool = False
) -> float:
    """Convert one scalar value of a physical kind to a float in SI units.

    Parameters
    ----------
    value : Quantity, str or float
        An astropy Quantity, a string such as ``"3.9478 m3 / s2"``, or a plain number
        (read as SI unless ``strict``).
    kind : str
        A key of :data:`SI` (``"length"``, ``"time"``, ``"gm"``, ...): the unit to convert to.
    key : str
        Where the value came from, named in error messages.
    strict : bool
        A plain number (no unit) is an error instead of being read as SI.
    positive : bool
        The value must be > 0.
    nonnegative : bool
        The value must be >= 0.

    Returns
    -------
    float
        The value in the SI unit of ``kind``.

    Raises
    ------
    InputError
        The value has no unit (``strict``), a unit of another kind, is not a scalar, is not
        finite, is larger than :data:`MAX_MAGNITUDE` in magnitude (in SI units), or breaks
        ``positive`` / ``nonnegative``.
    """
    unit = SI[kind]
    shown = repr(value) if not isinstance(value, u.Quantity) else f"'{value}'"  # the value as given
    if isinstance(value, str):
        q = _parse_string(key, value)
        if q.unit == u.dimensionless_unscaled and unit != u.dimensionless_unscaled:
            raise InputError(key, f"{value!r} has no unit; write it with a unit of {kind}, e.g. '{q.value:g} {unit}'")
        value = q
    if isinstance(value, u.Quantity):
        if not value.isscalar:
            raise InputError(key, f"expected one value, got an array of shape {value.shape}")
        try:
            number = float(
                value.to_value(unit, equivalencies=u.dimensionless_angles() if kind.startswith("angul") else [])
            )
        except u.UnitConversionError:
            raise InputError(key, f"{value} is not a {kind} (expected a unit convertible to {unit})") from None
    elif isinstance(value, numbers.Real) and not isinstance(value, bool):
        if strict:
            raise InputError(key, f"{value!r} has no unit; write it with a unit of {kind}, e.g. '{value} {unit}'")
        number = float(value)
    else:
        raise InputError(
            key, f"expected a {kind} (a Quantity, a string with a unit, or a number in {unit}), got {value!r}"
        )
    if not math.isfinite(number):
        raise InputError(key, f"{shown} is not finite")
    if abs(number) > MAX_MAGNITUDE:
        raise InputError(key, f"{shown} is out of range: values are at most {MAX_MAGNITUDE:g} {unit} in magnitude")
    if positive and not number > 0.0:
        raise InputError(key, f"must be > 0, got {shown}")
    if nonnegative and not number >= 0.0:
        raise InputError(key, f"must be >= 0, got {shown}")
    return number


def vector_to_si(value, kind: str, key: str, *, strict: bool = False) -> np.ndarray:
    """Convert a 3-vector to a float64 array of shape (3,) in SI units.

    Parameters
    ----------
    value : Quantity, ndarray or sequence
        A Quantity of shape (3,), or three scalars as :func:`to_si` accepts them.
    kind : str
        A key of :data:`SI`.
    key : str
        Where the value came from; a component's error names ``key[i]``.
    strict : bool
        Plain numbers (no unit) are errors instead of being read as SI.

    Returns
    -------
    ndarray
        Shape (3,), in the SI unit of ``kind``.

    Raises
    ------
    InputError
        Not three components, or a component that :func:`to_si` refuses.
    """
    if isinstance(value, u.Quantity) and not value.isscalar:
        if value.shape != (3,):
            raise InputError(key, f"expected 3 components, got shape {value.shape}")
        return np.array([to_si(c, kind, f"{key}[{i}]", strict=strict) for i, c in enumerate(value)])
    if isinstance(value, np.ndarray):
        if value.shape != (3,):
            raise InputError(key, f"expected 3 components, got shape {value.shape}")
        value = list(value)
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise InputError(key, f"expected a list of 3 components, got {value!r}")
    if len(value) != 3:
        raise InputError(key, f"expected 3 components, got {len(value)}: {value!r}")
    return np.array([to_si(c, kind, f"{key}[{i}]", strict=strict) for i, c in enumerate(value)])


def to_count(value, key: str, minimum: int = 1, maximum: int | None = None) -> int:
    """Check a count: an integer (not a bool) in [minimum, maximum].

    Parameters
    ----------
    value : object
        The value as given.
    key : str
        Where it came from, named in the error.
    minimum, maximum : int
        The bounds (``maximum`` None: none).

    Returns
    -------
    int
        ``value`` as an int.

    Raises
    ------
    InputError
        Not an integer, or out of bounds.
    """
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Integral)
        or value < minimum
        or (maximum is not None and value > maximum)
    ):
        bounds = f">= {minimum}" if maximum is None else f"in {minimum}..{maximum}"
        raise InputError(key, f"must be an integer {bounds}, got {value!r}")
    return int(value)


def information_text(nbytes: float) -> str:
    """A size of information with a decimal prefix and 3 significant digits, e.g. ``"24.1 GB"``.

    Parameters
    ----------
    nbytes : float
        Bytes.

    Returns
    -------
    str
        The size in B, kB, MB, GB, TB, PB or EB (beyond: EB in exponent form).
    """
    value = float(nbytes)
    for prefix in ("", "k", "M", "G", "T", "P"):
        if abs(value) < 999.5:
            return f"{value:.3g} {prefix}B"
        value /= 1000.0
    return f"{value:.3g} EB"
