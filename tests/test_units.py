"""Values at the edge: Quantities, strings with units and SI floats."""

import astropy.units as u
import numpy as np
import pytest

from emorbit.errors import InputError
from emorbit.units import to_si, vector_to_si


def test_accepts_quantities_strings_and_floats():
    assert to_si(1 * u.km, "length", "x") == 1000.0
    assert to_si("3.9478 m3 / s2", "gm", "gm") == 3.9478
    assert to_si("1 d", "time", "t") == 86400.0
    assert to_si(2.5, "time", "t") == 2.5
    assert to_si(np.float64(2.5), "time", "t") == 2.5
    np.testing.assert_array_equal(vector_to_si([1, 2, 3] * u.km, "length", "p"), [1000.0, 2000.0, 3000.0])
    np.testing.assert_array_equal(vector_to_si(["1 m", "2 km", "0 m"], "length", "p"), [1.0, 2000.0, 0.0])


@pytest.mark.parametrize(
    "value, kind, needle",
    [
        ("10", "length", "no unit"),
        ("10 s", "length", "not a length"),
        ("ten m", "length", "cannot read"),
        ("nan m", "length", "not finite"),
        (True, "length", "expected a length"),
        ([1, 2] * u.m, "length", "one value"),
    ],
)
def test_bad_scalars_name_key_and_value(value, kind, needle):
    with pytest.raises(InputError) as info:
        to_si(value, kind, "the.key", strict=True)
    assert "the.key" in str(info.value) and needle in str(info.value)


def test_strict_rejects_plain_numbers_and_sign_checks():
    with pytest.raises(InputError, match="no unit"):
        to_si(3.0, "mass", "mass", strict=True)
    with pytest.raises(InputError, match="> 0"):
        to_si("0 kg", "mass", "mass", positive=True)
    with pytest.raises(InputError, match="3 components"):
        vector_to_si(["1 m", "2 m"], "length", "position")
    with pytest.raises(InputError, match=r"position\[1\]"):
        vector_to_si(["1 m", "2 s", "0 m"], "length", "position")
