"""Every shipped scene writes the very bits it wrote when the reference hashes were recorded.

``tests/data/scene_hashes.json`` holds, per scene, a SHA-256 prefix of every dataset of the
file ``emorbit run SCENE`` writes (records, meshes, checkpoint and final state) and of its
root attributes other than the provenance ones (creation time, versions). A refactoring
that changes no physics leaves all of them unchanged; a change that moves a single bit of
any record fails here, naming the scene and the dataset.

The bits of the compiled kernels and of the linear algebra also follow the libraries (Numba,
LLVM, NumPy's LAPACK, SciPy's SuperLU): the file records their versions, and a failure says
when they differ from this environment's. They follow the machine too: OpenBLAS and NumPy
choose their kernels for the processor at run time, and an AMD EPYC's sums in the rigid and
elastic paths round differently from an Intel Xeon's. So a scene holds one or more recorded
alternatives, one per machine its bits were seen on, and its file must match one of them
whole on the machines recorded (``_machines``: the processor's model name and whether it has
AVX-512). On another machine a file that matches none is skipped, saying so: its bits are that
processor's rounding, not a result, and values cannot stand in for them, because several
scenes are chaotic (another processor's rounding moves the tumbling box in the paper's orbit
by 1e-15 at its eighth record and by its orbit's size at its last) and the structures' Newton
iterations stop at a stall, where another rounding stops elsewhere. To record new references
after a deliberate change of results (replacing all)::

    python tests/test_scene_outputs.py > tests/data/scene_hashes.json

and, on a machine whose bits differ (or are skipped) but whose results did not change, to add
its own::

    python tests/test_scene_outputs.py --add > scene_hashes.json && mv scene_hashes.json tests/data/
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import platform
import sys

import h5py
import numpy as np
import pytest

import emorbit
from emorbit.cli import main

REFERENCE = os.path.join(os.path.dirname(__file__), "data", "scene_hashes.json")
#: root attributes that say when and with what the file was written, not what it holds
PROVENANCE = {"created", "versions", "creator", "emorbit_version", "writer"}


def digest(path: str) -> dict[str, str]:
    """{dataset path: hash} of every dataset in ``path``, and "@attrs" for the root attributes."""
    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                a = np.ascontiguousarray(obj[()])
                data = a.tobytes()
                if a.dtype == object:  # text (the event log's labels): the strings, not their addresses
                    data = b"\0".join(x if isinstance(x, bytes) else str(x).encode() for x in a.ravel())
                out[name] = hashlib.sha256(str(a.dtype).encode() + str(a.shape).encode() + data).hexdigest()[:16]

        f.visititems(visit)
        attrs = {k: str(v) for k, v in sorted(f.attrs.items()) if k not in PROVENANCE}
        out["@attrs"] = hashlib.sha256(json.dumps(attrs).encode()).hexdigest()[:16]
    return out


def run_scene(name: str, folder: str) -> dict[str, str]:
    path = os.path.join(folder, f"{name}.h5")
    with contextlib.redirect_stdout(io.StringIO()):  # a stopping event is said even with -q
        assert main(["run", name, "-o", path, "-q"]) == 0
    return digest(path)


#: the key of the libraries the references were recorded with (the compiled kernels' and the
#: linear algebra's bits follow them: another Numba, LLVM or LAPACK may round differently)
ENVIRONMENT = "_environment"
#: the machines whose bits are recorded (:func:`machine`)
MACHINES = "_machines"


def machine() -> str:
    """The processor, as far as its rounding goes: its model name and whether it has AVX-512."""
    info = {}
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as fh:
        for line in fh:
            key, _, value = line.partition(":")
            info.setdefault(key.strip(), value.strip())
    model = info.get("model name") or platform.processor() or platform.machine()
    avx512 = "avx512f" in info.get("flags", "").split()
    return f"{model}, {'AVX-512' if avx512 else 'no AVX-512'}"


def environment() -> dict[str, str]:
    """The versions of the libraries whose arithmetic the recorded bits depend on."""
    import llvmlite
    import numba
    import scipy

    return {
        "numba": numba.__version__,
        "llvmlite": llvmlite.__version__,
        "numpy": np.__version__,
        "scipy": scipy.__version__,
    }


def _reference() -> dict:
    """{scene: [digest, ...]} (one digest per machine its bits were seen on) and the environment."""
    with open(REFERENCE) as fh:
        ref = json.load(fh)
    return {k: (v if k.startswith("_") or isinstance(v, list) else [v]) for k, v in ref.items()}


def test_every_shipped_scene_has_a_reference():
    reference = _reference()
    assert sorted(k for k in reference if not k.startswith("_")) == emorbit.list_scenes()
    assert reference[MACHINES], "the references name the machines whose bits they hold"


@pytest.mark.parametrize("name", emorbit.list_scenes())
def test_scene_output_is_bit_identical(name, tmp_path):
    reference = _reference()
    got = run_scene(name, str(tmp_path))
    alternatives = reference[name]
    assert any(sorted(got) == sorted(a) for a in alternatives), f"{name}: the file's datasets changed"
    if any(got == a for a in alternatives):
        return
    if machine() not in reference[MACHINES]:
        pytest.skip(
            f"{name}: this machine ({machine()}) rounds differently from the recorded ones "
            f"({'; '.join(reference[MACHINES])}); record its bits with python tests/test_scene_outputs.py --add"
        )
    # the recorded alternative with the fewest differing datasets, for the message
    closest = min(alternatives, key=lambda a: sum(got.get(k) != a[k] for k in a))
    changed = [key for key in closest if got[key] != closest[key]]
    recorded, now = reference.get(ENVIRONMENT), environment()
    note = "" if recorded == now else f" (the references were recorded with {recorded}, this is {now})"
    assert not changed, (
        f"{name}: these datasets differ from each of the {len(alternatives)} recorded machines' bits{note}: "
        f"{changed}; if this machine rounds differently and the results did not change, add its bits "
        "(python tests/test_scene_outputs.py --add)"
    )


if __name__ == "__main__":  # pragma: no cover - records the references
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        hashes = {n: [run_scene(n, folder)] for n in emorbit.list_scenes()}
    machines = [machine()]
    if "--add" in sys.argv[1:]:
        old = _reference()
        hashes = {n: old.get(n, []) + [d for d in hashes[n] if d not in old.get(n, [])] for n in hashes}
        machines = sorted(set(old.get(MACHINES, [])) | set(machines))
    json.dump(hashes | {MACHINES: machines, ENVIRONMENT: environment()}, sys.stdout, indent=1, sort_keys=True)
    sys.stdout.write("\n")
