"""Property-based fuzz of HDF5 mesh files through ``emorbit run``: a valid mesh of
tetrahedra, of bars, or of both, with its datasets (``/nodes``, ``/tetrahedra``, ``/bars``)
deleted, replaced by groups, stored in other dtypes and shapes, given other values and
``unit`` attributes, and the file truncated or overwritten at random bytes; the scene with
or without ``mesh_unit``. Every case ends in a clean error naming a key of the elastic body
(exit 2, one line, no traceback, no output file), a correct run (exit 0: the run completes,
its records are finite and em keeps the energy), or a step that fails (exit 1, one line, a
"failed" file). Integer indices in any integer dtype and coordinates in any float or
integer dtype are valid; indices stored as floats are not, even where whole."""

from __future__ import annotations

import copy

import h5py
import numpy as np
from fuzz_support import clean_error, cli, correct_run, listing, run_failed, to_toml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from emorbit.bodies.meshes import beam_mesh, chain_mesh

SETTINGS = dict(deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))

_X, _T = beam_mesh([2.0, 0.4, 0.4], [2, 1, 1])
_C, _B = chain_mesh([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], 3)
#: valid meshes: {name: {dataset: array}}, coordinates in m
MESHES = {
    "tetrahedra": {"nodes": _X, "tetrahedra": _T},
    "bars": {"nodes": _C, "bars": _B},
    "both": {"nodes": _X, "tetrahedra": _T, "bars": np.array([[0, 1], [1, 2]])},
}
#: the elastic body of every case: in a circular orbit, a few steps
SCENE = {
    "field": {"gm": "3.9478 m3 / s2"},
    "integrator": {"method": "em", "dt": "0.464758 s", "t_end": "1.394274 s"},
    "body": [
        {
            "name": "part",
            "kind": "elastic",
            "mesh": "file",
            "file": "mesh.h5",
            "young": "1 MPa",
            "density": "100 kg / m3",
            "position": ["10 m", "0 m", "0 m"],
            "velocity": ["0 m/s", "0.6283 m/s", "0 m/s"],
        }
    ],
}
DATASETS = ("nodes", "tetrahedra", "bars")
#: dtypes a dataset may be stored in (the values converted, or made up where they cannot be)
DTYPES = ["f8", "f4", "f2", "i8", "i4", "u1", "u8", "i1", "c16", "?", "S8", "str", "compound"]
UNITS = ["m", "mm", "km", "cm", "s", "", "parsec of nonsense", b"m", 5, np.array([b"m", b"m"]), "m2", "1e3 m", "deg"]


def _as(a: np.ndarray, dtype: str) -> np.ndarray:
    if dtype == "str":
        return a.astype(str).astype(object)
    if dtype == "S8":
        return a.astype("S8")
    if dtype == "compound":
        out = np.zeros(a.shape, dtype=[("x", "f8"), ("y", "i4")])
        out["x"] = a
        return out
    with np.errstate(all="ignore"):
        return a.astype(dtype)


def _write(path, arrays: dict, unit) -> None:
    with h5py.File(path, "w") as f:
        for name, a in arrays.items():
            if isinstance(a, str) and a == "group":
                f.create_group(name)
            elif isinstance(a, np.ndarray) and a.dtype == object:
                f.create_dataset(name, data=a, dtype=h5py.string_dtype())
            else:
                f.create_dataset(name, data=a)
        if unit is not None and isinstance(f.get("nodes"), h5py.Dataset):
            f["nodes"].attrs["unit"] = unit


