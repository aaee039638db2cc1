"""Rigid bodies discretised in space: elements with quadrature points, each a mass point.

Every shape returns :class:`MassPoints`: body coordinates ``X`` (3, N) relative to the
centre of mass, masses ``m`` (N,), and the inertia that follows from the *same*
discretisation (``E = sum m X X^T``, ``inertia = tr(E) I - E``), together with the analytic
inertia of the continuous shape where it exists, so the two can be compared.

The quadratures integrate second moments exactly where they can: boxes (2-point Gauss per
direction per cell), cylinders (2-point Gauss in r with weight r, uniform angles, 2-point
Gauss along the axis), solid spheres (3-point Gauss in r with weight r^2, Gauss-Legendre in
cos(theta), uniform in phi), solid ellipsoids (the sphere's points scaled along the axes),
thin spherical shells, and tetrahedral meshes (4-point rule of
degree 2) all reproduce the exact inertia of their geometry at any refinement; refinement
improves the gravity integral (the gravity-gradient torque and the centre of gravity).

Units: SI (m, kg, kg/m^3). Bodies are defined in their body frame; x = phi + R X in space.
"""

from __future__ import annotations

import functools
import numbers
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..units import MAX_MAGNITUDE

__all__ = [
    "MassPoints",
    "box",
    "cylinder",
    "sphere",
    "ellipsoid",
    "shell",
    "dumbbell",
    "tetra_mesh",
    "mesh_coordinates",
    "mesh_indices",
    "check_on_body",
    "SHAPES",
    "MAX_POINTS",
]

#: the most mass points a rigid body may have (its refinement sets how many its shape has)
MAX_POINTS = 10_000_000
#: the least second moment of mass a body may have, kg m2: below it X m X loses precision
#: (float64's smallest normal number over eps)
_SMALLEST_MOMENT = np.finfo(float).tiny / np.finfo(float).eps


def _quiet(shape):
    """A shape function whose arithmetic gives no overflow warnings: a value that overflows
    is not finite, and :func:`_finish` refuses it with an error naming the body."""

    @functools.wraps(shape)
    def wrapper(*args, **kwargs):
        with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
            return shape(*args, **kwargs)

    return wrapper


@dataclass
class MassPoints:
    """Mass points of a discretised body (body frame, relative to the centre of mass).

    Attributes
    ----------
    X : ndarray
        (3, N) positions, m.
    m : ndarray
        (N,) masses, kg.
    volume : float or None
        The body's volume, m^3 (None for a body without volume).
    analytic_inertia : ndarray or None
        (3, 3) inertia of the continuous shape about its centre of mass, kg m^2, where known.
    """

    X: np.ndarray
    m: np.ndarray
    volume: float | None = None
    analytic_inertia: np.ndarray | None = None

    @property
    def mass(self) -> float:
        """The total mass, kg."""
        return float(self.m.sum())

    @property
    def second_moment(self) -> np.ndarray:
        """E = sum m X X^T (kg m^2), the director mass matrix."""
        return (self.X * self.m) @ self.X.T

    @property
    def inertia(self) -> np.ndarray:
        """The inertia tensor of the mass points, tr(E) I - E (kg m^2)."""
        E = self.second_moment
        return np.trace(E) * np.eye(3) - E

    def __len__(self) -> int:
        return self.m.size


def check_on_body(nodes, which, centre, R, points: MassPoints, *, key: str, elastic: str, to: str) -> None:
    """Refuse nodes of an elastic body that would be attached to a rigid body they do not touch.

    A node attached to a rigid body rides at the material point where it starts, so it must
    start on or in the body. A node farther from every mass point than the extent of the mass
    points (the largest side of their bounding box, in the body frame) is not: a boom placed
    10 m from its bus, say.

    Parameters
    ----------
    nodes : array_like
        (k, 3) the nodes' positions, m.
    which : sequence of int
        (k,) their indices in the elastic body's mesh, for the message.
    centre : array_like
        (3,) the rigid body's centre of mass, m.
    R : array_like
        (3, 3) its attitude, body to space.
    points : MassPoints
        Its mass points.
    key : str
        The key the error names.
    elastic, to : str
        The elastic and the rigid body's names, for the message.

    Raises
    ------
    InputError
        Naming the nodes too far away and the largest distance.
    """
    from scipy.spatial import cKDTree

    X = points.X
    gap = cKDTree((np.asarray(centre, float)[:, None] + np.asarray(R, float) @ X).T).query(nodes)[0]
    tolerance = float(np.ptp(X, axis=1).max())
    far = np.flatnonzero(gap > tolerance)
    if far.size:
        raise InputError(
            key,
            f"node(s) {', '.join(str(int(which[k])) for k in far)} of {elastic!r} lie up to {gap[far].max():.6g} m "
            f"from the nearest mass point of {to!r}, more than {tolerance:.6g} m (the extent of its mass points): "
            "an attached node rides at the material point where it is, so it must lie on or in the body; place "
            "the elastic body there or attach other nodes",
        )


