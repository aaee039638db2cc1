"""Gravity field coefficients: a file in the ICGEM ``.gfc`` format, or EGM2008 from heyoka.

ICGEM's format (the International Centre for Global Earth Models' exchange format, in which
GFZ publishes every field it hosts) is a header of ``keyword value`` lines that ends with
``end_of_head``, then one line per coefficient, ``gfc n m C S [sigma_C sigma_S]`` (static
fields; ``gfct``, ``trnd``, ``acos`` and ``asin`` lines of time-variable fields are refused:
their epochs are not read). The header gives ``earth_gravity_constant`` (GM, m^3/s^2),
``radius`` (m), ``max_degree``, ``norm`` (``fully_normalized`` is the only one read) and
``tide_system``. Exponents may be Fortran's (``1.0D-06``).

EGM2008 (N. K. Pavlis, S. A. Holmes, S. C. Kenyon, J. K. Factor, J. Geophys. Res. 117 (2012)
B04406; NGA, approved for public release) comes from the coefficient table that heyoka ships
(``heyoka.model.get_egm2008_CS``, degrees 2 to 150, tide-free; heyoka is MPL-2.0 licensed,
the ``field`` extra: ``pip install "emorbit[field]"``).

Data layout: a :class:`Coefficients` with ``C``, ``S`` (N + 1, N + 1) float64, ``C[n, m]``
fully normalised, N the degree read.
"""

from __future__ import annotations

import gzip
import math
import os
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["Coefficients", "MAX_DEGREE", "MODELS", "read_gfc", "model"]

#: the highest degree a field may be read to (its tables hold 5 (N + 1)(N + 2) / 2 values)
MAX_DEGREE = 360
#: the shipped models: name -> (where it comes from, the pip command that brings it)
MODELS = {"egm2008": ("heyoka.model.get_egm2008_CS (degree 150)", 'pip install "emorbit[field]"')}


@dataclass
class Coefficients:
    """A field's fully normalised coefficients.

    Attributes
    ----------
    name : str
        The model's name.
    gm : float
        Its GM, m^3/s^2.
    radius : float
        Its reference radius, m.
    C, S : numpy.ndarray
        (N + 1, N + 1) ``C[n, m]``, ``S[n, m]`` for m <= n (0 elsewhere).
    max_degree : int
        The highest degree the source has.
    tide_system : str
        As the source states it ("unknown" where it does not).
    """

    name: str
    gm: float
    radius: float
    C: np.ndarray
    S: np.ndarray
    max_degree: int
    tide_system: str = "unknown"

    @property
    def degree(self) -> int:
        """The degree read, N."""
        return self.C.shape[0] - 1


