"""Band tables of the atmosphere's density for the kernels of :mod:`emorbit.kernels.effects.atmosphere`.

Method: a piecewise-exponential ("band") model. Band ``i`` starts at the base altitude
``h0[i]`` and holds ``rho(h) = rho0[i] exp(-(h - h0[i]) / H[i])`` up to ``h0[i + 1]``; the
first band also holds below ``h0[0]`` and the last one above ``h0[-1]`` (both extrapolate
their exponential). Altitudes are heights above a sphere of the central body's radius
(:func:`~emorbit.kernels.effects.atmosphere.altitude`): a spherical Earth.

Data layout: each table is a :class:`BandTable` of three (n,) float64 arrays in SI units,
``h0`` (m, increasing), ``rho0`` (kg/m^3) and ``H`` (m), the argument order of the kernels
(``table_h0, table_rho0, table_H``).

Tables:

- :data:`USSA1976`: the U.S. Standard Atmosphere 1976 at the 28 base altitudes of Vallado's
  Table 8-4 (0, 25, 30, ..., 150, 180, 200, 250, ..., 500, 600, ..., 1000 km): the
  densities as the standard tabulates them (4 significant digits; geometric altitude),
  with each band's scale height ``H[i] = (h0[i+1] - h0[i]) / ln(rho0[i] / rho0[i+1])`` so
  that the model passes through every tabulated node and is **continuous** (its slope jumps
  at the nodes). Above 1000 km the 900-1000 km band's scale height continues. Between the
  nodes it deviates from the full standard by up to 25 % below 25 km (the first band spans
  the troposphere's temperature profile), up to 8 % at 100-200 km and up to 5 % above
  200 km (measured on a 50 m grid: below 86 km against the standard's defining equations,
  as ``tests/test_atmosphere.py`` does; above 86 km against Braeunig's polynomial fits of
  the standard's tables, which match its 4-digit nodes to 7e-4).
  The same construction (the standard's densities at Vallado's altitudes, scale heights
  from neighbouring nodes) is in H. D. Curtis, *Orbital Mechanics for Engineering
  Students*, MATLAB function ``atmosphere``.
- :data:`VALLADO_2013`: Vallado's exponential model as printed (base altitude, nominal
  density, scale height per band). Per its note (after Wertz 1978, p. 820) it takes the
  U.S. Standard Atmosphere 1976 at 0 km, CIRA-72 at 25-500 km and CIRA-72 with an
  exospheric temperature of 1000 K at 500-1000 km, so above 25 km it is *not* the 1976
  standard (36 % denser at 350 km). Its scale heights were rounded to keep it nearly
  continuous: the density jumps by 0.14 % at 25 km and by less than 1e-4 (relative) at
  every other band edge (measured: ``tests/test_atmosphere.py``). Above 1000 km its last
  band (H = 268 km) holds.

References: U.S. Standard Atmosphere, 1976, NOAA-S/T 76-1562 (NOAA, NASA, USAF, Washington
D.C., 1976); D. A. Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed.
(Microcosm Press, 2013), Table 8-4 "Exponential Atmospheric Model", p. 567; J. R. Wertz
(ed.), *Spacecraft Attitude Determination and Control* (Reidel, 1978), p. 820;
R. A. Braeunig, "Atmospheric Models" (braeunig.us/space/atmmodel.htm).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["BandTable", "USSA1976", "VALLADO_2013", "TABLES", "exponential_table"]


class BandTable(NamedTuple):
    """A piecewise-exponential density model, in the kernels' argument order.

    Attributes
    ----------
    h0 : ndarray
        (n,) float64 base altitude of each band, m, increasing.
    rho0 : ndarray
        (n,) float64 density at the base altitude, kg/m^3.
    H : ndarray
        (n,) float64 scale height of each band, m.
    """

    h0: np.ndarray
    rho0: np.ndarray
    H: np.ndarray


#: the base altitudes of Vallado's Table 8-4, km
_BASE_KM = (
    (0.0, 25.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0)
    + (110.0, 120.0, 130.0, 140.0, 150.0, 180.0, 200.0, 250.0, 300.0, 350.0)
    + (400.0, 450.0, 500.0, 600.0, 700.0, 800.0, 900.0, 1000.0)
)

#: U.S. Standard Atmosphere 1976: density at each base altitude, kg/m^3
_USSA1976_RHO = (
    (1.225e0, 4.008e-2, 1.841e-2, 3.996e-3, 1.027e-3, 3.097e-4, 8.283e-5, 1.846e-5, 3.416e-6, 5.604e-7)
    + (9.708e-8, 2.222e-8, 8.152e-9, 3.831e-9, 2.076e-9, 5.194e-10, 2.541e-10, 6.073e-11, 1.916e-11, 7.014e-12)
    + (2.803e-12, 1.184e-12, 5.215e-13, 1.137e-13, 3.070e-14, 1.136e-14, 5.759e-15, 3.561e-15)
)

#: Vallado, Table 8-4: nominal density of each band, kg/m^3
_VALLADO_RHO = (
    (1.225e0, 3.899e-2, 1.774e-2, 3.972e-3, 1.057e-3, 3.206e-4, 8.770e-5, 1.905e-5, 3.396e-6, 5.297e-7)
    + (9.661e-8, 2.438e-8, 8.484e-9, 3.845e-9, 2.070e-9, 5.464e-10, 2.789e-10, 7.248e-11, 2.418e-11, 9.518e-12)
    + (3.725e-12, 1.585e-12, 6.967e-13, 1.454e-13, 3.614e-14, 1.170e-14, 5.245e-15, 3.019e-15)
)

#: Vallado, Table 8-4: scale height of each band, km
_VALLADO_H_KM = (
    (7.249, 6.349, 6.682, 7.554, 8.382, 7.714, 6.549, 5.799, 5.382, 5.877)
    + (7.263, 9.473, 12.636, 16.149, 22.523, 29.740, 37.105, 45.546, 53.628, 53.298)
    + (58.515, 60.828, 63.822, 71.835, 88.667, 124.64, 181.05, 268.00)
)


def _frozen(values) -> np.ndarray:
    out = np.array(values, dtype=np.float64)
    out.setflags(write=False)
    return out


def _ussa1976() -> BandTable:
    h0 = np.array(_BASE_KM, dtype=np.float64) * 1e3
    rho0 = np.array(_USSA1976_RHO, dtype=np.float64)
    H = np.empty_like(h0)
    H[:-1] = np.diff(h0) / np.log(rho0[:-1] / rho0[1:])
    H[-1] = H[-2]
    return BandTable(_frozen(h0), _frozen(rho0), _frozen(H))


def _vallado() -> BandTable:
    h0 = np.array(_BASE_KM, dtype=np.float64) * 1e3
    H = np.array(_VALLADO_H_KM, dtype=np.float64) * 1e3
    return BandTable(_frozen(h0), _frozen(_VALLADO_RHO), _frozen(H))


#: the U.S. Standard Atmosphere 1976 at Vallado's base altitudes, continuous (see the module)
USSA1976 = _ussa1976()
#: Vallado's Table 8-4 as printed (CIRA-72 above 25 km; see the module)
VALLADO_2013 = _vallado()
#: the shipped tables by name
TABLES = {"ussa1976": USSA1976, "vallado2013": VALLADO_2013}


def exponential_table(rho0: float, h0: float, H: float) -> BandTable:
    """The one-band table of a single exponential ``rho0 exp(-(h - h0) / H)``.

    Parameters
    ----------
    rho0 : float
        Density at ``h0``, kg/m^3.
    h0 : float
        Reference altitude, m.
    H : float
        Scale height, m.

    Returns
    -------
    BandTable
        Arrays of length 1, so that the band kernels evaluate the plain exponential model.
    """
    return BandTable(_frozen([h0]), _frozen([rho0]), _frozen([H]))
