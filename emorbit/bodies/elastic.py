"""Elastic bodies: St. Venant-Kirchhoff materials on a mesh (:mod:`.meshes`), and the arrays
a :class:`~emorbit.bodies.coupled.Structure` needs (an :class:`ElasticSpec`).

Meshes are in the body frame; ``x = position + R X`` places them.

Materials: Young's modulus E > 0, Poisson's ratio -1 < nu < 0.5 (tetrahedra), density > 0,
cross-section area > 0 (bars). Mass matrices: consistent (default) or lumped. Gravity acts
at the elements' quadrature points (tetrahedra: the 4-point degree-2 rule; bars: 2-point Gauss).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..units import to_si, vector_to_si
from .meshes import mesh_from_parameters
from .rotations import attitude_matrix

__all__ = [
    "ElasticSpec",
    "select_nodes",
    "elastic_spec",
    "build_elastic",
]

_TET_A = 0.5854101966249685
_TET_B = 0.1381966011250105


@dataclass
class ElasticSpec:
    """An elastic body ready to join a structure, in SI units, placed in space.

    Attributes
    ----------
    name : str
        The body's name.
    nodes, velocities : ndarray
        (n, 3) initial node positions (m) and velocities (m/s) in space.
    ref : ndarray
        (n, 3) reference node coordinates in the body frame, m (written to the file).
    bars : ndarray
        (m, 2) node indices of the bars.
    bar_EA, bar_L : ndarray
        (m,) axial stiffness E A (N) and rest length (m) of each bar.
    tets : ndarray
        (k, 4) node indices of the tetrahedra.
    tet_g : ndarray
        (k, 3, 4) reference gradients of the shape functions, 1/m.
    tet_V : ndarray
        (k,) reference volumes, m^3.
    tet_lam, tet_mu : ndarray
        (k,) Lame parameters, Pa.
    node_mass : scipy.sparse matrix
        (n, n) scalar mass matrix over the nodes, kg.
    gp_node, gp_w, gp_m : ndarray
        Gravity points: (q, 4) node indices (-1 unused), (q, 4) weights, (q,) masses in kg.
    gravity : bool
        Whether the field acts on the body.
    node_output_every : int
        Records between nodal-position outputs.
    material : dict or None
        Young's modulus, density, mass matrix and, where given, Poisson's ratio and area,
        with their units (the file's body attributes).
    """

    name: str
    nodes: np.ndarray
    velocities: np.ndarray
    ref: np.ndarray
    bars: np.ndarray
    bar_EA: np.ndarray
    bar_L: np.ndarray
    tets: np.ndarray
    tet_g: np.ndarray
    tet_V: np.ndarray
    tet_lam: np.ndarray
    tet_mu: np.ndarray
    node_mass: sp.spmatrix
    gp_node: np.ndarray
    gp_w: np.ndarray
    gp_m: np.ndarray
    gravity: bool
    node_output_every: int = 1
    material: dict | None = None


def select_nodes(ref, nodes, key: str) -> list[int]:
    """Node indices of a mesh, from a list or a selector.

    Parameters
    ----------
    ref : ndarray
        (n, 3) reference node coordinates, m.
    nodes : sequence of int or str
        0-based indices, or ``"first"``, ``"last"`` (chains), ``"<axis>-min"`` or
        ``"<axis>-max"`` with axis x, y or z (the nodes on that face of the reference mesh).
    key : str
        The key named in errors.

    Returns
    -------
    list of int
        The indices, each in 0..n-1.

    Raises
    ------
    InputError
        An unknown selector, an empty list, a value that is not an integer, or an index out
        of range.
    """
    n = ref.shape[0]
    if isinstance(nodes, str):
        if nodes == "first":
            return [0]
        if nodes == "last":
            return [n - 1]
        axes = {"x": 0, "y": 1, "z": 2}
        parts = nodes.split("-")
        if len(parts) == 2 and parts[0] in axes and parts[1] in ("min", "max"):
            col = ref[:, axes[parts[0]]]
            target = col.min() if parts[1] == "min" else col.max()
            tol = 1e-9 * max(float(np.ptp(ref, axis=0).max()), 1e-300)
            return np.flatnonzero(np.abs(col - target) <= tol).tolist()
        raise InputError(
            key,
            f"unknown node selector {nodes!r}; use a list of indices, 'first', 'last', "
            "or '<axis>-min' / '<axis>-max' with axis x, y or z",
        )
    if isinstance(nodes, (bytes, dict)) or not hasattr(nodes, "__iter__"):
        raise InputError(key, f"a list of node indices or a selector expected, got {nodes!r}")
    idx = list(nodes)
    for i in idx:
        if isinstance(i, bool) or not isinstance(i, numbers.Integral):
            raise InputError(key, f"a list of node indices expected (integers), got {nodes!r}")
    if not idx:
        raise InputError(key, "no nodes given")
    for i in idx:
        if not 0 <= i < n:
            raise InputError(key, f"node {i} is not in 0..{n - 1}")
    return [int(i) for i in idx]


def elastic_spec(
    name,
    X,
    tets,
    bars,
    *,
    young,
    density,
    poisson=None,
    area=None,
    mass_matrix="consistent",
    position,
    velocity,
    R,
    omega_space,
    gravity=True,
    node_output_every=1,
    key="body",
) -> ElasticSpec:
    """Check a mesh and a material and build the arrays of an elastic body.

    Parameters
    ----------
    name : str
        The body's name.
    X : array_like
        (n, 3) node coordinates in the body frame, m.
    tets : array_like
        (k, 4) tetrahedra (node indices; may be empty).
    bars : array_like
        (m, 2) bars (node indices; may be empty).
    young : float
        Young's modulus, Pa.
    density : float
        kg/m^3.
    poisson : float, optional
        Poisson's ratio in (-1, 0.5); required with tetrahedra.
    area : float, optional
        Bar cross-section, m^2; required with bars.
    mass_matrix : str
        ``"consistent"`` or ``"lumped"``.
    position, velocity : array_like
        The body frame's origin in space (m) and its velocity (m/s).
    R : array_like
        (3, 3) attitude, body to space.
    omega_space : array_like
        (3,) rigid angular velocity in space axes, rad/s.
    gravity : bool
        Whether the field acts on the body.
    node_output_every : int
        Records between nodal-position outputs.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    ElasticSpec
        The body, placed and moving in space.

    Raises
    ------
    InputError
        A bad mesh (no elements, an index out of range, a dangling node, an inverted,
        zero-volume or zero-length element) or material.
    """
    from .shapes import mesh_indices

    X = np.asarray(X, float)
    tets = mesh_indices(tets, 4, f"{key}.tetrahedra")
    bars = mesh_indices(bars, 2, f"{key}.bars")
    nn = X.shape[0]
    if X.ndim != 2 or X.shape[1] != 3 or nn < 2 or not np.all(np.isfinite(X)):
        raise InputError(f"{key}.nodes", f"expected finite (n >= 2, 3) coordinates, got shape {X.shape}")
    if tets.size == 0 and bars.size == 0:
        raise InputError(key, "the mesh has no elements")
    for arr, what in ((tets, "tetrahedra"), (bars, "bars")):
        if arr.size and (arr.min() < 0 or arr.max() >= nn):
            bad = int(np.flatnonzero((arr < 0).any(1) | (arr >= nn).any(1))[0])
            raise InputError(f"{key}.{what}[{bad}]", f"node index out of range 0..{nn - 1}: {arr[bad].tolist()}")
    if not (young > 0):
        raise InputError(f"{key}.young", f"Young's modulus must be > 0, got {young!r} Pa")
    if not (density > 0):
        raise InputError(f"{key}.density", f"must be > 0, got {density!r} kg/m3")
    if tets.size:
        if poisson is None:
            raise InputError(f"{key}.poisson", "missing: tetrahedra need Poisson's ratio")
        if not (-1.0 < poisson < 0.5):
            raise InputError(f"{key}.poisson", f"Poisson's ratio must be in (-1, 0.5), got {poisson!r}")
    if bars.size and not (area is not None and area > 0):
        raise InputError(f"{key}.area", f"bars need a cross-section area > 0, got {area!r} m2")
    if area is not None and not bars.size:
        raise InputError(f"{key}.area", "is the cross-section of bars, and this mesh has none (tetrahedra only)")
    if mass_matrix not in ("consistent", "lumped"):
        raise InputError(f"{key}.mass_matrix", f"must be 'consistent' or 'lumped', got {mass_matrix!r}")
    used = np.zeros(nn, bool)
    used[tets.ravel()] = True
    used[bars.ravel()] = True
    if not used.all():
        raise InputError(f"{key}.nodes[{int(np.flatnonzero(~used)[0])}]", "node belongs to no element (dangling node)")
    size = float(np.ptp(X, axis=0).max())
    rows, cols, vals = [], [], []
    # tetrahedra
    nt = tets.shape[0]
    tet_g = np.zeros((nt, 3, 4))
    tet_V = np.zeros(nt)
    if nt:
        P = X[tets]
        Dm = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]], axis=2)  # columns
        vol = np.linalg.det(Dm) / 6.0
        tiny = 1e-12 * size**3
        for what, mask in (("zero-volume", np.abs(vol) <= tiny), ("inverted (negative volume)", vol < -tiny)):
            if mask.any():
                e = int(np.flatnonzero(mask)[0])
                raise InputError(f"{key}.tetrahedra[{e}]", f"{what} element {tets[e].tolist()}, volume {vol[e]!r} m3")
        inv = np.linalg.inv(Dm)  # rows: gradients of N1..N3
        tet_g[:, :, 1:] = np.transpose(inv, (0, 2, 1))
        tet_g[:, :, 0] = -tet_g[:, :, 1:].sum(axis=2)
        tet_V = vol
        for a in range(4):
            for b in range(4):
                rows.append(tets[:, a])
                cols.append(tets[:, b])
                if mass_matrix == "consistent":
                    vals.append(density * vol / 20.0 * (2.0 if a == b else 1.0))
                else:
                    vals.append(density * vol / 4.0 * (1.0 if a == b else 0.0))
    lam_ = young * (poisson or 0.0) / ((1 + (poisson or 0.0)) * (1 - 2 * (poisson or 0.0)))
    mu_ = young / (2 * (1 + (poisson or 0.0)))
    # bars
    nb = bars.shape[0]
    bar_L = np.linalg.norm(X[bars[:, 1]] - X[bars[:, 0]], axis=1) if nb else np.zeros(0)
    if nb and np.any(bar_L <= 1e-12 * max(size, 1e-300)):
        e = int(np.flatnonzero(bar_L <= 1e-12 * max(size, 1e-300))[0])
        raise InputError(f"{key}.bars[{e}]", f"zero-length bar {bars[e].tolist()}")
    if nb:
        mb = density * area * bar_L
        for a in range(2):
            for b in range(2):
                rows.append(bars[:, a])
                cols.append(bars[:, b])
                vals.append(
                    mb / 6.0 * (2.0 if a == b else 1.0)
                    if mass_matrix == "consistent"
                    else mb / 2.0 * (1.0 if a == b else 0.0)
                )
    M = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nn, nn)).tocsr()
    M.sum_duplicates()
    if not M.sum() > 0:  # density times the elements' volume underflows
        total = float(M.sum())
        raise InputError(f"{key}.density", f"{density!r} kg/m3 gives the body a mass of {total!r} kg, not > 0")
    # gravity points
    gp_node, gp_w, gp_m = [], [], []
    for e in range(nt):
        for j in range(4):
            w = np.full(4, _TET_B)
            w[j] = _TET_A
            gp_node.append(tets[e])
            gp_w.append(w)
            gp_m.append(density * tet_V[e] / 4.0)
    g = 0.5 / np.sqrt(3.0)
    for e in range(nb):
        for xi in (0.5 - g, 0.5 + g):
            gp_node.append([bars[e, 0], bars[e, 1], -1, -1])
            gp_w.append([1.0 - xi, xi, 0.0, 0.0])
            gp_m.append(density * area * bar_L[e] / 2.0)
    R = np.asarray(R, float)
    x = np.asarray(position, float)[None] + X @ R.T
    v = np.asarray(velocity, float)[None] + np.cross(
        np.asarray(omega_space, float)[None], x - np.asarray(position)[None]
    )
    if (
        isinstance(node_output_every, bool)
        or not isinstance(node_output_every, (int, np.integer))
        or node_output_every < 1
    ):
        raise InputError(f"{key}.node_output_every", f"an integer >= 1 expected, got {node_output_every!r}")
    material = {
        "young": float(young),
        "young_unit": "Pa",
        "density": float(density),
        "density_unit": "kg / m3",
        "mass_matrix": mass_matrix,
    }
    if poisson is not None:
        material["poisson"] = float(poisson)
    if area is not None:
        material["area"] = float(area)
        material["area_unit"] = "m2"
    return ElasticSpec(
        name=name,
        nodes=x,
        velocities=v,
        ref=X,
        bars=bars,
        bar_EA=np.full(nb, young * (area or 0.0)),
        bar_L=bar_L,
        tets=tets,
        tet_g=tet_g,
        tet_V=tet_V,
        tet_lam=np.full(nt, lam_),
        tet_mu=np.full(nt, mu_),
        node_mass=M,
        gp_node=np.array(gp_node, dtype=np.int64).reshape(-1, 4),
        gp_w=np.array(gp_w, float).reshape(-1, 4),
        gp_m=np.array(gp_m, float),
        gravity=bool(gravity),
        node_output_every=int(node_output_every),
        material=material,
    )


def build_elastic(
    name,
    mesh,
    mesh_params,
    *,
    position,
    velocity,
    young,
    density,
    poisson,
    area,
    attitude,
    rotation_vector,
    angular_velocity,
    frame,
    gravity,
    mass_matrix,
    node_output_every,
    has_field: bool,
    strict: bool,
    key: str,
) -> ElasticSpec:
    """Check and convert an elastic body's input as a scene or the Python API gives it.

    Parameters
    ----------
    name : str
        The body's name.
    mesh : str
        One of :data:`MESH_KINDS`.
    mesh_params : dict
        The mesh's parameters (see :func:`mesh_from_parameters`).
    position, velocity : Quantity or sequence
        The body frame's initial position (m) and velocity (m/s).
    young : Quantity, str or float
        Young's modulus, Pa.
    density : Quantity, str or float
        Density, kg/m^3.
    poisson : float or None
        Poisson's ratio (tetrahedra).
    area : Quantity, str, float or None
        Cross-section of the bars, m^2.
    attitude, rotation_vector, angular_velocity, frame
        The body frame's attitude and rigid rotation (see
        :func:`~emorbit.bodies.rotations.attitude_matrix`).
    gravity : str or None
        ``"volume"`` or ``"none"``; None: ``"volume"`` with a field, else ``"none"``.
    mass_matrix : str
        ``"consistent"`` or ``"lumped"``.
    node_output_every : int
        Records between nodal-position outputs.
    has_field : bool
        Whether the simulation has a central field.
    strict : bool
        Require units on every value.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    ElasticSpec
        The body, placed and moving in space.

    Raises
    ------
    InputError
        A bad mesh, material, gravity model or value.
    """
    gravity = gravity or ("volume" if has_field else "none")
    if gravity not in ("volume", "none"):
        raise InputError(f"{key}.gravity", f"must be 'volume' or 'none', got {gravity!r}")
    if gravity == "volume" and not has_field:
        raise InputError(
            f"{key}.gravity",
            "'volume' needs a central field or an effect that acts at points; without one use 'none'",
        )
    E = to_si(young, "pressure", f"{key}.young", strict=strict, positive=True)
    rho = to_si(density, "density", f"{key}.density", strict=strict, positive=True)
    A = to_si(area, "area", f"{key}.area", strict=strict, positive=True) if area is not None else None
    if poisson is not None and (isinstance(poisson, bool) or not isinstance(poisson, numbers.Real)):
        raise InputError(f"{key}.poisson", f"a number expected, got {poisson!r}")
    X, tets, bars = mesh_from_parameters(mesh, mesh_params, strict, key)
    x = vector_to_si(position, "length", f"{key}.position", strict=strict)
    v = vector_to_si(velocity, "speed", f"{key}.velocity", strict=strict)
    R, omega = attitude_matrix(attitude, rotation_vector, angular_velocity, frame, strict, key)
    return elastic_spec(
        name,
        X,
        tets,
        bars,
        young=E,
        density=rho,
        poisson=poisson,
        area=A,
        mass_matrix=mass_matrix,
        position=x,
        velocity=v,
        R=R,
        omega_space=omega,
        gravity=gravity == "volume",
        node_output_every=node_output_every,
        key=key,
    )
