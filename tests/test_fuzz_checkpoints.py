"""Property-based fuzz of run files through ``emorbit resume``: real files of a point mass, a
rigid body and a coupled structure (two boxes joined by a tether), their checkpoint at the
end or in the middle, edited: root and checkpoint attributes deleted or given other types and
values, state arrays and record datasets deleted, reshaped, retyped, resized or given other
values, body groups renamed, the scene text rewritten or changed, the file truncated or
overwritten at random bytes. Every case ends in one of:

* a clean error: exit 2, one line on stderr naming the file, no traceback, the file
  byte for byte as it was and nothing else in its folder;
* a correct continuation: exit 0, and every record and the final state equal, bit for bit,
  to those of one unbroken run to the same end (a dataset the edit changed is compared from
  the checkpoint's record on: the records before it are the file's own).
"""

from __future__ import annotations

import shutil
import sys

import h5py
import numpy as np
import pytest
from fuzz_support import clean_error, cli, listing, run_failed, to_toml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

SETTINGS = dict(deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))

#: scene, (t0, t1, t2), checkpoint_every: runs to t1 (checkpoint at t1, or at t0 in the
#: "middle" variant), resumed to t2, against an unbroken run to t2
RUNS = {
    "point": ("paper-ellipse", ("23.2379 s", "46.4758 s", "92.9516 s"), 20),
    "rigid": ("rigid-tumbling-box", ("0.3 s", "0.6 s", "1.2 s"), 10),
    "coupled": ("tethered-satellites", ("40 s", "80 s", "160 s"), 20),
}
STATE_GROUPS = ("checkpoint", "checkpoint_next", "final_state")


class _Files(dict):
    """{(run, variant): path} and {run: reference path}; printed in one word by hypothesis."""

    def __repr__(self) -> str:
        return f"<{len(self)} run files>"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs")
    out = _Files()
    for run, (scene, (t0, t1, t2), cp) in RUNS.items():
        paths = {}
        for name, t_end in (("t0", t0), ("end", t1), ("reference", t2)):
            paths[name] = folder / f"{run}-{name}.h5"
            code, _, err = cli(["run", scene, "-o", paths[name], "-q", "--t-end", t_end, "--checkpoint-every", cp])
            assert code == 0, err
        middle = folder / f"{run}-middle.h5"
        shutil.copy(paths["end"], middle)
        with h5py.File(middle, "r+") as f, h5py.File(paths["t0"], "r") as g:  # as a run killed after t0
            del f["checkpoint"]
            g.copy(g["checkpoint"], f, "checkpoint")
            f.attrs["status"] = "running"
        out[(run, "end")] = paths["end"]
        out[(run, "middle")] = middle
        out[run] = paths["reference"]
    return out


# -- edits --------------------------------------------------------------------------------------
def _datasets(f, under: str = "") -> list[str]:
    names = []
    (f[under] if under else f).visititems(
        lambda n, o: names.append(f"{under}/{n}" if under else n) if isinstance(o, h5py.Dataset) else None
    )
    return names


ODD_VALUES = [None, "abc", b"xyz", -1, 0, 1, 2.5, np.nan, np.inf, 1e300, -(2**62), np.array([1.0, 2.0]), True]


def _attribute_value(draw, old):
    """Another value for an attribute: a variant of the old one, or one of another type."""
    options = list(ODD_VALUES)
    if isinstance(old, (int, np.integer)) and not isinstance(old, bool):
        options += [int(old) + 1, int(old) - 1, 2 * int(old), float(old), np.int32(old), 10**9]
    elif isinstance(old, (float, np.floating)):
        options += [float(old) * 2, float(old) * (1 + 2e-16), -float(old), float(old) + 1.0]
    elif isinstance(old, str):
        options += ["em", "midpoint", "leapfrog", "rk4", "completed", "", old + " "]
    return draw(st.sampled_from(options))


def _set_attr(obj, name, value) -> None:
    if value is None:
        if name in obj.attrs:
            del obj.attrs[name]
    else:
        obj.attrs[name] = value


#: state arrays that only start the next step's Newton iteration (the last step's mean
#: acceleration, Lagrange multipliers, kept factors): nothing in the file says what they were, and
#: another start converges to the same step up to round-off
WARM_STARTS = ("structure/acc", "structure/lam", "rigid/lam", "structure/last_iterations", "structure/lu_")