def _finish(X, m, volume, analytic, key, size: str = "size") -> MassPoints:
    """Mass points about their centre of mass, checked: finite, and with inertia about every
    axis (errors name the body's ``size`` key where its dimensions are too small)."""
    X = np.ascontiguousarray(X, dtype=float)
    m = np.ascontiguousarray(m, dtype=float)
    small = np.all(np.abs(X) < 1e-100)  # lengths whose products underflow (weights, volumes)
    com = (X * m).sum(axis=1) / m.sum()
    X = np.ascontiguousarray(X - com[:, None])
    pts = MassPoints(X, m, volume, analytic)
    with np.errstate(over="ignore", invalid="ignore"):
        E = pts.second_moment
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(m)) and np.all(np.isfinite(E))):
        if small:
            raise InputError(f"{key}.{size}", "the body is too small for float64: its mass points underflow")
        raise InputError(key, "the body's size and mass overflow: its second moment of mass is not finite")
    ev = np.linalg.eigvalsh(E)
    if not ev[-1] > _SMALLEST_MOMENT:  # X m X underflows: the lengths, not the shape, are at fault
        raise InputError(
            f"{key}.{size}",
            f"the body is too small for float64: its second moment of mass is {ev[-1]!r} kg m2 "
            f"(at least {_SMALLEST_MOMENT:g} kg m2)",
        )
    if not ev[0] > 1e-12 * ev[-1]:
        raise InputError(
            f"{key}.{size}", "the mass points lie in a plane or on a line: the body has no inertia about some axis"
        )
    return pts


def _gauss(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return x, w


def _refinement(refinement, key, points) -> int:
    """``refinement`` as an int >= 1 whose shape has at most :data:`MAX_POINTS` mass points
    (``points(refinement)``)."""
    if isinstance(refinement, bool) or not isinstance(refinement, (int, np.integer)) or refinement < 1:
        raise InputError(key, f"refinement must be an integer >= 1, got {refinement!r}")
    if points(int(refinement)) > MAX_POINTS:
        raise InputError(
            key,
            f"refinement {refinement!r} gives {points(int(refinement)):,} mass points, more than a body may have "
            f"({MAX_POINTS:,})",
        )
    return int(refinement)


def _mass_from(density, mass, volume, key, size: str = "size") -> float:
    """Total mass from exactly one of density (kg/m^3) and mass (kg); errors name the key at
    fault: ``mass``, ``density``, or the ``size`` key whose volume underflows."""
    if (density is None) == (mass is None):
        raise InputError(key, "give exactly one of density and mass")
    if mass is not None:
        if not mass > 0:
            raise InputError(f"{key}.mass", f"must be > 0, got {mass!r} kg")
        return float(mass)
    if not volume > 0:
        raise InputError(f"{key}.{size}", f"the body's volume, {volume!r} m3, underflows float64: it is too small")
    total = density * volume
    if not total > 0:
        raise InputError(
            f"{key}.density",
            f"{density!r} kg/m3 times the volume {volume!r} m3 is a mass of {total!r} kg, not > 0 in float64",
        )
    if not np.isfinite(total):
        raise InputError(key, f"the mass (density times volume {volume!r} m3) overflows: {total!r} kg")
    return float(total)


@_quiet
def box(size, *, density=None, mass=None, refinement: int = 1, key: str = "body") -> MassPoints:
    """A homogeneous box: 2 x 2 x 2 Gauss points in each of refinement^3 cells.

    Parameters
    ----------
    size : array_like
        Edges (a, b, c) along the body axes, m.
    density : float, optional
        kg/m^3; give exactly one of density and mass.
    mass : float, optional
        Total mass, kg.
    refinement : int
        Cells per edge: 8 refinement^3 mass points.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    MassPoints
        Relative to the centre of mass, with the analytic inertia of the continuous shape.

    Raises
    ------
    InputError
        A size that is not positive, not exactly one of density and mass, or a bad refinement.
    """
    n = _refinement(refinement, f"{key}.refinement", lambda n: 8 * n**3)
    a = np.asarray(size, float)
    if a.shape != (3,) or not np.all(a > 0):
        raise InputError(f"{key}.size", f"three edge lengths > 0 expected, got {size!r}")
    vol = float(np.prod(a))
    total = _mass_from(density, mass, vol, key, "size")
    g, w = _gauss(2)
    axes = []
    weights = []
    for L in a:
        edges = np.linspace(-L / 2, L / 2, n + 1)
        mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * (edges[1:] - edges[:-1])
        axes.append((mid[:, None] + half[:, None] * g).ravel())
        weights.append((half[:, None] * w).ravel())
    X = np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1)
    W = np.prod(np.array(np.meshgrid(*weights, indexing="ij")).reshape(3, -1), axis=0)
    m = total * W / W.sum()
    I = total / 12.0 * np.diag([a[1] ** 2 + a[2] ** 2, a[0] ** 2 + a[2] ** 2, a[0] ** 2 + a[1] ** 2])
    return _finish(X, m, vol, I, key)


