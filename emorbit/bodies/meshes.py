"""Elastic bodies' meshes, in the body frame: generated, or read from a file with its unit.

Generated meshes:

* ``beam``: a box of ``size`` = (Lx, Ly, Lz) centred on the origin, ``elements`` = (nx, ny, nz)
  hexahedral cells each cut into 6 tetrahedra (Kuhn's conforming split);
* ``chain``: ``elements`` bars from ``start`` to ``end`` (a tether);
* ``net``: a grid of bars in the x-y plane, ``size`` = (Lx, Ly), ``elements`` = (nx, ny),
  centred on the origin.

Mesh files (``file``): an HDF5 file with ``/nodes`` (n, 3) (attribute ``unit``, or the
scene's ``mesh_unit``) and ``/tetrahedra`` (m, 4) and/or ``/bars`` (m, 2) of 0-based node
indices stored as integers; or any format meshio reads (points and "tetra"/"line" cells,
coordinates in ``mesh_unit``), when meshio is installed. Sizes are bounded
(:data:`MAX_MESH`) before anything is allocated; errors name the key.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..errors import InputError
from ..units import to_si, vector_to_si

__all__ = ["MESH_KINDS", "MAX_MESH", "beam_mesh", "chain_mesh", "net_mesh", "read_mesh", "mesh_from_parameters"]

#: the meshes an elastic body can be given
MESH_KINDS = ("beam", "chain", "net", "file")
#: the most nodes or elements a generated mesh may have
MAX_MESH = 1_000_000


def _grid(size, elements, dim: int, key: str):
    """``size`` as ``dim`` lengths > 0 and ``elements`` as ``dim`` integers >= 1 (arrays), or an
    error naming ``key.size`` / ``key.elements``."""
    word = {2: "two", 3: "three"}[dim]
    L = np.asarray(size, float)
    n = np.asarray(elements)
    if L.shape != (dim,) or not np.all(L > 0):
        raise InputError(f"{key}.size", f"{word} lengths > 0 expected, got {size!r}")
    if n.shape != (dim,) or not np.issubdtype(n.dtype, np.integer) or not np.all(n >= 1):
        raise InputError(f"{key}.elements", f"{word} integers >= 1 expected, got {elements!r}")
    k = [int(c) for c in n]
    _mesh_size(math.prod(c + 1 for c in k), 6 * math.prod(k) if dim == 3 else 2 * k[0] * k[1] + k[0] + k[1], key)
    return L, n


def _mesh_size(nodes: int, elements: int, key: str) -> None:
    if max(nodes, elements) > MAX_MESH:
        raise InputError(
            f"{key}.elements", f"{nodes:,} nodes and {elements:,} elements, more than a mesh may have ({MAX_MESH:,})"
        )


def beam_mesh(size, elements, key: str = "body"):
    """A box meshed with tetrahedra: 6 per hexahedral cell (Kuhn's conforming split).

    Parameters
    ----------
    size : array_like
        (Lx, Ly, Lz), m; the box is centred on the origin.
    elements : array_like
        (nx, ny, nz) cells along each axis.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    nodes : ndarray
        (n, 3), m.
    tetrahedra : ndarray
        (6 nx ny nz, 4) node indices, positively oriented.

    Raises
    ------
    InputError
        Sizes or counts that are not positive.
    """
    L, n = _grid(size, elements, 3, key)
    axes = [np.linspace(-L[k] / 2, L[k] / 2, n[k] + 1) for k in range(3)]
    X = np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T
    idx = np.arange(X.shape[0]).reshape(n[0] + 1, n[1] + 1, n[2] + 1)
    # Kuhn: the 6 tetrahedra along the diagonal (0,0,0)-(1,1,1) of each cell, one per axis order
    orders = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    tets = []
    for i in range(n[0]):
        for j in range(n[1]):
            for k in range(n[2]):
                for order in orders:
                    p = np.array([i, j, k])
                    verts = [idx[tuple(p)]]
                    for ax in order:
                        p = p.copy()
                        p[ax] += 1
                        verts.append(idx[tuple(p)])
                    tets.append(verts)
    T = np.array(tets, dtype=np.int64)
    # orient every element positively
    P = X[T]
    vol = np.einsum("ij,ij->i", np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), P[:, 3] - P[:, 0])
    T[vol < 0] = T[vol < 0][:, [0, 2, 1, 3]]
    return X, T


def chain_mesh(start, end, elements, key: str = "body"):
    """A chain of bars on a segment (a tether).

    Parameters
    ----------
    start, end : array_like
        The ends (3,), m.
    elements : int
        Number of bars.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    nodes : ndarray
        (elements + 1, 3), m.
    bars : ndarray
        (elements, 2) node indices.

    Raises
    ------
    InputError
        ``elements`` is not an integer >= 1.
    """
    a = np.asarray(start, float)
    b = np.asarray(end, float)
    if isinstance(elements, bool) or not isinstance(elements, (int, np.integer)) or elements < 1:
        raise InputError(f"{key}.elements", f"an integer >= 1 expected, got {elements!r}")
    _mesh_size(int(elements) + 1, int(elements), key)
    t = np.linspace(0.0, 1.0, int(elements) + 1)
    X = a[None] + t[:, None] * (b - a)[None]
    bars = np.stack([np.arange(elements), np.arange(1, elements + 1)], 1)
    return X, bars


def net_mesh(size, elements, key: str = "body"):
    """A rectangular net of bars in the x-y plane, centred on the origin.

    Parameters
    ----------
    size : array_like
        (Lx, Ly), m.
    elements : array_like
        (nx, ny) cells along each axis.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    nodes : ndarray
        ((nx + 1) (ny + 1), 3), m.
    bars : ndarray
        The grid's edges as node index pairs.

    Raises
    ------
    InputError
        Sizes or counts that are not positive.
    """
    L, n = _grid(size, elements, 2, key)
    xs = np.linspace(-L[0] / 2, L[0] / 2, n[0] + 1)
    ys = np.linspace(-L[1] / 2, L[1] / 2, n[1] + 1)
    X = np.array([[x, y, 0.0] for x in xs for y in ys])
    idx = np.arange(X.shape[0]).reshape(n[0] + 1, n[1] + 1)
    bars = [(idx[i, j], idx[i + 1, j]) for i in range(n[0]) for j in range(n[1] + 1)]
    bars += [(idx[i, j], idx[i, j + 1]) for i in range(n[0] + 1) for j in range(n[1])]
    return X, np.array(bars, dtype=np.int64)


def _length_scale(unit, key: str, what: str) -> float:
    """Metres per ``unit`` (a string naming a length), or an error naming ``key``."""
    if isinstance(unit, bytes):
        unit = unit.decode(errors="replace")
    if not isinstance(unit, str):
        raise InputError(key, f"{what} must be a length unit such as 'm', got {unit!r}")
    try:
        return to_si(f"1 {unit}", "length", key)
    except InputError:
        raise InputError(key, f"{what} {unit!r} is not a length unit") from None


def read_mesh(path, key: str = "body", mesh_unit: str | None = None):
    """Read a mesh file: HDF5 in emorbit's layout, or any format meshio reads.

    The HDF5 layout: ``/nodes`` (n, 3) numbers with a ``unit`` attribute (a length),
    ``/tetrahedra`` (m, 4) and/or ``/bars`` (m, 2) of 0-based node indices, stored as
    integers. Without a ``unit`` attribute, and for meshio files (which carry no unit), the
    unit is ``mesh_unit``; where both are given they must agree.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    key : str
        Prefix of the keys that error messages name.
    mesh_unit : str, optional
        The unit of the coordinates, e.g. ``"mm"``.

    Returns
    -------
    nodes : ndarray
        (n, 3), m.
    tetrahedra : ndarray
        (k, 4) node indices.
    bars : ndarray
        (m, 2) node indices.

    Raises
    ------
    InputError
        No such file, no ``/nodes``, coordinates that are not numbers, indices that are not
        integers (float values or a float dtype), no unit anywhere, a unit that is not a
        length or disagrees with ``mesh_unit``, or a non-HDF5 file without meshio installed.
    """
    from .shapes import mesh_coordinates, mesh_indices

    where = f"{key}.file"
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(where, f"a path (a string) expected, got {path!r}")
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(where, f"mesh file {path!r} does not exist")
    given = None if mesh_unit is None else _length_scale(mesh_unit, f"{key}.mesh_unit", "mesh_unit")
    if path.endswith((".h5", ".hdf5")):
        arrays, unit = _read_hdf5(path, where)
        scale = given
        if unit is not None:
            scale = _length_scale(unit, where, f"{path!r}: the unit attribute of /nodes")
            if given is not None and given != scale:
                raise InputError(
                    f"{key}.mesh_unit", f"{mesh_unit!r} disagrees with the unit {unit!r} of /nodes in {path!r}"
                )
        elif scale is None:
            raise InputError(
                f"{key}.mesh_unit",
                f"/nodes in {path!r} has no unit attribute: give the unit of its coordinates with mesh_unit "
                '(e.g. "m"), or write it into the file (/nodes attribute unit)',
            )
        X = mesh_coordinates(arrays["nodes"], where, f"/nodes of {path!r}", scale)
        T, B = (
            mesh_indices([] if arrays[name] is None else arrays[name], width, where, f"/{name} of {path!r}")
            for name, width in (("tetrahedra", 4), ("bars", 2))
        )
        return X, T, B
    try:
        import meshio
    except ImportError:
        raise InputError(
            where,
            f"{path!r} is not HDF5 and meshio is not installed (pip install meshio, or use the HDF5 layout)",
        ) from None
    if given is None:
        raise InputError(f"{key}.mesh_unit", f'missing: {path!r} carries no unit; give mesh_unit, e.g. "m"')
    m = meshio.read(path)
    T = np.concatenate([c.data for c in m.cells if c.type == "tetra"] or [np.zeros((0, 4), np.int64)])
    B = np.concatenate([c.data for c in m.cells if c.type == "line"] or [np.zeros((0, 2), np.int64)])
    return (
        mesh_coordinates(np.asarray(m.points), where, f"the points of {path!r}", given),
        mesh_indices(T, 4, where, f"the tetra cells of {path!r}"),
        mesh_indices(B, 2, where, f"the line cells of {path!r}"),
    )


def _read_hdf5(path: str, where: str):
    """The arrays /nodes, /tetrahedra, /bars (None where absent) of an HDF5 mesh file and the
    unit attribute of /nodes; a file that HDF5 cannot read (damaged, truncated) is an error."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            arrays = {}
            for name in ("nodes", "tetrahedra", "bars"):
                if name in f and not isinstance(f[name], h5py.Dataset):
                    raise InputError(where, f"{path!r}: /{name} is not a dataset")
                arrays[name] = f[name][()] if name in f else None
            if arrays["nodes"] is None:
                raise InputError(where, f"{path!r} has no /nodes dataset")
            return arrays, f["nodes"].attrs.get("unit")
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:  # h5py's errors on a damaged file
        if isinstance(exc, InputError):
            raise
        raise InputError(where, f"{path!r} is not a readable HDF5 file ({' '.join(str(exc).split())})") from None


def mesh_from_parameters(mesh, params: dict, strict: bool, key: str):
    """A mesh from its kind and parameters, as a scene gives them.

    Parameters
    ----------
    mesh : str
        One of :data:`MESH_KINDS`.
    params : dict
        beam: ``size``, ``elements``; chain: ``start``, ``end``, ``elements``; net:
        ``size``, ``elements``; file: ``file`` [, ``mesh_unit``].
    strict : bool
        Require units on lengths.
    key : str
        Prefix of the keys that error messages name (``key.<parameter>``).

    Returns
    -------
    nodes : ndarray
        (n, 3), m.
    tetrahedra : ndarray
        (k, 4) node indices (empty for bar meshes).
    bars : ndarray
        (m, 2) node indices (empty for beams).

    Raises
    ------
    InputError
        An unknown mesh or parameter, a missing one, or a bad value.
    """
    allowed = {
        "beam": ("size", "elements"),
        "chain": ("start", "end", "elements"),
        "net": ("size", "elements"),
        "file": ("file", "mesh_unit"),
    }
    if not isinstance(mesh, str) or mesh not in allowed:  # a list or a table cannot be looked up
        raise InputError(f"{key}.mesh", f"unknown mesh {mesh!r}; known: {', '.join(allowed)}")
    for p in params:
        if p not in allowed[mesh]:
            raise InputError(f"{key}.{p}", f"not a parameter of mesh {mesh!r}; allowed: {', '.join(allowed[mesh])}")
    for p in allowed[mesh]:
        if p not in params and p != "mesh_unit":
            raise InputError(f"{key}.{p}", f"missing (required for mesh {mesh!r})")
    empty = np.zeros((0, 4), np.int64), np.zeros((0, 2), np.int64)
    if mesh == "beam":
        X, T = beam_mesh(vector_to_si(params["size"], "length", f"{key}.size", strict=strict), params["elements"], key)
        return X, T, empty[1]
    if mesh == "chain":
        X, B = chain_mesh(
            vector_to_si(params["start"], "length", f"{key}.start", strict=strict),
            vector_to_si(params["end"], "length", f"{key}.end", strict=strict),
            params["elements"],
            key,
        )
        return X, empty[0], B
    if mesh == "net":
        size = params["size"]
        if isinstance(size, str) or not hasattr(size, "__len__") or len(size) != 2:
            raise InputError(f"{key}.size", f"two lengths expected, got {size!r}")
        L = [to_si(s_, "length", f"{key}.size[{i}]", strict=strict, positive=True) for i, s_ in enumerate(size)]
        X, B = net_mesh(L, params["elements"], key)
        return X, empty[0], B
    return read_mesh(params["file"], key, params.get("mesh_unit"))