def roundoff_edit(what: str) -> bool:
    """Whether an edit changes the run by round-off only, which no check can see: a state value
    moved by an ulp, a compensation term (itself a rounding error) moved within its ulp, or a
    warm start changed to finite values."""
    name, _, how = what.partition(" ")
    field = name.rpartition("/")[2]
    if not name.startswith(("checkpoint/", "checkpoint_next/")) or not how.startswith("value"):
        return False
    return (
        how.startswith("value ulp")
        or (field in ("cx", "cv", "cq", "cu") and how.startswith(("value zero", "value negate")))
        or any(w in name for w in WARM_STARTS)
    )


def _new_array(draw, old: np.ndarray, warm_start: bool = False):
    """Another array for a dataset: reshaped, retyped, resized, or with a value changed (for a
    warm start not to 1e300: test_an_absurd_warm_start_fails_cleanly)."""
    how = draw(st.sampled_from(["transpose", "ravel", "drop row", "add row", "drop column", "dtype", "value"]))
    a = np.array(old, copy=True)
    if how == "transpose" and a.ndim >= 2:
        return a.T, how
    if how == "ravel":
        return a.ravel(), how
    if how == "drop row" and a.shape and a.shape[0]:
        return a[:-1], how
    if how == "add row" and a.shape:
        return np.concatenate([a, a[-1:] if a.shape[0] else np.zeros((1,) + a.shape[1:])]), how
    if how == "drop column" and a.ndim >= 2:
        return a[:, :-1], how
    if how == "dtype":
        dtype = draw(st.sampled_from(["f4", "i8", "u1", "c16", "?", "S4"]))
        with np.errstate(all="ignore"):
            return a.astype(dtype), f"dtype {dtype}"
    if a.size == 0:
        return a, "unchanged"
    flat = a.reshape(-1)
    i = draw(st.integers(0, flat.size - 1))
    value = draw(st.sampled_from(["nan", "inf", "zero", "ulp", "1e-3", "negate"] + ([] if warm_start else ["huge"])))
    with np.errstate(all="ignore"):
        flat[i] = {
            "nan": np.nan,
            "inf": np.inf,
            "zero": 0.0,
            "ulp": np.nextafter(flat[i], np.inf),
            "1e-3": flat[i] * (1 + 1e-3) + 1e-3,
            "negate": -flat[i],
            "huge": 1e300,
        }[value]
    return a, f"value {value} at {i}"


def _replace(f, name: str, data) -> None:
    growable = name in _datasets(f) and f[name].maxshape and f[name].maxshape[0] is None
    unit = f[name].attrs.get("unit") if name in f else None
    del f[name]
    if growable and np.ndim(data) >= 1 and data.dtype.kind in "fiu":
        f.create_dataset(name, data=data, maxshape=(None,) + np.shape(data)[1:], chunks=True)
    else:
        f.create_dataset(name, data=data)
    if unit is not None:
        f[name].attrs["unit"] = unit


def _scene_edit(draw, text: str) -> tuple[str, str]:
    """The scene text rewritten (the same scene as TOML without comments) or changed."""
    d = tomllib.loads(text)
    how = draw(st.sampled_from(["rewritten", "mass", "gm", "rename", "drop body", "add key", "dt", "method"]))
    body = d["body"][draw(st.integers(0, len(d["body"]) - 1))]
    if how == "mass" and "mass" in body:
        body["mass"] = "2 kg"
    elif how == "gm" and "field" in d:
        d["field"] = {"gm": "4 m3 / s2"}
    elif how == "rename":
        body["name"] = body["name"] + "2"
    elif how == "drop body" and len(d["body"]) > 1 and "coupling" not in d:
        d["body"].remove(body)
    elif how == "add key":
        body["colour"] = "red"
    elif how == "dt":
        d["integrator"]["dt"] = "0.1 s"
    elif how == "method":
        d["integrator"]["method"] = "midpoint"
    else:
        how = "rewritten"
    return to_toml(d), how


