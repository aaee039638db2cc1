"""A structure in Newton's "reuse" mode keeps LU factors across steps; they are part of its
checkpoint state, so a run gives the same bits wherever its checkpoints fall, and a resume from
any checkpoint equals the unbroken run."""

import h5py
import numpy as np
import pytest
from shared_scenes import reuse_structure

import emorbit
from emorbit.io.resume import resume

SCENE = reuse_structure("2 s")


def _records(path) -> dict:
    """Every record dataset of a run file (not the checkpoint or final state)."""
    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not name.startswith(("checkpoint", "final_state")):
                out[name] = obj[()]

        f.visititems(visit)
    return out


def _same(a: dict, b: dict) -> list:
    return sorted(k for k in set(a) | set(b) if k not in a or k not in b or not np.array_equal(a[k], b[k]))


def _run(tmp_path, name, t_end, checkpoint_every):
    sim = emorbit.parse_scene(SCENE).build()
    assert sim.structure is not None
    path = tmp_path / f"{name}.h5"
    sim.run(t_end, every=3, output=path, checkpoint_every=checkpoint_every, progress=False)
    assert sim.structure.newton == "reuse"
    return path


def test_checkpoint_positions_do_not_change_the_results(tmp_path):
    reference = _records(_run(tmp_path, "once", "2 s", 10_000))
    for every in (3, 21, 60):
        assert _same(_records(_run(tmp_path, f"cp{every}", "2 s", every)), reference) == [], every


@pytest.mark.parametrize("t1", ["0.33 s", "0.9 s", "1.5 s"])
def test_resume_from_any_checkpoint_equals_the_unbroken_run(tmp_path, t1):
    reference = _records(_run(tmp_path, "once", "2 s", 10_000))
    part = _run(tmp_path, "part", t1, 9)
    resume(part, "2 s", progress=False)
    assert _same(_records(part), reference) == []
    with h5py.File(part, "r") as f:  # the kept factors are in the checkpoint
        assert f["checkpoint/structure/lu_jacobians"].shape[0] >= 1


def test_a_bad_newton_state_is_refused(tmp_path):
    part = _run(tmp_path, "part", "0.3 s", 9)
    with h5py.File(part, "r+") as f:
        jac = f["checkpoint/structure/lu_jacobians"][()]
        del f["checkpoint/structure/lu_jacobians"]
        f["checkpoint/structure/lu_jacobians"] = jac[:, :-1]
    with pytest.raises(emorbit.InputError, match="checkpoint.*Newton state"):
        resume(part, "1 s", progress=False)


@pytest.mark.parametrize("scene", ["satellite-flexible-boom", "tethered-satellites"])
def test_rigid_bodies_of_a_structure_record_the_same_bits_in_any_chunks(tmp_path, scene):
    """A rigid body's angular velocity is computed in a fixed order of summation, so records
    computed one at a time (after a checkpoint) equal records computed in a block."""
    base = emorbit.load_scene(scene)
    runs = []
    for every in (5, 10_000):
        sim = base.build()
        path = tmp_path / f"{every}.h5"
        sim.run(steps=40 * base.output_every, every=base.output_every, output=path, checkpoint_every=every)
        runs.append(_records(path))
    assert _same(*runs) == []
