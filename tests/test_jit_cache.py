"""The on-disk kernel cache is dropped when any kernel source changes (Numba itself only
re-checks a kernel against its own file, not the kernels it inlines)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import emorbit

PACKAGE = Path(emorbit.__file__).resolve().parent


def _import_jit(root: Path) -> None:
    code = f"import emorbit.kernels.jit, emorbit; assert emorbit.__file__.startswith({str(root)!r})"
    env = {k: v for k, v in os.environ.items() if k != "EMORBIT_JIT_CACHE"}
    env["PYTHONPATH"] = str(root)
    # -S: no site-packages path hooks (an editable install would shadow the copy); numba and
    # numpy come from the running interpreter's paths, appended after the copy
    paths = [p for p in sys.path if p and "site-packages" in p]
    code = f"import sys; sys.path[1:1] = {paths!r}; " + code
    subprocess.run([sys.executable, "-S", "-c", code], check=True, env=env, cwd=root, timeout=120)


def test_cache_files_dropped_when_an_inlined_source_changes(tmp_path):
    root = tmp_path / "copy"
    shutil.copytree(PACKAGE, root / "emorbit", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    cache = root / "emorbit" / "kernels" / "__pycache__"
    _import_jit(root)
    stamp = cache / "emorbit-kernel-sources.sha1"
    assert stamp.is_file()

    # a cache entry written after the stamp survives an import with unchanged sources
    fake = cache / "coupled.fill_forces-1.py311.nbi"
    fake.write_bytes(b"x")
    other = root / "emorbit" / "kernels" / "pointmass" / "__pycache__"
    other.mkdir(exist_ok=True)
    fake_packed = other / "packed._points_em-1.py311.1.nbc"
    fake_packed.write_bytes(b"x")
    _import_jit(root)
    assert fake.exists() and fake_packed.exists()

    # an edit to gravity.py (inlined by the point-mass and coupled kernels, whose own files
    # are unchanged)
    gravity = root / "emorbit" / "kernels" / "gravity.py"
    gravity.write_text(gravity.read_text() + "\n# edited\n")
    _import_jit(root)
    assert not fake.exists() and not fake_packed.exists()
    assert stamp.is_file()
