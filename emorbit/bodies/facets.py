"""Surface facets of rigid bodies: flat plates on which atmospheric drag and solar radiation
pressure act.

A facet is a flat plate of area ``A`` with its centroid ``c`` (body frame, relative to the
body's centre of mass, the same frame and centring as the shape's mass points in
:mod:`emorbit.bodies.shapes`), its unit outward normal ``n``, whether it is two-sided (a thin
plate either side of which may face the flow or the Sun), and its coefficients: drag ``Cd``,
specular ``rho_s`` and diffuse ``rho_d`` reflection (the rest, ``1 - rho_s - rho_d``, is
absorbed). They enter the standard flat-plate models (``e`` the unit vector toward the Sun,
``v`` the plate's velocity relative to the air, P the radiation pressure, rho the air's
density)::

    F_srp  = -P A cos [(1 - rho_s) e + 2 (rho_s cos + rho_d / 3) n],  cos = n . e > 0, else 0
    F_drag = -1/2 rho Cd A max(0, n . v) v

with ``|n . e|``, ``|n . v|`` and the normal turned toward e or v for a two-sided plate
(Montenbruck & Gill 2000, eq. 3.75; Vallado 2013, section 8.6.4), applied at ``c``. The area
of the body seen from a unit direction u is ``A_proj(u) = sum A max(0, n . u)`` (two-sided:
``|n . u|``): for a closed convex surface half of ``sum A |n . u|``.

Surfaces of the shapes (:func:`shape_facets`), each a closed polyhedron:

* box: each of the 6 faces cut into refinement x refinement rectangles (exact);
* sphere, shell: a geodesic icosphere inscribed in the sphere: each face of the icosahedron
  cut into ``k^2`` triangles, ``k = 6 refinement`` (class I subdivision, Kenner 1976), the
  vertices pushed onto the sphere: ``720 refinement^2`` triangles;
* ellipsoid: the sphere's triangles scaled by the semi-axes (an inscribed polyhedron);
* cylinder (axis along body z, ``-height/2 <= z <= height/2``): ``N = 32 refinement`` sides
  of a regular inscribed polygon, each cut into refinement rectangles along z, and caps of
  refinement rings of triangles: ``32 refinement^2 + 64 refinement (2 refinement - 1)`` facets;
* mesh: the boundary triangles of the tetrahedral mesh (:func:`boundary_triangles`), shifted
  by the centre of mass exactly as :func:`~emorbit.bodies.shapes.tetra_mesh` shifts the mass
  points;
* dumbbell: no surface; its facets are given as tables (:func:`facet_tables`).

An inscribed polyhedron is smaller than its shape. Measured over 20,000 random directions
and by a local search for the extremes (``tests/test_facets.py`` checks these bands): the
sphere's projected area falls short of pi R^2 by 0.72-0.98 % at refinement 1 (720 facets),
0.18-0.25 % at 2 (2880), 0.080-0.110 % at 3 (6480), 0.045-0.062 % at 4 (11520), about
1 % / refinement^2, and its volume by 1.53 %, 0.38 %, 0.17 %, 0.096 %; an ellipsoid's by the
same fractions (a linear map scales the polyhedron's and the ellipsoid's projections alike);
the cylinder's (96, 512, 1248, 2304 facets at refinement 1-4) by up to 0.48 % (side) and
0.64 % (ends, and volume) at refinement 1, 0.12 % and 0.16 % at 2, 0.054 % and 0.071 % at 3.
The box is exact (6 refinement^2 facets). Every surface is closed: ``sum A n = 0`` and
``sum A (c . n) = 3 V`` (the divergence theorem, V the polyhedron's volume) to round-off.

Data layout: :class:`Facets` holds (nf, ...) float64 arrays, SI units (m, m^2). Kernels read
:meth:`Facets.packed`, one C-contiguous (nf, 11) float64 row per facet, columns
:data:`PACKED_COLUMNS`: ``[cx, cy, cz, nx, ny, nz, area, cd, specular, diffuse, two_sided]``
(two_sided 1.0 or 0.0).

References: O. Montenbruck, E. Gill, Satellite Orbits (Springer, 2000), section 3.4;
D. A. Vallado, Fundamentals of Astrodynamics and Applications, 4th ed. (2013), section 8.6.4;
H. Kenner, Geodesic Math and How to Use It (University of California Press, 1976).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..keys import Key
from ..units import MAX_MAGNITUDE, to_si, vector_to_si

__all__ = [
    "Facets",
    "PACKED_COLUMNS",
    "FACET_KEYS",
    "FACET_SHAPES",
    "MAX_FACETS",
    "SPHERE_FREQUENCY",
    "CYLINDER_SIDES",
    "boundary_triangles",
    "shape_facets",
    "facet_tables",
    "facet_coefficients",
    "surface_spec",
]

#: the columns of :meth:`Facets.packed`, in order
PACKED_COLUMNS = ("cx", "cy", "cz", "nx", "ny", "nz", "area", "cd", "specular", "diffuse", "two_sided")
#: the most facets a shape's surface may have (its refinement sets how many it has)
MAX_FACETS = 1_000_000
#: icosphere edge divisions per refinement (sphere, shell, ellipsoid)
SPHERE_FREQUENCY = 6
#: polygon sides per refinement (cylinder)
CYLINDER_SIDES = 32
#: the shapes :func:`shape_facets` knows
FACET_SHAPES = ("box", "cylinder", "sphere", "ellipsoid", "shell", "dumbbell", "mesh")


@dataclass
class Facets:
    """Flat surface facets of a body (body frame, relative to its centre of mass; SI).

    Attributes
    ----------
    center : ndarray
        (nf, 3) facet centroids, m.
    normal : ndarray
        (nf, 3) unit outward normals.
    area : ndarray
        (nf,) areas, m^2.
    two_sided : ndarray
        (nf,) bool: a thin plate that can face the flow or the Sun with either side.
    drag_coefficient : ndarray
        (nf,) drag coefficients Cd.
    specular, diffuse : ndarray
        (nf,) specular and diffuse reflection coefficients (the rest is absorbed).

    Raises
    ------
    ValueError
        Arrays of other shapes or of different lengths.
    """

    center: np.ndarray
    normal: np.ndarray
    area: np.ndarray
    two_sided: np.ndarray
    drag_coefficient: np.ndarray
    specular: np.ndarray
    diffuse: np.ndarray

    def __post_init__(self):
        self.center = np.ascontiguousarray(self.center, dtype=float)
        self.normal = np.ascontiguousarray(self.normal, dtype=float)
        for name in ("area", "drag_coefficient", "specular", "diffuse"):
            setattr(self, name, np.ascontiguousarray(getattr(self, name), dtype=float))
        self.two_sided = np.ascontiguousarray(self.two_sided, dtype=bool)
        nf = self.area.shape[0] if self.area.ndim == 1 else -1
        for name in ("center", "normal"):
            if getattr(self, name).shape != (nf, 3):
                raise ValueError(f"Facets.{name}: expected shape ({nf}, 3), got {getattr(self, name).shape}")
        for name in ("area", "two_sided", "drag_coefficient", "specular", "diffuse"):
            if getattr(self, name).shape != (nf,):
                raise ValueError(f"Facets.{name}: expected shape ({nf},), got {getattr(self, name).shape}")

    def __len__(self) -> int:
        return self.area.shape[0]

    @property
    def total_area(self) -> float:
        """The sum of the facets' areas, m^2."""
        return float(self.area.sum())

    def packed(self) -> np.ndarray:
        """The facets as kernels read them.

        Returns
        -------
        ndarray
            C-contiguous (nf, 11) float64, one row per facet, columns :data:`PACKED_COLUMNS`:
            ``[cx, cy, cz, nx, ny, nz, area, cd, specular, diffuse, two_sided]`` (m, m^2,
            two_sided 1.0 or 0.0).
        """
        out = np.empty((len(self), 11))
        out[:, 0:3] = self.center
        out[:, 3:6] = self.normal
        out[:, 6] = self.area
        out[:, 7] = self.drag_coefficient
        out[:, 8] = self.specular
        out[:, 9] = self.diffuse
        out[:, 10] = self.two_sided
        return out

    @classmethod
    def from_packed(cls, packed) -> Facets:
        """The facets of a :meth:`packed` array (two_sided: above 0.5).

        Parameters
        ----------
        packed : array_like
            (nf, 11), columns :data:`PACKED_COLUMNS`.

        Returns
        -------
        Facets
        """
        p = np.asarray(packed, dtype=float).reshape(-1, 11)
        return cls(p[:, 0:3], p[:, 3:6], p[:, 6], p[:, 10] > 0.5, p[:, 7], p[:, 8], p[:, 9])

    def projected_area(self, direction):
        """The area seen from a direction: ``sum A max(0, n . u)`` (two-sided: ``|n . u|``).

        Parameters
        ----------
        direction : array_like
            (3,) or (k, 3) directions u in the body frame (normalised here).

        Returns
        -------
        float or ndarray
            m^2; a float for one direction, (k,) for k.

        Raises
        ------
        ValueError
            A direction that is zero or not finite.
        """
        u = np.asarray(direction, dtype=float)
        if u.shape[-1:] != (3,) or u.ndim > 2:
            raise ValueError(f"directions of shape (3,) or (k, 3) expected, got {u.shape}")
        scale = np.max(np.abs(u), axis=-1, keepdims=True)
        if not (np.all(np.isfinite(u)) and np.all(scale > 0)):
            raise ValueError(f"a direction must be finite and not zero, got {direction!r}")
        u = u / scale
        u = u / np.linalg.norm(u, axis=-1, keepdims=True)
        cos = u @ self.normal.T
        seen = np.where(self.two_sided, np.abs(cos), np.maximum(cos, 0.0))
        out = seen @ self.area
        return float(out) if u.ndim == 1 else out

    @classmethod
    def empty(cls) -> Facets:
        """No facets."""
        z = np.zeros(0)
        return cls(np.zeros((0, 3)), np.zeros((0, 3)), z, np.zeros(0, bool), z, z, z)

    @classmethod
    def concatenate(cls, parts) -> Facets:
        """The facets of several sets, in order.

        Parameters
        ----------
        parts : iterable of Facets

        Returns
        -------
        Facets
            Empty where ``parts`` is.
        """
        parts = list(parts)
        if not parts:
            return cls.empty()
        names = ("center", "normal", "area", "two_sided", "drag_coefficient", "specular", "diffuse")
        return cls(*(np.concatenate([getattr(p, n) for p in parts]) for n in names))