def _number(token: str, where: str) -> float:
    try:
        value = float(token.replace("D", "E").replace("d", "e"))
    except ValueError:
        raise InputError(where, f"{token!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(where, f"{token!r} is not finite")
    return value


def read_gfc(path, degree: int, key: str = "gfc") -> Coefficients:
    """Read a static field from an ICGEM ``.gfc`` file (``.gz`` compressed or not) up to
    ``degree``.

    Parameters
    ----------
    path : str
        The file.
    degree : int
        The highest degree to read (1 to :data:`MAX_DEGREE`); lines of higher degree are
        skipped as they stream past.
    key : str
        The key errors name.

    Returns
    -------
    Coefficients

    Raises
    ------
    InputError
        No such file; a header without GM, radius or ``end_of_head``; a normalisation other
        than ``fully_normalized``; a time-variable field; a line that is not a coefficient; a
        degree the file does not reach. Each names ``key``, the file and the line.
    """
    if not os.path.isfile(path):
        raise InputError(key, f"no gravity field file {path!r}")
    opener = gzip.open if str(path).endswith(".gz") else open
    header: dict[str, str] = {}
    C = np.zeros((degree + 1, degree + 1))
    S = np.zeros((degree + 1, degree + 1))
    seen = 0
    with opener(path, "rt", encoding="latin-1") as f:
        line_no = 0
        for line in f:
            line_no += 1
            words = line.split()
            if not words:
                continue
            if words[0] == "end_of_head":
                break
            if len(words) >= 2:
                header[words[0].lower()] = words[1]
        else:
            raise InputError(key, f"{path!r} has no end_of_head line: not an ICGEM .gfc file")
        where = f"{key} ({path}, line {{}})"
        for field in ("earth_gravity_constant", "radius"):
            if field not in header:
                raise InputError(key, f"{path!r}: the header gives no {field}")
        norm = header.get("norm", "fully_normalized").lower()
        if norm != "fully_normalized":
            raise InputError(key, f"{path!r} is {norm}; only fully_normalized coefficients are read")
        for line in f:
            line_no += 1
            words = line.split()
            if not words:
                continue
            tag = words[0].lower()
            if tag in ("gfct", "trnd", "acos", "asin"):
                raise InputError(key, f"{path!r} is a time-variable field ({tag} at line {line_no}): not read")
            if tag != "gfc" or len(words) < 5:
                raise InputError(where.format(line_no), f"a 'gfc n m C S' line expected, got {line.strip()[:80]!r}")
            try:
                n, m = int(words[1]), int(words[2])
            except ValueError:
                raise InputError(
                    where.format(line_no), f"degree and order must be integers: {line.strip()[:80]!r}"
                ) from None
            if not 0 <= m <= n:
                raise InputError(where.format(line_no), f"order {m} of degree {n} is out of range")
            if n > degree:
                continue
            C[n, m] = _number(words[3], where.format(line_no))
            S[n, m] = _number(words[4], where.format(line_no))
            seen = max(seen, n)
    top = int(header.get("max_degree", seen))
    if top < degree or seen < degree:
        raise InputError(key, f"{path!r} reaches degree {min(top, seen)}, not the {degree} asked for")
    gm = _number(header["earth_gravity_constant"], f"{key} ({path}, earth_gravity_constant)")
    radius = _number(header["radius"], f"{key} ({path}, radius)")
    if gm <= 0.0 or radius <= 0.0:
        raise InputError(key, f"{path!r}: GM {gm!r} and radius {radius!r} must be > 0")
    name = header.get("modelname", os.path.basename(str(path)))
    return Coefficients(name, gm, radius, C, S, top, header.get("tide_system", "unknown"))


def model(name: str, degree: int, key: str = "model") -> Coefficients:
    """A shipped model up to ``degree``.

    Raises
    ------
    InputError
        An unknown model, a degree beyond it, or the package that carries it not installed
        (with the pip command).
    """
    lower = name.lower() if isinstance(name, str) else name
    if lower not in MODELS:
        raise InputError(key, f"unknown gravity model {name!r}; known: {', '.join(MODELS)} (or give gfc, a file)")
    try:
        import heyoka
    except ImportError:
        raise InputError(
            key, f"the {name} coefficients come from heyoka, which is not installed: {MODELS[lower][1]}"
        ) from None
    CS = np.asarray(heyoka.model.get_egm2008_CS(), float)
    top = int(round((math.sqrt(8 * (CS.shape[0] + 3) + 1) - 3) / 2))
    if degree > top:
        raise InputError(key, f"{name} reaches degree {top}, not the {degree} asked for")
    C = np.zeros((degree + 1, degree + 1))
    S = np.zeros((degree + 1, degree + 1))
    k = 0
    for n in range(2, degree + 1):
        C[n, : n + 1] = CS[k : k + n + 1, 0]
        S[n, : n + 1] = CS[k : k + n + 1, 1]
        k += n + 1
    gm = float(heyoka.model.get_egm2008_mu())
    radius = float(heyoka.model.get_egm2008_a())
    return Coefficients("EGM2008", gm, radius, C, S, top, "tide_free")
