"""Two-body relations: osculating elements from a state and back, Kepler's equation, and the
analytic propagation used as the exact reference.

All functions are vectorised numpy over leading axes and use SI units and radians.
States are given as ``position`` and ``velocity`` arrays whose *last* axis has length 3,
relative to the field's centre unless ``center`` is given. :func:`orbit_state` turns
elements as a scene or the scripting API gives them (values with units, a periapsis and an
apoapsis in place of a and e) into a state.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from .errors import InputError
from .units import to_si

__all__ = [
    "OrbitalElements",
    "elements",
    "state_from_elements",
    "solve_kepler",
    "solve_kepler_hyperbolic",
    "mean_from_true",
    "kepler_period",
    "semi_major_axis",
    "propagate",
    "ORBIT_ELEMENTS",
    "orbit_state",
    "initial_state",
]

_TWO_PI = 2.0 * math.pi
_ROUND = 1e-11  # e below this is circular, sin(i) below this is equatorial


class OrbitalElements(NamedTuple):
    """Osculating elements, each an array over the states' leading axes.

    For a circular orbit ``argp`` is 0 and ``nu``/``M`` are measured from the ascending node
    (argument of latitude); for an equatorial orbit ``raan`` is 0 and ``argp`` is measured
    from the x axis (longitude of periapsis); both: true longitude.

    Attributes
    ----------
    a : ndarray
        Semi-major axis, m (negative for hyperbolic orbits).
    e : ndarray
        Eccentricity.
    i : ndarray
        Inclination, rad.
    raan : ndarray
        Longitude of the ascending node, rad.
    argp : ndarray
        Argument of periapsis, rad.
    nu : ndarray
        True anomaly, rad.
    M : ndarray
        Mean anomaly, rad.
    """

    a: np.ndarray
    e: np.ndarray
    i: np.ndarray
    raan: np.ndarray
    argp: np.ndarray
    nu: np.ndarray
    M: np.ndarray

    def with_units(self) -> OrbitalElements:
        """The same elements as astropy Quantities (sharing their memory where they are arrays).

        Returns
        -------
        OrbitalElements
            ``a`` in m, ``e`` dimensionless, ``i``, ``raan``, ``argp``, ``nu`` and ``M`` in rad.
        """
        import astropy.units as u

        rad = u.rad
        return OrbitalElements(
            self.a << u.m, self.e << u.dimensionless_unscaled, self.i << rad, self.raan << rad,
            self.argp << rad, self.nu << rad, self.M << rad,
        )  # fmt: skip


def _dot(a, b):
    return np.einsum("...k,...k->...", a, b)


def _angle(y, x):
    return np.mod(np.arctan2(y, x), _TWO_PI)


def semi_major_axis(position, velocity, gm, center=(0.0, 0.0, 0.0)):
    """Semi-major axis from the vis-viva law, 1/a = 2/r - v^2/GM.

    Parameters
    ----------
    position, velocity : array_like
        States (..., 3), m and m/s.
    gm : float
        GM of the centre, m^3/s^2.
    center : array_like
        The centre, m.

    Returns
    -------
    ndarray
        a in m over the leading axes (negative for hyperbolic states).
    """
    r = np.linalg.norm(np.asarray(position, float) - np.asarray(center, float), axis=-1)
    v2 = _dot(np.asarray(velocity, float), np.asarray(velocity, float))
    return 1.0 / (2.0 / r - v2 / gm)


def kepler_period(a, gm):
    """The Kepler period 2 pi sqrt(a^3 / GM).

    Parameters
    ----------
    a : array_like
        Semi-major axis, m (> 0).
    gm : float
        GM, m^3/s^2.

    Returns
    -------
    ndarray
        The period, s.

    Raises
    ------
    ValueError
        Some a <= 0 (an unbound orbit has no period).
    """
    a = np.asarray(a, float)
    if np.any(a <= 0):
        raise ValueError("the Kepler period needs a > 0 (a bound orbit)")
    return _TWO_PI * np.sqrt(a**3 / gm)


def mean_from_true(nu, e):
    """Mean anomaly from the true anomaly, for elliptic and hyperbolic orbits.

    Parameters
    ----------
    nu : array_like
        True anomaly, rad.
    e : array_like
        Eccentricity.

    Returns
    -------
    ndarray
        Mean anomaly, rad: in [0, 2 pi) for e < 1, e sinh F - F for e > 1.
    """
    nu = np.asarray(nu, float)
    e = np.asarray(e, float)
    with np.errstate(invalid="ignore"):
        E = np.arctan2(np.sqrt(np.abs(1.0 - e * e)) * np.sin(nu), e + np.cos(nu))
        M_ell = np.mod(E - e * np.sin(E), _TWO_PI)
        F = 2.0 * np.arctanh(np.sqrt(np.abs((e - 1.0) / (e + 1.0))) * np.tan(0.5 * nu))
        M_hyp = e * np.sinh(F) - F
    return np.where(e < 1.0, M_ell, M_hyp)


def elements(position, velocity, gm, center=(0.0, 0.0, 0.0)) -> OrbitalElements:
    """Osculating elements of states about a centre.

    Parameters
    ----------
    position, velocity : array_like
        States (..., 3), m and m/s.
    gm : float
        GM of the centre, m^3/s^2.
    center : array_like
        The centre, m.

    Returns
    -------
    OrbitalElements
        The elements over the states' leading axes.
    """
    r = np.asarray(position, float) - np.asarray(center, float)
    v = np.asarray(velocity, float)
    rn = np.linalg.norm(r, axis=-1)
    v2 = _dot(v, v)
    h = np.cross(r, v)
    hn = np.linalg.norm(h, axis=-1)
    hhat = h / hn[..., None]
    node = np.stack([-h[..., 1], h[..., 0], np.zeros_like(hn)], axis=-1)
    nn = np.linalg.norm(node, axis=-1)
    evec = ((v2 - gm / rn)[..., None] * r - _dot(r, v)[..., None] * v) / gm
    e = np.linalg.norm(evec, axis=-1)
    a = 1.0 / (2.0 / rn - v2 / gm)
    inc = np.arccos(np.clip(hhat[..., 2], -1.0, 1.0))

    equatorial = nn <= _ROUND * hn
    circular = e <= _ROUND
    xhat = np.broadcast_to(np.array([1.0, 0.0, 0.0]), r.shape)
    nhat = np.where(equatorial[..., None], xhat, node / np.where(nn > 0, nn, 1.0)[..., None])
    raan = np.where(equatorial, 0.0, _angle(node[..., 1], node[..., 0]))
    ehat = evec / np.where(e > 0, e, 1.0)[..., None]
    argp = np.where(circular, 0.0, _angle(_dot(hhat, np.cross(nhat, ehat)), _dot(nhat, ehat)))
    ref = np.where(circular[..., None], nhat, ehat)  # where anomalies are measured from
    nu = _angle(_dot(hhat, np.cross(ref, r)), _dot(ref, r))
    return OrbitalElements(a, e, inc, raan, argp, nu, mean_from_true(nu, e))


def solve_kepler(M, e, *, max_iter: int = 50):
    """Eccentric anomaly E with E - e sin E = M, to round-off.

    Halley's iteration from Danby's starter E0 = M + 0.85 e sign(sin M), then one Newton
    polish; the result is on the branch of M (E - M in (-pi, pi)).

    Parameters
    ----------
    M : array_like
        Mean anomaly, rad.
    e : array_like
        Eccentricity, 0 <= e < 1.
    max_iter : int
        Halley iterations at most.

    Returns
    -------
    ndarray
        E in rad, broadcast over M and e.

    Raises
    ------
    ValueError
        Some e outside [0, 1).
    """
    M = np.asarray(M, float)
    e = np.asarray(e, float)
    if np.any((e < 0) | (e >= 1)):
        raise ValueError("solve_kepler needs 0 <= e < 1")
    Mr = np.mod(M + math.pi, _TWO_PI) - math.pi  # in [-pi, pi)
    E = Mr + 0.85 * e * np.sign(np.sin(Mr))
    for _ in range(max_iter):
        s = e * np.sin(E)
        c = e * np.cos(E)
        f = E - s - Mr
        f1 = 1.0 - c
        dE = f / (f1 - 0.5 * f * s / f1)
        E = E - dE
        if np.all(np.abs(dE) <= 4e-16 * np.maximum(np.abs(E), 1.0)):
            break
    # one Newton polish at the converged point
    E = E - (E - e * np.sin(E) - Mr) / (1.0 - e * np.cos(E))
    return E + (M - Mr)


def solve_kepler_hyperbolic(M, e, *, max_iter: int = 100):
    """Hyperbolic anomaly F with e sinh F - F = M, to round-off (Newton from asinh(M / e)).

    Parameters
    ----------
    M : array_like
        Mean anomaly, rad.
    e : array_like
        Eccentricity, e > 1.
    max_iter : int
        Newton iterations at most.

    Returns
    -------
    ndarray
        F, broadcast over M and e.

    Raises
    ------
    ValueError
        Some e <= 1.
    """
    M = np.asarray(M, float)
    e = np.asarray(e, float)
    if np.any(e <= 1):
        raise ValueError("solve_kepler_hyperbolic needs e > 1")
    F = np.arcsinh(M / e)
    for _ in range(max_iter):
        dF = (e * np.sinh(F) - F - M) / (e * np.cosh(F) - 1.0)
        F = F - dF
        if np.all(np.abs(dF) <= 4e-16 * np.maximum(np.abs(F), 1.0)):
            break
    return F


def state_from_elements(el: OrbitalElements | tuple, gm, center=(0.0, 0.0, 0.0)):
    """Position and velocity from osculating elements.

    Parameters
    ----------
    el : OrbitalElements or tuple
        (a, e, i, raan, argp, nu[, M]) in m and rad; M, if given, is ignored.
    gm : float
        GM of the centre, m^3/s^2.
    center : array_like
        The centre, m.

    Returns
    -------
    position, velocity : ndarray
        States (..., 3), m and m/s.

    Raises
    ------
    ValueError
        Some a (1 - e^2) <= 0 (the state of a parabolic orbit has no a).
    """
    a, e, inc, raan, argp, nu = (np.asarray(q, float) for q in tuple(el)[:6])
    p = a * (1.0 - e * e)
    if np.any(p <= 0):
        raise ValueError("state_from_elements needs a (1 - e^2) > 0")
    return _state_from_p(p, e, inc, raan, argp, nu, gm, center)


def _state_from_p(p, e, inc, raan, argp, nu, gm, center):
    """The state of an orbit with semi-latus rectum p > 0 (any e >= 0, a parabola included)."""
    p, e, inc, raan, argp, nu = (np.asarray(q, float) for q in (p, e, inc, raan, argp, nu))
    r = p / (1.0 + e * np.cos(nu))
    rp = np.stack([r * np.cos(nu), r * np.sin(nu), np.zeros_like(r)], axis=-1)
    vp = np.stack([-np.sin(nu), e + np.cos(nu), np.zeros_like(r)], axis=-1) * np.sqrt(gm / p)[..., None]
    cO, sO = np.cos(raan), np.sin(raan)
    co, so = np.cos(argp), np.sin(argp)
    ci, si = np.cos(inc), np.sin(inc)
    rot = np.stack(
        [
            np.stack([cO * co - sO * so * ci, -cO * so - sO * co * ci, sO * si], axis=-1),
            np.stack([sO * co + cO * so * ci, -sO * so + cO * co * ci, -cO * si], axis=-1),
            np.stack([so * si, co * si, ci], axis=-1),
        ],
        axis=-2,
    )
    pos = np.einsum("...ij,...j->...i", rot, rp) + np.asarray(center, float)
    vel = np.einsum("...ij,...j->...i", rot, vp)
    return pos, vel


#: the keys of an orbit given by elements, and the kind of value each takes
ORBIT_ELEMENTS = {
    "a": "length",
    "e": "number",
    "periapsis_radius": "length",
    "apoapsis_radius": "length",
    "periapsis_altitude": "length",
    "apoapsis_altitude": "length",
    "i": "angle",
    "raan": "angle",
    "argp": "angle",
    "nu": "angle",
    "mean_anomaly": "angle",
}


def _given(orbit, names) -> list[str]:
    return [n for n in names if n in orbit]


def _size_and_shape(orbit, radius: float, strict: bool, key: str) -> tuple[float, float]:
    """(p, e): the semi-latus rectum (m) and e, from a and e, a periapsis and an apoapsis, or a periapsis and e."""
    sizes = _given(orbit, ("a", "periapsis_radius", "periapsis_altitude"))
    apo = _given(orbit, ("apoapsis_radius", "apoapsis_altitude"))
    if len(sizes) != 1:
        what = " and ".join(sizes) if sizes else "none"
        raise InputError(key, f"give exactly one of a, periapsis_radius and periapsis_altitude; got {what}")
    if len(apo) > 1:
        raise InputError(key, "give at most one of apoapsis_radius and apoapsis_altitude")
    if apo and "e" in orbit:
        raise InputError(f"{key}.e", f"e and {apo[0]} both fix the shape: give one of them")
    if apo and sizes[0] == "a":
        raise InputError(f"{key}.{apo[0]}", "an apoapsis goes with a periapsis (periapsis_radius or _altitude), not a")

    def radius_of(name: str) -> float:
        value = to_si(orbit[name], "length", f"{key}.{name}", strict=strict)
        if name.endswith("_altitude"):
            if not radius > 0:
                raise InputError(
                    f"{key}.{name}",
                    "an altitude is measured from the central body's surface, and this field has no radius; "
                    f"give {name.replace('altitude', 'radius')} (from the centre) or a [field] radius",
                )
            value += radius
        if not value > 0:
            raise InputError(f"{key}.{name}", f"the distance from the centre must be > 0, got {value!r} m")
        return value

    e = None
    if "e" in orbit:
        e = orbit["e"]
        if hasattr(e, "unit") and hasattr(e, "to_value"):  # a dimensionless Quantity
            try:
                e = float(e.to_value(""))
            except Exception:
                raise InputError(f"{key}.e", f"the eccentricity is a number without a unit, got {e!r}") from None
        if isinstance(e, bool) or not isinstance(e, numbers.Real) or not math.isfinite(e) or e < 0:
            raise InputError(f"{key}.e", f"the eccentricity must be a finite number >= 0, got {orbit['e']!r}")
        e = float(e)
    if sizes[0] == "a":
        a = to_si(orbit["a"], "length", f"{key}.a", strict=strict)
        e = 0.0 if e is None else e
        if e == 1.0:
            raise InputError(f"{key}.e", "a parabola (e = 1) has no finite a: give periapsis_radius with e = 1")
        if not (a > 0 and e < 1) and not (a < 0 and e > 1):
            raise InputError(
                f"{key}.a",
                f"a = {a!r} m does not fit e = {e!r}: an ellipse (e < 1) has a > 0, a hyperbola (e > 1) a < 0",
            )
        return a * (1.0 - e * e), e
    rp = radius_of(sizes[0])
    if apo:
        ra = radius_of(apo[0])
        if ra < rp:
            raise InputError(f"{key}.{apo[0]}", f"the apoapsis ({ra!r} m) is below the periapsis ({rp!r} m)")
        e = (ra - rp) / (ra + rp)
        return 2.0 * ra * rp / (ra + rp), e
    if e is None:
        raise InputError(f"{key}.e", f"missing: {sizes[0]} needs e or an apoapsis to fix the shape")
    return rp * (1.0 + e), e


def orbit_state(orbit, gm: float, center, radius: float = 0.0, *, strict: bool = False, key: str = "orbit"):
    """The state of osculating elements about a field's centre, as a scene or the API gives them.

    The elements are those of :func:`elements` (reference plane x-y, reference direction x):
    the size and shape as ``a`` and ``e`` (e default 0), as a periapsis and an apoapsis, or
    as a periapsis and ``e``; distances from the centre (``*_radius``) or above the field's
    radius (``*_altitude``); the angles ``i`` (in [0, 180] deg), ``raan``, ``argp`` (default
    0) and the position on the orbit as the true anomaly ``nu`` or ``mean_anomaly`` (default:
    ``nu`` = 0, the periapsis). A hyperbola has a < 0 and e > 1, a parabola e = 1 with a
    periapsis and ``nu``.

    Parameters
    ----------
    orbit : mapping
        {name: value} with names of :data:`ORBIT_ELEMENTS`: lengths and angles as Quantities,
        strings with units or (unless ``strict``) plain SI numbers (m, rad); ``e`` a number.
    gm : float
        GM of the field, m^3/s^2.
    center : array_like
        The field's centre (3,), m.
    radius : float
        The field's radius, m, from which altitudes are measured (0: altitudes are refused).
    strict : bool
        Require units on lengths and angles.
    key : str
        The key of the orbit, prefixed to the element named in errors.

    Returns
    -------
    position, velocity : ndarray
        (3,) m and m/s.

    Raises
    ------
    InputError
        Not a table, an unknown element, a missing or conflicting one, e < 0, a sign of a
        that does not fit e, an altitude without a field radius, an apoapsis below the
        periapsis, an inclination outside [0, 180] deg, or a true anomaly a hyperbola does
        not reach.
    """
    if not isinstance(orbit, Mapping):
        raise InputError(key, f"a table of orbital elements expected (a, e, i, raan, argp, nu ...), got {orbit!r}")
    for name in orbit:
        if name not in ORBIT_ELEMENTS:
            raise InputError(f"{key}.{name}", f"not an orbital element; allowed: {', '.join(ORBIT_ELEMENTS)}")
    p, e = _size_and_shape(orbit, radius, strict, key)
    angles = {}
    for name in ("i", "raan", "argp", "nu", "mean_anomaly"):
        if name in orbit:
            angles[name] = to_si(orbit[name], "angle", f"{key}.{name}", strict=strict)
    inc = angles.get("i", 0.0)
    if not 0.0 <= inc <= math.pi:
        raise InputError(f"{key}.i", f"the inclination must be in [0, 180] deg, got {orbit['i']!r}")
    if "nu" in angles and "mean_anomaly" in angles:
        raise InputError(f"{key}.mean_anomaly", "give nu or mean_anomaly, not both")
    if "mean_anomaly" in angles:
        M = angles["mean_anomaly"]
        if e < 1.0:
            E = float(solve_kepler(M, e))
            nu = 2.0 * math.atan2(math.sqrt(1.0 + e) * math.sin(0.5 * E), math.sqrt(1.0 - e) * math.cos(0.5 * E))
        elif e > 1.0:
            F = float(solve_kepler_hyperbolic(M, e))
            nu = 2.0 * math.atan(math.sqrt((e + 1.0) / (e - 1.0)) * math.tanh(0.5 * F))
        else:
            raise InputError(f"{key}.mean_anomaly", "a parabola (e = 1) takes nu, not mean_anomaly")
    else:
        nu = angles.get("nu", 0.0)
    if e >= 1.0:
        limit = math.pi - math.acos(1.0 / e) if e > 1.0 else math.pi
        wrapped = math.remainder(nu, 2.0 * math.pi)
        if not abs(wrapped) < limit:
            raise InputError(
                f"{key}.nu",
                f"an open orbit with e = {e!r} reaches true anomalies within +-{math.degrees(limit):.6g} deg only, "
                f"got {math.degrees(wrapped):.6g} deg",
            )
    pos, vel = _state_from_p(p, e, inc, angles.get("raan", 0.0), angles.get("argp", 0.0), nu, gm, center)
    return pos, vel


def initial_state(position, velocity, orbit, field, *, strict: bool, key: str):
    """A body's initial state as given: a position and a velocity, or osculating elements.

    Parameters
    ----------
    position, velocity : Quantity, sequence or None
        As the body's table or the API gives them (checked later, as given).
    orbit : mapping or None
        Elements for :func:`orbit_state`, instead of ``position`` and ``velocity``.
    field : CentralField or None
        The field the elements are taken about.
    strict : bool
        Require units.
    key : str
        The body's key, e.g. ``body[0]``.

    Returns
    -------
    position, velocity
        As given, or Quantities (3,) in m and m/s from ``orbit``.
    position_key, velocity_key : str
        The keys that name them in later errors (``<key>.orbit`` for both from elements).

    Raises
    ------
    InputError
        Neither or both forms, elements without a field, or what :func:`orbit_state` refuses.
    """
    if orbit is None:
        for what, value in (("position", position), ("velocity", velocity)):
            if value is None:
                raise InputError(f"{key}.{what}", "missing: give position and velocity, or orbit (elements)")
        return position, velocity, f"{key}.position", f"{key}.velocity"
    if position is not None or velocity is not None:
        raise InputError(f"{key}.orbit", "give either orbit (elements) or position and velocity, not both")
    if field is None:
        raise InputError(f"{key}.orbit", "orbital elements are taken about a central field; there is none")
    import astropy.units as u

    x, v = orbit_state(orbit, field.gm, field.center, field.radius, strict=strict, key=f"{key}.orbit")
    return x * u.m, v * (u.m / u.s), f"{key}.orbit", f"{key}.orbit"


def _stumpff(z):
    """Stumpff functions C(z), S(z) without cancellation for small |z|."""
    z = np.asarray(z, float)
    C = np.empty_like(z)
    S = np.empty_like(z)
    small = np.abs(z) < 0.5
    zs = z[small]
    # series: C = sum (-z)^k / (2k+2)!, S = sum (-z)^k / (2k+3)!
    c_terms = np.zeros_like(zs)
    s_terms = np.zeros_like(zs)
    term_c = np.full_like(zs, 0.5)
    term_s = np.full_like(zs, 1.0 / 6.0)
    for k in range(16):
        c_terms += term_c
        s_terms += term_s
        term_c = term_c * (-zs) / ((2 * k + 3) * (2 * k + 4))
        term_s = term_s * (-zs) / ((2 * k + 4) * (2 * k + 5))
    C[small] = c_terms
    S[small] = s_terms
    pos = (~small) & (z > 0)
    y = np.sqrt(z[pos])
    C[pos] = 2.0 * np.sin(0.5 * y) ** 2 / z[pos]
    S[pos] = (y - np.sin(y)) / y**3
    neg = (~small) & (z < 0)
    y = np.sqrt(-z[neg])
    C[neg] = 2.0 * np.sinh(0.5 * y) ** 2 / -z[neg]
    S[neg] = (np.sinh(y) - y) / y**3
    return C, S


def propagate(position, velocity, gm, dt, center=(0.0, 0.0, 0.0), *, max_iter: int = 60):
    """The exact Kepler motion: the state a time ``dt`` after each given state.

    The universal-variable Kepler equation is solved by Newton's method to round-off
    (bisection where a Newton step leaves its bracket), then Lagrange's f and g give the
    state. For bound orbits ``dt`` is first reduced modulo the period, so long spans keep
    their accuracy (the reduction costs about n_periods * 1e-16 in phase).

    Parameters
    ----------
    position, velocity : array_like
        States (..., 3), m and m/s.
    gm : float
        GM of the centre, m^3/s^2.
    dt : array_like
        Time to propagate, s (broadcast against the states' leading axes).
    center : array_like
        The centre, m.
    max_iter : int
        Newton iterations at most.

    Returns
    -------
    position, velocity : ndarray
        States (..., 3) with the broadcast shape of the inputs and ``dt``, m and m/s.
    """
    c = np.asarray(center, float)
    r0v = np.asarray(position, float) - c
    v0v = np.asarray(velocity, float)
    dt = np.asarray(dt, float)
    shape = np.broadcast_shapes(r0v.shape[:-1], v0v.shape[:-1], dt.shape)
    r0v = np.broadcast_to(r0v, shape + (3,))
    v0v = np.broadcast_to(v0v, shape + (3,))
    dt = np.broadcast_to(dt, shape).astype(float).copy()
    r0 = np.linalg.norm(r0v, axis=-1)
    vr = _dot(r0v, v0v)
    alpha = 2.0 / r0 - _dot(v0v, v0v) / gm  # 1/a
    bound = alpha > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        period = np.where(bound, _TWO_PI / np.sqrt(np.where(bound, alpha, 1.0) ** 3 * gm), np.inf)
    dt = np.where(bound, dt - np.round(dt / np.where(bound, period, 1.0)) * np.where(bound, period, 0.0), dt)
    sq = math.sqrt(gm)
    # starter: elliptic chi ~ sqrt(GM) alpha dt; otherwise from the near-parabolic guess
    chi = np.where(bound, sq * alpha * dt, sq * dt / r0)
    # F(chi) increases monotonically (dF/dchi = r > 0), so a bracket keeps Newton safe where
    # the starter is poor (e -> 1): a bound orbit with |dt| <= T/2 has |chi| = |dE| / sqrt(alpha)
    # <= 2 pi / sqrt(alpha); a Newton step that leaves the bracket is replaced by bisection
    # (unbound orbits keep plain Newton).
    with np.errstate(invalid="ignore", divide="ignore"):
        span = np.where(bound, 1.01 * _TWO_PI / np.sqrt(np.where(bound, alpha, 1.0)), np.inf)
    lo, hi = -span, span.copy()
    for _ in range(max_iter):
        z = alpha * chi * chi
        C, S = _stumpff(z)
        chi2 = chi * chi
        F = vr / sq * chi2 * C + (1.0 - alpha * r0) * chi2 * chi * S + r0 * chi - sq * dt
        dF = vr / sq * chi * (1.0 - z * S) + (1.0 - alpha * r0) * chi2 * C + r0
        lo = np.where(F < 0.0, chi, lo)
        hi = np.where(F > 0.0, chi, hi)
        new = chi - F / dF
        new = np.where(~bound | ((new >= lo) & (new <= hi)), new, 0.5 * (lo + hi))
        step = chi - new
        chi = new
        if np.all(np.abs(step) <= 4e-16 * np.maximum(np.abs(chi), 1e-300)):
            break
    z = alpha * chi * chi
    C, S = _stumpff(z)
    chi2 = chi * chi
    f = 1.0 - chi2 / r0 * C
    g = dt - chi2 * chi * S / sq
    rv = f[..., None] * r0v + g[..., None] * v0v
    r = np.linalg.norm(rv, axis=-1)
    fdot = sq / (r * r0) * chi * (z * S - 1.0)
    gdot = 1.0 - chi2 / r * C
    vv = fdot[..., None] * r0v + gdot[..., None] * v0v
    return rv + c, vv