def _facets(center, normal, area, coefficients, two_sided=False) -> Facets:
    """Facets with the same coefficients (Cd, specular, diffuse) and sidedness."""
    n = np.shape(area)[0]
    cd, s, d = coefficients
    return Facets(center, normal, area, np.full(n, bool(two_sided)), np.full(n, cd), np.full(n, s), np.full(n, d))


# -- coefficients and values -----------------------------------------------------------------


def _real(value, key: str, what: str) -> float:
    """A plain finite number (not a bool), or an error naming ``key``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(key, f"{what} expected (a plain number), got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise InputError(key, f"must be finite, got {value!r}")
    return x


def facet_coefficients(cd, specular, diffuse, key: str, where=("drag_coefficient", "specular", "diffuse")):
    """Check a drag coefficient >= 0 and reflection coefficients in [0, 1] summing to at most 1.

    Parameters
    ----------
    cd, specular, diffuse : float
        The coefficients.
    key : str
        The body's key; errors name ``key.<where[i]>``.
    where : tuple of str
        The three keys' names.

    Returns
    -------
    tuple of float
        ``(cd, specular, diffuse)``.

    Raises
    ------
    InputError
        A value that is not a plain finite number in its range, naming its key.
    """
    cd = _real(cd, f"{key}.{where[0]}", "a drag coefficient")
    if not 0.0 <= cd <= MAX_MAGNITUDE:
        raise InputError(f"{key}.{where[0]}", f"must be >= 0 (and at most {MAX_MAGNITUDE:g}), got {cd!r}")
    out = [cd]
    for value, name in ((specular, where[1]), (diffuse, where[2])):
        x = _real(value, f"{key}.{name}", "a reflection coefficient")
        if not 0.0 <= x <= 1.0:
            raise InputError(f"{key}.{name}", f"must be in [0, 1], got {value!r}")
        out.append(x)
    if out[1] + out[2] > 1.0:
        raise InputError(
            f"{key}.{where[2]}",
            f"specular + diffuse must be at most 1 (the rest is absorbed), got {out[1]!r} + {out[2]!r} = "
            f"{out[1] + out[2]!r}",
        )
    return out[0], out[1], out[2]


def _lengths(params: dict, name: str, count: int, key: str) -> np.ndarray:
    """``params[name]`` as ``count`` finite lengths > 0 (m), or an error naming ``key.name``."""
    if name not in params:
        raise InputError(f"{key}.{name}", "missing (required for this shape's surface)")
    value = params[name]
    try:
        x = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        x = None
    if x is None or x.shape != ((count,) if count > 1 else ()) or not np.all((x > 0) & (x <= MAX_MAGNITUDE)):
        want = f"{count} lengths" if count > 1 else "a length"
        raise InputError(f"{key}.{name}", f"{want} > 0 in m expected, got {value!r}")
    return x


def _refinement(params: dict, key: str, facets) -> int:
    """``params["refinement"]`` (default 1) as an int >= 1 whose surface has at most
    :data:`MAX_FACETS` facets (``facets(refinement)``)."""
    n = params.get("refinement", 1)
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
        raise InputError(f"{key}.refinement", f"refinement must be an integer >= 1, got {n!r}")
    if facets(int(n)) > MAX_FACETS:
        raise InputError(
            f"{key}.refinement",
            f"refinement {n!r} gives {facets(int(n)):,} surface facets, more than a body may have ({MAX_FACETS:,})",
        )
    return int(n)


# -- surfaces --------------------------------------------------------------------------------


def _triangles(T: np.ndarray, key: str):
    """Centroids, unit normals (right-hand rule) and areas of triangles T (nt, 3, 3)."""
    cross = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    twice = np.linalg.norm(cross, axis=1)
    edge2 = np.max(np.sum((T - np.roll(T, 1, axis=1)) ** 2, axis=2), axis=1)
    bad = ~(twice > 1e-12 * edge2)  # collinear corners (to round-off): no normal
    if bad.any():
        t = int(np.flatnonzero(bad)[0])
        raise InputError(key, f"surface triangle {t} has no area: corners {T[t].tolist()} m")
    return T.mean(axis=1), cross / twice[:, None], 0.5 * twice


def _box(size, n: int):
    """Centroids, normals and areas of the 6 faces of a box centred on the origin, each cut
    into n x n rectangles."""
    centers, normals, areas = [], [], []
    edges = [np.linspace(-L / 2, L / 2, n + 1) for L in size]
    for k in range(3):
        i, j = [a for a in range(3) if a != k]
        mi, mj = 0.5 * (edges[i][1:] + edges[i][:-1]), 0.5 * (edges[j][1:] + edges[j][:-1])
        A = np.outer(np.diff(edges[i]), np.diff(edges[j])).ravel()
        MI, MJ = (g.ravel() for g in np.meshgrid(mi, mj, indexing="ij"))
        for sign in (1.0, -1.0):
            c = np.zeros((n * n, 3))
            c[:, i], c[:, j], c[:, k] = MI, MJ, sign * size[k] / 2
            nrm = np.zeros((n * n, 3))
            nrm[:, k] = sign
            centers.append(c)
            normals.append(nrm)
            areas.append(A)
    return np.concatenate(centers), np.concatenate(normals), np.concatenate(areas)


_ICO_FACES = np.array(
    [
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6],
        [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
        [8, 6, 7], [9, 8, 1],
    ]
)  # fmt: skip


def _icosphere(k: int) -> np.ndarray:
    """(20 k^2, 3, 3) triangles of the class I geodesic subdivision of frequency k of the
    icosahedron, vertices on the unit sphere, corners counter-clockwise seen from outside."""
    p = (1.0 + math.sqrt(5.0)) / 2.0
    V = np.array(
        [[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0], [0, -1, p], [0, 1, p],
         [0, -1, -p], [0, 1, -p], [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]],
        dtype=float,
    )  # fmt: skip
    corners = V[_ICO_FACES]  # (20, 3, 3): A, B, C of each face
    up = [((i, j), (i + 1, j), (i, j + 1)) for i in range(k) for j in range(k - i)]
    down = [((i + 1, j), (i + 1, j + 1), (i, j + 1)) for i in range(k) for j in range(k - i - 1)]
    ij = np.array(up + down, dtype=float)  # (k^2, 3 corners, 2): the grid steps along AB and AC
    bary = np.stack([k - ij[..., 0] - ij[..., 1], ij[..., 0], ij[..., 1]], axis=-1) / k  # (k^2, 3, 3)
    T = np.einsum("tcw,fwx->ftcx", bary, corners).reshape(-1, 3, 3)
    T /= np.linalg.norm(T, axis=2, keepdims=True)
    cross = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    inward = np.einsum("ij,ij->i", cross, T.sum(axis=1)) < 0
    T[inward] = T[inward][:, [0, 2, 1]]
    return T


def _cylinder(R: float, H: float, n: int, key: str):
    """Centroids, normals and areas of a cylinder's inscribed prism: N = 32 n side rectangles
    per layer, n layers, and caps of n rings of triangles."""
    N = CYLINDER_SIDES * n
    th = 2.0 * np.pi * np.arange(N + 1) / N
    th[-1] = 0.0  # the polygon closes on its first vertex
    cos, sin = np.cos(th), np.sin(th)
    z = np.linspace(-H / 2, H / 2, n + 1)
    # side: rectangles between consecutive vertices, layers along z
    mid = 0.5 * (th[:-1] + np.append(th[1:-1], 2.0 * np.pi))
    normal = np.stack([np.cos(mid), np.sin(mid), np.zeros(N)], axis=1)
    chord = np.hypot(cos[1:] - cos[:-1], sin[1:] - sin[:-1]) * R
    foot = 0.5 * R * np.stack([cos[1:] + cos[:-1], sin[1:] + sin[:-1]], axis=1)
    zc, dz = 0.5 * (z[1:] + z[:-1]), np.diff(z)
    side_c = np.concatenate([np.column_stack([foot, np.full(N, zz)]) for zz in zc])
    side_n = np.tile(normal, (n, 1))
    side_a = np.concatenate([chord * h for h in dz])
    # caps: a fan of triangles about the axis, then rings of two triangles per sector
    r = R * np.arange(n + 1) / n
    r[-1] = R

    def vertex(ring, j, zz):
        return np.stack([r[ring] * cos[j], r[ring] * sin[j], np.full(np.shape(j), zz)], axis=-1)

    j0, j1 = np.arange(N), np.arange(1, N + 1)
    caps = []
    for zz in (-H / 2, H / 2):
        tri = [np.stack([vertex(0, j0, zz), vertex(1, j0, zz), vertex(1, j1, zz)], axis=1)]
        for ring in range(1, n):
            a, b = vertex(ring, j0, zz), vertex(ring, j1, zz)
            c, d = vertex(ring + 1, j0, zz), vertex(ring + 1, j1, zz)
            tri += [np.stack([a, c, d], axis=1), np.stack([a, d, b], axis=1)]
        T = np.concatenate(tri)
        cross = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
        flip = cross[:, 2] * zz < 0  # outward: +z on top, -z below
        T[flip] = T[flip][:, [0, 2, 1]]
        caps.append(_triangles(T, f"{key}.radius"))
    c, nn, a = zip(*caps)
    return (np.concatenate([side_c, *c]), np.concatenate([side_n, *nn]), np.concatenate([side_a, *a]))


def boundary_triangles(tetrahedra, nodes, *, key: str = "body") -> np.ndarray:
    """The boundary of a tetrahedral mesh: the faces that belong to exactly one tetrahedron.

    Each is oriented outward, away from its tetrahedron's fourth node (whatever the
    tetrahedron's own orientation): the right-hand rule on its corners gives the outward
    normal. Faces shared by two tetrahedra are interior; a face of three or more (a
    non-manifold mesh) is not returned either.

    Parameters
    ----------
    tetrahedra : array_like
        (k, 4) 0-based node indices.
    nodes : array_like
        (n, 3) node coordinates.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    ndarray
        (nf, 3) int64 node indices, in the order of the tetrahedra they bound.

    Raises
    ------
    InputError
        Bad arrays or an index out of range.
    """
    from .shapes import mesh_coordinates, mesh_indices  # on use: a point-mass run imports no shape code

    P = mesh_coordinates(nodes, f"{key}.nodes")
    T = mesh_indices(tetrahedra, 4, f"{key}.tetrahedra")
    if T.size and (T.min() < 0 or T.max() >= P.shape[0]):
        bad = int(np.flatnonzero((T < 0).any(axis=1) | (T >= P.shape[0]).any(axis=1))[0])
        raise InputError(f"{key}.tetrahedra[{bad}]", f"node index out of range 0..{P.shape[0] - 1}: {T[bad].tolist()}")
    local = np.array([[1, 2, 3, 0], [0, 3, 2, 1], [0, 1, 3, 2], [0, 2, 1, 3]])  # three corners, then the fourth
    faces = T[:, local[:, :3]].reshape(-1, 3)
    fourth = T[:, local[:, 3]].reshape(-1)
    _, inverse, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True, return_counts=True)
    once = counts[inverse.reshape(-1)] == 1
    F, O = faces[once], fourth[once]
    x0 = P[F[:, 0]]
    toward = np.einsum("ij,ij->i", np.cross(P[F[:, 1]] - x0, P[F[:, 2]] - x0), P[O] - x0) > 0
    F[toward] = F[toward][:, [0, 2, 1]]
    return np.ascontiguousarray(F, dtype=np.int64)


def _mesh_center(P: np.ndarray, T: np.ndarray, density: float) -> np.ndarray:
    """The centre of mass of tetra_mesh's mass points, computed as it computes it."""
    from .shapes import _TET_A, _TET_B

    x0, x1, x2, x3 = (P[T[:, k]] for k in range(4))
    vol = np.einsum("ij,ij->i", np.cross(x1 - x0, x2 - x0), x3 - x0) / 6.0
    corners = np.stack([x0, x1, x2, x3])
    pts = []
    for j in range(4):
        bary = np.full(4, _TET_B)
        bary[j] = _TET_A
        pts.append(np.einsum("k,kei->ei", bary, corners))
    X = np.ascontiguousarray(np.concatenate(pts).T, dtype=float)
    m = np.ascontiguousarray(density * np.tile(vol / 4.0, 4), dtype=float)
    return (X * m).sum(axis=1) / m.sum()


