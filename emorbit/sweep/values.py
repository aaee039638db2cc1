"""The values of sweep files: numbers, integers and units, and a value where the base scene
has a quantity. Each error names the key."""

from __future__ import annotations

import math
import numbers

from ..errors import InputError

__all__ = ["check_unit", "number", "integer", "has_unit", "check_quantity"]


def check_unit(unit: str, key: str) -> None:
    """Refuse a unit astropy cannot read."""
    import astropy.units as u

    try:
        u.Unit(unit)
    except (TypeError, ValueError) as exc:
        raise InputError(key, f"cannot read {unit!r} as a unit ({exc})") from None


def number(value, key: str) -> float:
    """A finite number, as given."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise InputError(key, f"a finite number expected, got {value!r}")
    return value


def integer(value, key: str, minimum: int, maximum: int | None = None) -> int:
    """An integer in ``minimum..maximum``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise InputError(key, f"must be an integer >= {minimum}, got {value!r}")
    if maximum is not None and value > maximum:
        raise InputError(key, f"must be an integer <= {maximum:,}, got {value!r}")
    return int(value)


def has_unit(current) -> bool:
    """Whether a scene's value is a quantity (a string with a unit, or a list holding one)."""
    return isinstance(current, str) or (isinstance(current, list) and any(isinstance(c, str) for c in current))


def check_quantity(current, value, key: str, what: str) -> None:
    """Refuse a bare number (or a list holding one) where the base scene has a quantity
    (``current``): every run would fail on it."""
    items = value if isinstance(value, list) else [value]
    if has_unit(current) and any(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in items):
        raise InputError(
            key,
            f"{what} is {value!r}, a number without a unit, where the scene has {current!r}; "
            "write it with its unit, or give the parameter's unit",
        )