@_quiet
def cylinder(radius, height, *, density=None, mass=None, refinement: int = 1, key: str = "body") -> MassPoints:
    """A solid homogeneous cylinder along the body z axis.

    ``refinement`` radial rings and axial layers, max(4, 4 refinement) angles; 2-point Gauss
    in r (weight r) and in z.

    Parameters
    ----------
    radius, height : float
        m.
    density : float, optional
        kg/m^3; give exactly one of density and mass.
    mass : float, optional
        Total mass, kg.
    refinement : int
        Rings and layers.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    MassPoints
        Relative to the centre of mass, with the analytic inertia of the continuous shape.

    Raises
    ------
    InputError
        A size that is not positive, not exactly one of density and mass, or a bad refinement.
    """
    n = _refinement(refinement, f"{key}.refinement", lambda n: 4 * n * n * max(4, 4 * n))
    R, H = float(radius), float(height)
    if not (R > 0 and H > 0):
        raise InputError(key, f"radius and height must be > 0, got {radius!r}, {height!r}")
    vol = np.pi * R * R * H
    total = _mass_from(density, mass, vol, key, "radius")
    g, w = _gauss(2)
    re = np.linspace(0, R, n + 1)
    r = (0.5 * (re[1:] + re[:-1])[:, None] + 0.5 * (re[1:] - re[:-1])[:, None] * g).ravel()
    wr = (0.5 * (re[1:] - re[:-1])[:, None] * w).ravel() * r
    ze = np.linspace(-H / 2, H / 2, n + 1)
    z = (0.5 * (ze[1:] + ze[:-1])[:, None] + 0.5 * (ze[1:] - ze[:-1])[:, None] * g).ravel()
    wz = (0.5 * (ze[1:] - ze[:-1])[:, None] * w).ravel()
    nt = max(4, 4 * n)
    th = (np.arange(nt) + 0.5) * 2 * np.pi / nt
    rr, tt, zz = np.meshgrid(r, th, z, indexing="ij")
    W = np.einsum("i,k->ik", wr, wz)[:, None, :] * np.ones((1, nt, 1))
    X = np.array([rr * np.cos(tt), rr * np.sin(tt), zz]).reshape(3, -1)
    m = total * W.ravel() / W.sum()
    I = total * np.diag([(3 * R * R + H * H) / 12, (3 * R * R + H * H) / 12, R * R / 2])
    return _finish(X, m, vol, I, key, "radius")


def _sphere_directions(n):
    """Unit vectors and weights (sum 1) integrating polynomials of degree <= 2n+... on the sphere:
    Gauss-Legendre in cos(theta) (2n points) times uniform phi (4n points)."""
    mu, wmu = _gauss(2 * n)
    nphi = 4 * n
    phi = (np.arange(nphi) + 0.5) * 2 * np.pi / nphi
    MU, PHI = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - MU**2)
    U = np.array([s * np.cos(PHI), s * np.sin(PHI), MU]).reshape(3, -1)
    W = (wmu[:, None] * np.ones(nphi)[None, :]).ravel()
    return U, W / W.sum()