@st.composite
def mutation(draw, arrays: dict) -> str:
    """Change one dataset of ``arrays`` in place; say what changed."""
    name = draw(st.sampled_from(DATASETS))
    op = draw(st.sampled_from(["delete", "group", "dtype", "dtype", "shape", "value", "value", "empty"]))
    if name not in arrays:
        if op == "delete":
            return "nothing"
        arrays[name] = np.array([[0, 1]]) if name == "bars" else np.array([[0, 1, 2, 3]])
        return f"added /{name}"
    a = arrays[name]
    if not (isinstance(a, np.ndarray) and a.ndim == 2 and a.size and a.dtype.kind in "iuf"):
        op = draw(st.sampled_from(["delete", "group", "empty"]))  # changed before: no values to change
    if op == "delete":
        del arrays[name]
    elif op == "group":
        arrays[name] = "group"
    elif op == "empty":
        arrays[name] = np.zeros((0,) + np.shape(a)[1:], dtype=a.dtype if isinstance(a, np.ndarray) else "f8")
    elif op == "dtype":
        arrays[name] = _as(np.asarray(a), draw(st.sampled_from(DTYPES)))
    elif op == "shape":
        a = np.asarray(a)
        arrays[name] = draw(
            st.sampled_from(
                [a.T, a.ravel(), a[:, :-1], np.concatenate([a, a[:, :1]], axis=1), a[:, :, None], a[:1], a[None]]
            )
        )
    else:
        a = np.array(a, copy=True)
        row = draw(st.integers(0, max(0, a.shape[0] - 1)))
        col = draw(st.integers(0, a.shape[1] - 1))
        if name == "nodes":
            value = draw(st.sampled_from([np.nan, np.inf, -np.inf, 1e300, 1e160, -1e-300, 0.0, 3.0, 1e6]))
            if draw(st.booleans()):
                a[row, col] = value
            else:
                with np.errstate(over="ignore"):
                    a = a * draw(st.sampled_from([0.0, 1e-300, 1e-9, 1e200, -1.0, 1e3]))
        else:
            n = arrays["nodes"].shape[0] if isinstance(arrays.get("nodes"), np.ndarray) else 8
            value = draw(st.sampled_from([-1, n, n + 5, 2**62, a[row, (col + 1) % a.shape[1]], 0]))
            if draw(st.booleans()):
                a[row, col] = value
            else:  # swap two nodes of an element: the other orientation
                a[row, [0, 1]] = a[row, [1, 0]]
        arrays[name] = a
    return f"{op} /{name}"


@st.composite
def mesh_cases(draw):
    kind = draw(st.sampled_from(sorted(MESHES)))
    arrays = copy.deepcopy(MESHES[kind])
    what = [draw(mutation(arrays)) for _ in range(draw(st.sampled_from([0, 0, 1, 1, 1, 2])))]
    unit = draw(st.sampled_from(["m"] * 14 + [None] + UNITS))
    scene_unit = draw(st.sampled_from([None] * 8 + ["m", "mm", "s", 5]))
    damage = draw(st.sampled_from([None] * 12 + ["truncate", "overwrite", "empty", "not hdf5"]))
    offset = draw(st.floats(0.0, 1.0))
    return kind, arrays, what, unit, scene_unit, damage, offset


def _scene(kind: str, scene_unit) -> dict:
    d = copy.deepcopy(SCENE)
    b = d["body"][0]
    if kind in ("tetrahedra", "both"):
        b["poisson"] = 0.3
    if kind in ("bars", "both"):
        b["area"] = "1 cm2"
    if scene_unit is not None:
        b["mesh_unit"] = scene_unit
    return d


def test_the_meshes_are_valid(tmp_path):
    for kind, arrays in MESHES.items():
        _write(tmp_path / "mesh.h5", arrays, "m")
        (tmp_path / "scene.toml").write_text(to_toml(_scene(kind, None)))
        out = tmp_path / f"{kind}.h5"
        code, _, err = cli(["run", tmp_path / "scene.toml", "-o", out, "-q"])
        assert code == 0, err
        correct_run(out, 1.394274, err)


@settings(max_examples=200, **SETTINGS)
@given(case=mesh_cases())
def test_generated_meshes(tmp_path_factory, case):
    kind, arrays, what, unit, scene_unit, damage, offset = case
    folder = tmp_path_factory.mktemp("mesh")
    mesh = folder / "mesh.h5"
    _write(mesh, arrays, unit)
    if damage is not None:
        raw = mesh.read_bytes()
        at = int(offset * len(raw))
        raw = {
            "truncate": raw[:at],
            "overwrite": raw[:at] + bytes(64) + raw[at + 64 :],
            "empty": b"",
            "not hdf5": b"nodes = [[0, 0, 0]]\n",
        }[damage]
        mesh.write_bytes(raw)
    (folder / "scene.toml").write_text(to_toml(_scene(kind, scene_unit)))
    before = listing(folder)
    out = folder / "out.h5"
    code, _, err = cli(["run", folder / "scene.toml", "-o", out, "-q"])
    event(f"exit {code}")
    if code == 2:
        key = clean_error(code, err)
        assert key.startswith("body[0]"), f"{key!r} is not a key of the elastic body ({what}): {err}"
        assert listing(folder) == before
        return
    if code == 1:
        run_failed(code, err, out)
        return
    assert code == 0, err
    correct_run(out, 1.394274, err)