@st.composite
def edit(draw, f) -> tuple[str, set]:
    """Apply one edit to the open file ``f``; return (what, the datasets it touched)."""
    where = draw(st.sampled_from(["root attribute", "checkpoint attribute", "state", "records", "structure", "scene"]))
    cp = "checkpoint" if "checkpoint" in f else "checkpoint_next"
    if where in ("checkpoint attribute", "state") and not (isinstance(f.get(cp), h5py.Group) and _datasets(f, cp)):
        where = "records"  # an earlier edit took the checkpoint's arrays
    if where == "root attribute":
        name = draw(st.sampled_from(sorted(f.attrs)))
        value = _attribute_value(draw, f.attrs[name])
        _set_attr(f, name, value)
        return f"@{name} = {value!r}", set()
    if where == "checkpoint attribute":
        name = draw(st.sampled_from(sorted(f[cp].attrs)))
        value = _attribute_value(draw, f[cp].attrs[name])
        _set_attr(f[cp], name, value)
        return f"/{cp}@{name} = {value!r}", set()
    if where == "scene" and isinstance(f.attrs.get("scene"), str):
        text, how = _scene_edit(draw, f.attrs["scene"])
        f.attrs["scene"] = text
        return f"scene {how}", set()
    if where == "structure":
        how = draw(
            st.sampled_from(["rename body", "drop body", "add body", "checkpoint_next", "drop final_state", "group"])
        )
        bodies = sorted(f["bodies"])
        if not bodies and how in ("rename body", "drop body", "add body"):
            how = "group"  # an earlier edit dropped the only body
        if how == "rename body":
            f.move(f"bodies/{bodies[0]}", f"bodies/{bodies[0]}x")
        elif how == "drop body":
            del f[f"bodies/{bodies[-1]}"]
        elif how == "add body":
            f.copy(f[f"bodies/{bodies[0]}"], f["bodies"], f"extra{len(bodies)}")  # a new name per edit
        elif how == "checkpoint_next" and cp == "checkpoint":
            f.move("checkpoint", "checkpoint_next")
            if draw(st.booleans()):
                del f["checkpoint_next"].attrs["complete"]
        elif how == "drop final_state" and "final_state" in f:
            del f["final_state"]
        else:
            names = _datasets(f, cp) if isinstance(f.get(cp), h5py.Group) else []
            if not names:
                return "no checkpoint dataset left to turn into a group", set()
            name = draw(st.sampled_from(names))
            del f[name]
            f.create_group(name)
            return f"{name} a group", {name}
        return how, set()
    if where == "scene":
        where = "records"  # an earlier edit took the scene
    names = _datasets(f, cp) if where == "state" else [n for n in _datasets(f) if not n.startswith(STATE_GROUPS)]
    name = draw(st.sampled_from(names))
    if draw(st.integers(0, 5)) == 0:
        del f[name]
        return f"{name} deleted", {name}
    ds = f[name]
    if where == "records" and ds.maxshape and ds.maxshape[0] is None and draw(st.booleans()):
        rows = draw(st.sampled_from([0, 1, ds.shape[0] - 1, ds.shape[0] + 1, ds.shape[0] + 1000]))
        ds.resize(max(rows, 0), axis=0)
        return f"{name} resized to {rows} rows", {name}
    data, how = _new_array(draw, ds[()], any(w in name for w in WARM_STARTS))
    _replace(f, name, data)
    return f"{name} {how}", {name}


@st.composite
def checkpoint_cases(draw):
    run = draw(st.sampled_from(sorted(RUNS)))
    variant = draw(st.sampled_from(["end", "middle"]))
    n_edits = draw(st.sampled_from([0, 1, 1, 1, 1, 2]))
    damage = draw(st.sampled_from([None] * 9 + ["truncate", "overwrite"]))
    return run, variant, n_edits, damage, draw(st.floats(0.0, 1.0))


def _same_continuation(path, reference, records: int, touched: set) -> None:
    """Every dataset of the reference run's records and final state is in ``path`` and equal
    bit for bit (a touched record dataset after the checkpoint's row ``records - 1``); nothing
    else is there."""
    with h5py.File(path, "r") as f, h5py.File(reference, "r") as r:
        assert f.attrs["status"] == "completed"
        for name in ("steps", "t_end", "method", "order", "dt", "output_every"):
            assert f.attrs[name] == r.attrs[name], name
        ours = {n for n in _datasets(f) if not n.startswith(("checkpoint", "checkpoint_next"))}
        theirs = {n for n in _datasets(r) if not n.startswith(("checkpoint", "checkpoint_next"))}
        assert ours - touched == theirs - touched, ours ^ theirs
        if any(t.endswith("drift/scale") for t in touched):
            # the drift monitor's running round-off scale: a resume checks it against the drift
            # recorded with the checkpoint, which cannot show it where that drift is 0; a changed
            # scale changes the drift measured after the checkpoint (a diagnostic), not the run
            theirs -= {"diagnostics/invariant_drift", "final_state/drift/scale", "final_state/drift/progress"}
        for name in sorted(theirs):
            if name in touched:
                if name not in f or not (r[name].maxshape and r[name].maxshape[0] is None) or "/nodes/" in name:
                    continue  # written once (a body's constants), or nodal records: the file's own data
                a, b = f[name][records:], r[name][records:]  # a record dataset: the continuation
            else:
                a, b = f[name][()], r[name][()]
            if name == "final_state/drift/scale":  # the running scale of an invariant the run does not check
                checked = r["diagnostics/invariant_drift"][-1] >= 0  # is in no record, and may be the edit's
                a, b = a[checked], b[checked]
            assert a.dtype == b.dtype and a.shape == b.shape, (name, a.dtype, b.dtype, a.shape, b.shape)
            assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name