@_quiet
def sphere(radius, *, density=None, mass=None, refinement: int = 1, key: str = "body") -> MassPoints:
    """A solid homogeneous sphere: 24 refinement^3 mass points.

    ``refinement`` radial shells with 3-point Gauss in r (weight r^2), times the direction
    rule (2 refinement x 4 refinement directions).

    Parameters
    ----------
    radius : float
        m.
    density : float, optional
        kg/m^3; give exactly one of density and mass.
    mass : float, optional
        Total mass, kg.
    refinement : int
        Radial shells.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    MassPoints
        Relative to the centre of mass, with the analytic inertia of the continuous shape.

    Raises
    ------
    InputError
        A size that is not positive, not exactly one of density and mass, or a bad refinement.
    """
    n = _refinement(refinement, f"{key}.refinement", lambda n: 24 * n**3)
    R = float(radius)
    if not R > 0:
        raise InputError(f"{key}.radius", f"must be > 0, got {radius!r}")
    vol = 4.0 / 3.0 * np.pi * R**3
    total = _mass_from(density, mass, vol, key, "radius")
    g, w = _gauss(3)
    re = np.linspace(0, R, n + 1)
    r = (0.5 * (re[1:] + re[:-1])[:, None] + 0.5 * (re[1:] - re[:-1])[:, None] * g).ravel()
    wr = (0.5 * (re[1:] - re[:-1])[:, None] * w).ravel() * r * r
    U, wu = _sphere_directions(n)
    X = (r[:, None, None] * U[None, :, :]).transpose(1, 0, 2).reshape(3, -1)
    W = (wr[:, None] * wu[None, :]).ravel()
    m = total * W / W.sum()
    return _finish(X, m, vol, total * 0.4 * R * R * np.eye(3), key, "radius")


@_quiet
def ellipsoid(semi_axes, *, density=None, mass=None, refinement: int = 1, key: str = "body") -> MassPoints:
    """A solid homogeneous ellipsoid: the unit sphere's 24 refinement^3 mass points
    (:func:`sphere`) scaled by the semi-axes along the body axes.

    A linear map keeps a homogeneous body homogeneous, so the scaled quadrature integrates the
    ellipsoid as the sphere's integrates the ball: its second moments are exact,
    ``E = m/5 diag(a^2, b^2, c^2)``.

    Parameters
    ----------
    semi_axes : array_like
        (a, b, c) along the body axes, m.
    density : float, optional
        kg/m^3; give exactly one of density and mass.
    mass : float, optional
        Total mass, kg.
    refinement : int
        Radial shells.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    MassPoints
        Relative to the centre of mass, with the analytic inertia of the continuous shape.

    Raises
    ------
    InputError
        Semi-axes that are not three positive lengths, not exactly one of density and mass,
        or a bad refinement.
    """
    axes = np.asarray(semi_axes, dtype=float).ravel() if not isinstance(semi_axes, str) else np.zeros(0)
    if axes.shape != (3,) or not np.all(axes > 0) or not np.all(np.isfinite(axes)):
        raise InputError(f"{key}.semi_axes", f"three lengths > 0 expected, got {semi_axes!r}")
    vol = 4.0 / 3.0 * np.pi * float(np.prod(axes))
    total = _mass_from(density, mass, vol, key, "semi_axes")
    unit = sphere(1.0, mass=total, refinement=refinement, key=key)
    analytic = np.diag([axes[1] ** 2 + axes[2] ** 2, axes[0] ** 2 + axes[2] ** 2, axes[0] ** 2 + axes[1] ** 2])
    return _finish(axes[:, None] * unit.X, unit.m, vol, total / 5.0 * analytic, key, "semi_axes")


@_quiet
def shell(radius, *, mass, refinement: int = 1, key: str = "body") -> MassPoints:
    """A thin spherical shell, all mass on the surface: 8 refinement^2 mass points.

    Parameters
    ----------
    radius : float
        m.
    mass : float
        kg.
    refinement : int
        Refinement of the direction rule.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    MassPoints
        With the analytic inertia 2/3 m R^2.

    Raises
    ------
    InputError
        A radius or mass that is not positive, or a bad refinement.
    """
    n = _refinement(refinement, f"{key}.refinement", lambda n: 8 * n * n)
    R = float(radius)
    if not R > 0:
        raise InputError(f"{key}.radius", f"must be > 0, got {radius!r}")
    total = _mass_from(None, mass, 0.0, key)
    U, wu = _sphere_directions(n)
    return _finish(R * U, total * wu, None, total * 2.0 / 3.0 * R * R * np.eye(3), key, "radius")