def shape_facets(
    shape: str,
    params: dict,
    *,
    drag_coefficient: float = 2.2,
    specular: float = 0.0,
    diffuse: float = 0.0,
    key: str = "body",
) -> Facets:
    """The closed outer surface of a rigid shape as one-sided facets.

    In the body frame and centring of the shape's mass points (:mod:`emorbit.bodies.shapes`);
    the surfaces are described in the module docstring.

    Parameters
    ----------
    shape : str
        One of :data:`FACET_SHAPES`.
    params : dict
        The shape's parameters in SI as :func:`emorbit.bodies.rigid_input.build_rigid` keeps them:
        ``size`` (box), ``radius`` (sphere, shell, cylinder), ``height`` (cylinder),
        ``semi_axes`` (ellipsoid), ``refinement`` (default 1), ``nodes`` and ``tetrahedra``
        (mesh, with ``density`` where given: the centre of mass is the mass points'); others
        (mass, density) are not used.
    drag_coefficient : float
        Cd of every facet, >= 0.
    specular, diffuse : float
        Reflection coefficients of every facet, in [0, 1], summing to at most 1.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    Facets

    Raises
    ------
    InputError
        An unknown shape (``key.shape``), a dumbbell (``key.facets``: it has no surface), a
        missing or bad parameter, a refinement above :data:`MAX_FACETS` facets, or bad
        coefficients.
    """
    coefficients = facet_coefficients(drag_coefficient, specular, diffuse, key)
    if not isinstance(shape, str) or shape not in FACET_SHAPES:
        raise InputError(f"{key}.shape", f"unknown shape {shape!r}; known: {', '.join(FACET_SHAPES)}")
    if shape == "dumbbell":
        raise InputError(
            f"{key}.facets",
            "a dumbbell has no surface (two points on a massless rod): give its facets as [[body.facet]] tables",
        )
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        if shape == "box":
            size = _lengths(params, "size", 3, key)
            n = _refinement(params, key, lambda n: 6 * n * n)
            return _facets(*_box(size, n), coefficients)
        if shape in ("sphere", "shell", "ellipsoid"):
            axes = _lengths(params, "semi_axes", 3, key) if shape == "ellipsoid" else _lengths(params, "radius", 1, key)
            k = SPHERE_FREQUENCY * _refinement(params, key, lambda n: 20 * (SPHERE_FREQUENCY * n) ** 2)
            name = "semi_axes" if shape == "ellipsoid" else "radius"
            return _facets(*_triangles(_icosphere(k) * axes, f"{key}.{name}"), coefficients)
        if shape == "cylinder":
            R, H = float(_lengths(params, "radius", 1, key)), float(_lengths(params, "height", 1, key))
            sides = CYLINDER_SIDES
            n = _refinement(params, key, lambda n: sides * n * n + 2 * sides * n * (2 * n - 1))
            return _facets(*_cylinder(R, H, n, key), coefficients)
        # a tetrahedral mesh
        for need in ("nodes", "tetrahedra"):
            if need not in params:
                raise InputError(f"{key}.{need}", "missing (required for a mesh)")
        from .shapes import mesh_coordinates, mesh_indices

        P = mesh_coordinates(params["nodes"], f"{key}.nodes")
        T = mesh_indices(params["tetrahedra"], 4, f"{key}.tetrahedra")
        if T.shape[0] < 1:
            raise InputError(f"{key}.tetrahedra", "a mesh needs at least one tetrahedron")
        F = boundary_triangles(T, P, key=key)
        density = params.get("density", 1.0)
        density = _real(density, f"{key}.density", "a density in kg/m3")
        if not density > 0:
            raise InputError(f"{key}.density", f"must be > 0, got {density!r}")
        com = _mesh_center(P, T, density)
        if not np.all(np.isfinite(com)):
            raise InputError(f"{key}.tetrahedra", "the mesh has no volume: its centre of mass is not finite")
        return _facets(*_triangles((P - com)[F], f"{key}.tetrahedra"), coefficients)