def test_the_run_files_resume(tmp_path, files):
    """Untouched, every file continues to the unbroken run."""
    for run, (_, (_, _, t2), _) in RUNS.items():
        for variant in ("end", "middle"):
            path = tmp_path / f"{run}-{variant}.h5"
            shutil.copy(files[(run, variant)], path)
            with h5py.File(path, "r") as f:
                records = int(f["checkpoint"].attrs["records"])
            code, _, err = cli(["resume", path, "--t-end", t2, "-q"])
            assert code == 0, err
            _same_continuation(path, files[run], records, set())


@settings(max_examples=80, **SETTINGS)
@given(case=checkpoint_cases(), data=st.data())
def test_generated_checkpoints(tmp_path_factory, files, case, data):
    run, variant, n_edits, damage, offset = case
    folder = tmp_path_factory.mktemp("resume")
    path = folder / "run.h5"
    shutil.copy(files[(run, variant)], path)
    with h5py.File(path, "r") as f:
        records = int(f["checkpoint"].attrs["records"])
    what, touched = [], set()
    with h5py.File(path, "r+") as f:
        for _ in range(n_edits):
            w, t = data.draw(edit(f), label="edit")
            what.append(w)
            touched |= t
    if damage is not None:
        raw = bytearray(path.read_bytes())
        at = int(offset * len(raw))
        raw = raw[:at] if damage == "truncate" else raw[:at] + bytes(64) + raw[at + 64 :]
        path.write_bytes(bytes(raw))
        what.append(f"{damage} at byte {at}")
    before = path.read_bytes()
    listed = listing(folder)
    code, _, err = cli(["resume", path, "--t-end", RUNS[run][1][2], "-q"])
    event(f"exit {code}")
    if code == 2:
        key = clean_error(code, err)
        assert key == "file", f"{what}: {err}"
        assert str(path) in err, f"{what}: {err}"
        assert path.read_bytes() == before, f"{what}: the file changed on a refusal: {err}"
        assert listing(folder) == listed
        return
    lenient = what and all(roundoff_edit(w) for w in what)
    if code == 1 and lenient:  # a warm start far from the step's solution: Newton fails, and says so
        run_failed(code, err, path)
        return
    assert code == 0, f"{what}: exit {code}: {err}"
    assert listing(folder) == listed
    if lenient:
        event("a change at round-off: the continuation to round-off")
        _close_continuation(path, files[run], records)
    else:
        _same_continuation(path, files[run], records, touched)


def _close_continuation(path, reference, records: int) -> None:
    """The records after the checkpoint equal the reference run's to round-off (amplified by
    the few steps of a tumbling box and a stiff tether)."""
    with h5py.File(path, "r") as f, h5py.File(reference, "r") as r:
        assert f.attrs["status"] == "completed" and f["time"].shape == r["time"].shape
        for name in ["time", "invariants/energy", "invariants/angular_momentum"] + [
            f"bodies/{b}/{q}" for b in r["bodies"] for q in ("position", "velocity") if q in r["bodies"][b]
        ]:
            a, b = f[name][records:], r[name][records:]
            scale = max(float(np.max(np.abs(r[name][()]))), 1e-300)
            assert np.max(np.abs(a - b), initial=0.0) <= 1e-9 * scale, name


def test_an_absurd_warm_start_fails_cleanly(tmp_path, files):
    """A structure's warm start (its last step's mean acceleration) edited to 1e300 is refused
    by the checkpoint's digest; with the digest gone too, the resumed step fails and says so in
    one line."""
    path = tmp_path / "run.h5"
    shutil.copy(files[("coupled", "end")], path)
    with h5py.File(path, "r+") as f:
        f["checkpoint/structure/acc"][0, 0] = 1e300
    before = path.read_bytes()
    code, _, err = cli(["resume", path, "--t-end", RUNS["coupled"][1][2], "-q"])
    assert clean_error(code, err) == "file" and "digest" in err, err
    assert path.read_bytes() == before
    with h5py.File(path, "r+") as f:
        del f["checkpoint"].attrs["digest"]  # a file written before digests: the warm start is taken
    code, _, err = cli(["resume", path, "--t-end", RUNS["coupled"][1][2], "-q"])
    run_failed(code, err, path)