@_quiet
def dumbbell(masses, length, *, end_radius=None, refinement: int = 1, key: str = "body") -> MassPoints:
    """Two masses on a massless rod along the body x axis.

    Each end is a small solid sphere discretised like :func:`sphere`, which gives the body
    its (small) inertia about the rod.

    Parameters
    ----------
    masses : sequence of 2 floats
        kg.
    length : float
        The rod's length between the two centres, m.
    end_radius : float, optional
        Radius of the end spheres, m, in (0, length / 2) (default length / 20).
    refinement : int
        Refinement of each end sphere.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    MassPoints
        Relative to the centre of mass.

    Raises
    ------
    InputError
        A mass, length or end radius out of range.
    """
    m1, m2 = (float(x) for x in masses)
    L = float(length)
    if not (m1 > 0 and m2 > 0):
        raise InputError(f"{key}.masses", f"both masses must be > 0, got {masses!r}")
    if not L > 0:
        raise InputError(f"{key}.length", f"must be > 0, got {length!r}")
    rho = L / 20.0 if end_radius is None else float(end_radius)
    if not (0 < rho < L / 2):
        raise InputError(f"{key}.end_radius", f"must be in (0, length/2), got {end_radius!r}")
    ends = [sphere(rho, mass=mm, refinement=refinement, key=key) for mm in (m1, m2)]
    M = m1 + m2
    x1, x2 = -m2 * L / M, m1 * L / M
    X = np.concatenate([ends[0].X + np.array([[x1], [0], [0]]), ends[1].X + np.array([[x2], [0], [0]])], axis=1)
    m = np.concatenate([ends[0].m, ends[1].m])
    own = 0.4 * rho * rho * M
    red = m1 * m2 / M * L * L
    return _finish(X, m, None, np.diag([own, red + own, red + own]), key, "length")


def _mesh_array(values, integral: bool, key: str, what: str) -> np.ndarray:
    """``values`` as an array of numbers (integers if ``integral``), or an error naming ``key``.

    Lists (as TOML gives them) are scanned value by value, so that booleans, strings and, for
    indices, floats are refused even where numpy would convert them; arrays by their dtype.
    """
    kinds = "iu" if integral else "iuf"
    if isinstance(values, np.ndarray):
        if values.dtype.kind not in kinds and (values.size or values.dtype.kind not in "iuf"):
            want = "integers" if integral else "numbers"
            raise InputError(key, f"{what} must be {want}, got an array of {values.dtype}")
        return values
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise InputError(key, f"{what} expected as rows of numbers, got {values!r}")
    stack = [values]
    while stack:
        for x in stack.pop():
            if isinstance(x, (list, tuple)):
                stack.append(x)
            elif isinstance(x, bool) or not isinstance(x, (numbers.Integral if integral else numbers.Real)):
                want = "integers (0-based node indices)" if integral else "numbers"
                raise InputError(key, f"{what} must be {want}, got {x!r}")
    try:
        return np.asarray(values, dtype=np.int64 if integral else float)
    except (TypeError, ValueError, OverflowError):
        raise InputError(key, f"{what} must be rows of equal length, got {values!r}") from None