# -- facets given as tables ------------------------------------------------------------------

# One key per entry: Key(name, required, value, default, allowed, meaning).
# fmt: off
FACET_KEYS = (
    Key("center", True, "length (m), 3 strings with units", "", "3 finite values",
        "the facet's centroid in the body frame, relative to the centre of mass"),
    Key("normal", True, "3 numbers", "", "not all 0 (normalised)", "the facet's outward normal in the body frame"),
    Key("area", True, "area (m2)", "", "> 0", "the facet's area"),
    Key("two_sided", False, "boolean", "false", "true, false",
        "a thin plate that faces the flow or the Sun with either side"),
    Key("drag_coefficient", False, "number", "the body's (2.2)", ">= 0", "the facet's drag coefficient Cd"),
    Key("specular", False, "number", "the body's (0)", "in [0, 1]; specular + diffuse <= 1",
        "the fraction of sunlight reflected specularly"),
    Key("diffuse", False, "number", "the body's (0)", "in [0, 1]; specular + diffuse <= 1",
        "the fraction of sunlight reflected diffusely (Lambert); the rest is absorbed"),
)
# fmt: on
_ALLOWED = tuple(k.name for k in FACET_KEYS)


def _normal(value, key: str) -> np.ndarray:
    """Three plain numbers, not all zero, as a unit vector."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 3:
        raise InputError(key, f"expected 3 numbers, got {value!r}")
    n = np.array([_real(x, f"{key}[{i}]", "a number") for i, x in enumerate(value)])
    scale = np.max(np.abs(n))
    if not scale > 0:
        raise InputError(key, f"a normal must not be zero, got {value!r}")
    n = n / scale
    return n / np.linalg.norm(n)


def facet_tables(
    tables,
    *,
    key: str = "body",
    strict: bool = False,
    drag_coefficient: float = 2.2,
    specular: float = 0.0,
    diffuse: float = 0.0,
) -> Facets:
    """Facets from tables: a scene's ``[[body.facet]]`` array of tables or a list of dicts.

    Keys of each table (:data:`FACET_KEYS`): ``center`` (3 lengths), ``normal`` (3 numbers,
    normalised), ``area`` (> 0), ``two_sided`` (default false), ``drag_coefficient``,
    ``specular``, ``diffuse`` (default the body's values given here).

    Parameters
    ----------
    tables : sequence of dict
        One table per facet (may be empty: no facets).
    key : str
        The body's key; errors name ``key.facet[i].<name>``.
    strict : bool
        Require units on the center and area (scenes); else plain numbers are SI.
    drag_coefficient : float
        The body's Cd, the default of each facet, >= 0.
    specular, diffuse : float
        The body's reflection coefficients, the defaults of each facet.

    Returns
    -------
    Facets

    Raises
    ------
    InputError
        Not a list of tables, an unknown or missing key, or a bad value (the key named).
    """
    body = facet_coefficients(drag_coefficient, specular, diffuse, key)
    if isinstance(tables, (str, bytes, Mapping)) or not isinstance(tables, (list, tuple)):
        raise InputError(f"{key}.facet", f"expected an array of tables (a list of dicts), got {tables!r}")
    rows = []
    for i, table in enumerate(tables):
        where = f"{key}.facet[{i}]"
        if not isinstance(table, Mapping):
            raise InputError(where, f"expected a table (a dict), got {table!r}")
        for name in table:
            if name not in _ALLOWED:
                raise InputError(f"{where}.{name}", f"unknown key; a facet has {', '.join(_ALLOWED)}")
        for k in FACET_KEYS:
            if k.required and k.name not in table:
                raise InputError(f"{where}.{k.name}", "missing (required)")
        center = vector_to_si(table["center"], "length", f"{where}.center", strict=strict)
        normal = _normal(table["normal"], f"{where}.normal")
        area = to_si(table["area"], "area", f"{where}.area", strict=strict, positive=True)
        two = table.get("two_sided", False)
        if not isinstance(two, (bool, np.bool_)):
            raise InputError(f"{where}.two_sided", f"expected true or false, got {two!r}")
        cd, s, d = facet_coefficients(
            table.get("drag_coefficient", body[0]),
            table.get("specular", body[1]),
            table.get("diffuse", body[2]),
            where,
            ("drag_coefficient", "specular", "diffuse"),
        )
        rows.append((center, normal, area, bool(two), cd, s, d))
    if not rows:
        return Facets.empty()
    c, n, a, two, cd, s, d = zip(*rows)
    return Facets(np.array(c), np.array(n), np.array(a), np.array(two), np.array(cd), np.array(s), np.array(d))


def surface_spec(facets, facet, drag_coefficient, specular, diffuse, strict: bool, key: str):
    """A rigid body's facet specification, checked: the ``surface`` of
    :meth:`emorbit.bodies.rigid.RigidBodies.add`; its shape's facets are built when an effect
    needs them (:meth:`~emorbit.bodies.rigid.RigidBodies.facets`).

    Parameters
    ----------
    facets : str
        ``"shape"`` or ``"none"``.
    facet : list of dict or None
        Facet tables (:func:`facet_tables`).
    drag_coefficient, specular, diffuse : float
        The shape's facets' coefficients and the tables' defaults.
    strict : bool
        Require units (scenes).
    key : str
        The body's key in errors.

    Returns
    -------
    tuple or None
        ``(mode, Facets, defaults, key)``; None where the body has no facets.

    Raises
    ------
    InputError
        A mode other than "shape" and "none", or a bad facet table or coefficient.
    """
    if facets not in ("shape", "none"):
        raise InputError(f"{key}.facets", f'must be "shape" or "none", got {facets!r}')
    defaults = {"drag_coefficient": drag_coefficient, "specular": specular, "diffuse": diffuse}
    extra = facet_tables(facet if facet is not None else [], key=key, strict=strict, **defaults)
    defaults = {k: float(v) for k, v in defaults.items()}  # checked by facet_tables
    if facets == "none" and not len(extra):
        return None
    return (facets, extra, defaults, key)