def mesh_coordinates(values, key: str, what: str = "node coordinates", scale: float = 1.0) -> np.ndarray:
    """Node coordinates as plain numbers, (n, 3) float64, times ``scale``.

    Parameters
    ----------
    values : array_like
        Rows [x, y, z] of numbers (a nested list or a numeric array).
    key : str
        The key named in errors.
    what : str
        What the values are, for the message (e.g. the dataset they were read from).
    scale : float
        Metres per unit of the values.

    Returns
    -------
    ndarray
        (n, 3) float64, m.

    Raises
    ------
    InputError
        Strings, booleans, ragged rows, not three columns, or coordinates that are not finite
        or beyond :data:`~emorbit.units.MAX_MAGNITUDE` metres.
    """
    X = np.asarray(_mesh_array(values, False, key, what), dtype=float)
    if X.ndim != 2 or X.shape[1] != 3:
        raise InputError(key, f"{what}: expected rows [x, y, z], got shape {X.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        X = X * scale
    if X.size and not np.max(np.abs(X)) <= MAX_MAGNITUDE:  # nan and inf fail too
        bad = np.unravel_index(np.argmax(~(np.abs(X) <= MAX_MAGNITUDE)), X.shape)
        raise InputError(
            key, f"{what}: node {bad[0]} has coordinate {X[bad]!r} m, not finite or beyond {MAX_MAGNITUDE:g} m"
        )
    return X


def mesh_indices(values, width: int, key: str, what: str = "element indices") -> np.ndarray:
    """Element node indices as integers, (k, width) int64 (k may be 0).

    Parameters
    ----------
    values : array_like
        Rows of ``width`` 0-based node indices (a nested list or an integer array).
    width : int
        Nodes per element: 4 for tetrahedra, 2 for bars.
    key : str
        The key named in errors.
    what : str
        What the values are, for the message (e.g. the dataset they were read from).

    Returns
    -------
    ndarray
        (k, width) int64.

    Raises
    ------
    InputError
        Floats (integral or not, and a float dtype), strings, booleans, ragged rows or rows of
        another width.
    """
    T = _mesh_array(values, True, key, what)
    if T.size == 0:
        return np.zeros((0, width), np.int64)
    if T.ndim != 2 or T.shape[1] != width:
        raise InputError(key, f"{what}: expected rows of {width} node indices, got shape {T.shape}")
    return np.asarray(T, dtype=np.int64)


_TET_A = 0.5854101966249685
_TET_B = 0.1381966011250105


@_quiet
def tetra_mesh(nodes, tetrahedra, *, density, key: str = "body") -> MassPoints:
    """A homogeneous body meshed with 4-node tetrahedra.

    The degree-2 four-point rule in every element gives the exact inertia of the meshed
    geometry.

    Parameters
    ----------
    nodes : array_like
        (n >= 4, 3) node coordinates, m.
    tetrahedra : array_like
        (k, 4) 0-based node indices, positively oriented.
    density : float
        kg/m^3.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    MassPoints
        4 k mass points, with the meshed volume.

    Raises
    ------
    InputError
        Bad arrays, an index out of range, a node of no element, or an inverted or
        zero-volume element (named).
    """
    P = np.asarray(nodes, dtype=float)
    T = np.asarray(tetrahedra)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] < 4:
        raise InputError(f"{key}.nodes", f"expected (n >= 4, 3) coordinates, got shape {P.shape}")
    if not np.all(np.abs(P) <= MAX_MAGNITUDE):
        raise InputError(f"{key}.nodes", f"coordinates must be finite and at most {MAX_MAGNITUDE:g} m in magnitude")
    if T.ndim != 2 or T.shape[1] != 4 or T.shape[0] < 1 or not np.issubdtype(T.dtype, np.integer):
        raise InputError(f"{key}.tetrahedra", f"expected (n >= 1, 4) node indices, got {T.shape} {T.dtype}")
    if T.min() < 0 or T.max() >= P.shape[0]:
        bad = int(np.flatnonzero((T < 0).any(axis=1) | (T >= P.shape[0]).any(axis=1))[0])
        raise InputError(f"{key}.tetrahedra[{bad}]", f"node index out of range 0..{P.shape[0] - 1}: {T[bad].tolist()}")
    if not (isinstance(density, (int, float)) and density > 0):
        raise InputError(f"{key}.density", f"must be > 0, got {density!r}")
    unused = np.setdiff1d(np.arange(P.shape[0]), T.ravel())
    if unused.size:
        raise InputError(f"{key}.nodes[{int(unused[0])}]", "node belongs to no tetrahedron (dangling node)")
    x0, x1, x2, x3 = (P[T[:, k]] for k in range(4))
    vol = np.einsum("ij,ij->i", np.cross(x1 - x0, x2 - x0), x3 - x0) / 6.0
    size = np.ptp(P, axis=0).max()
    tiny = 1e-12 * size**3
    for name, mask in (("zero-volume", np.abs(vol) <= tiny), ("inverted (negative volume)", vol < -tiny)):
        if mask.any():
            e = int(np.flatnonzero(mask)[0])
            raise InputError(f"{key}.tetrahedra[{e}]", f"{name} element {T[e].tolist()}, volume {vol[e]!r} m^3")
    corners = np.stack([x0, x1, x2, x3])  # (4, ne, 3)
    pts = []
    for j in range(4):
        bary = np.full(4, _TET_B)
        bary[j] = _TET_A
        pts.append(np.einsum("k,kei->ei", bary, corners))
    X = np.concatenate(pts).T
    m = density * np.tile(vol / 4.0, 4)
    return _finish(X, m, float(vol.sum()), None, key, "nodes")


#: shape name -> the function that discretises it
SHAPES = {
    "box": box,
    "cylinder": cylinder,
    "sphere": sphere,
    "ellipsoid": ellipsoid,
    "shell": shell,
    "dumbbell": dumbbell,
    "mesh": tetra_mesh,
}
