"""Numba's on-disk cache of emorbit's kernels: it lives in a per-user folder, one per install,
never inside the package (NUMBA_CACHE_DIR set: Numba's own rule); a second process loads
what the first compiled; a read-only package still caches; and the cache is dropped when
any kernel source changes (Numba itself only re-checks a kernel against its own file, not
the kernels it inlines).

Each test works on a copy of the package in a temporary folder, with ``XDG_CACHE_HOME``
there too, so the user's own cache is neither used nor touched."""

import hashlib
import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import emorbit

PACKAGE = Path(emorbit.__file__).resolve().parent
REPO = PACKAGE.parent
STAMP = "emorbit-kernel-sources.sha1"

#: compile (or load) one small kernel; print what its dispatcher did
PROBE = """
import json
from emorbit.kernels.gravity import accel
accel(1.0, 2.0, 3.0, 4.0)
print(json.dumps({"hits": sum(accel.stats.cache_hits.values()), "misses": sum(accel.stats.cache_misses.values())}))
"""

#: an audit hook that makes every write under the package folder fail, as on a read-only
#: install (root ignores permission bits, so chmod alone cannot show it)
READ_ONLY = """
import os, sys
_ro = os.path.realpath({root!r}) + os.sep
def _hook(event, args):
    if event == "open":
        path, mode, flags = args
        writes = (isinstance(mode, str) and any(c in mode for c in "wax+")) or (
            isinstance(flags, int) and flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT))
    elif event in ("os.mkdir", "os.remove", "os.rename", "os.replace", "os.rmdir"):
        path, writes = args[0], True
    else:
        return
    if writes and isinstance(path, (str, bytes, os.PathLike)):
        p = os.path.realpath(os.fsdecode(path))
        if (p + os.sep).startswith(_ro):
            raise PermissionError(13, "read-only package", p)
sys.addaudithook(_hook)
"""


def _copy(tmp_path: Path, name: str = "copy") -> Path:
    """A copy of the package (no caches) as ``<tmp>/<name>/emorbit``; returns ``<tmp>/<name>``."""
    root = tmp_path / name
    shutil.copytree(PACKAGE, root / "emorbit", ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.nb[ic]"))
    return root


def _python(root: Path, code: str, xdg: Path, before: str = "", **env_extra) -> dict:
    """Run ``code`` with the copy at ``root`` as the emorbit package (``before``: ahead of
    any import of it); returns the JSON it printed last."""
    code = before + f"import emorbit; assert emorbit.__file__.startswith({str(root)!r}), emorbit.__file__\n" + code
    env = {k: v for k, v in os.environ.items() if k not in ("EMORBIT_JIT_CACHE", "NUMBA_CACHE_DIR")}
    env.update(PYTHONPATH=str(root), XDG_CACHE_HOME=str(xdg), PYTHONDONTWRITEBYTECODE="1", **env_extra)
    # -S: no site-packages path hooks (an editable install would shadow the copy); numba and
    # numpy come from the running interpreter's paths, appended after the copy
    paths = [p for p in sys.path if p and "site-packages" in p]
    code = f"import sys; sys.path[1:1] = {paths!r}\n" + code
    done = subprocess.run(
        [sys.executable, "-S", "-c", code], env=env, cwd=root, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.strip().splitlines()
    return json.loads(lines[-1]) if lines else {}


def _folder(root: Path, xdg: Path) -> Path:
    """The per-user cache folder of the install at ``root``."""
    key = hashlib.sha1(os.path.realpath(root / "emorbit").encode()).hexdigest()[:16]
    return xdg / "emorbit" / "numba" / key


def _cache_files(folder: Path) -> list[Path]:
    return sorted(folder.rglob("*.nb[ic]")) if folder.exists() else []


def test_cache_is_per_user_not_in_the_package_and_a_second_process_loads_it(tmp_path):
    root, xdg = _copy(tmp_path), tmp_path / "xdg"
    first = _python(root, PROBE, xdg)
    folder = _folder(root, xdg)
    assert first == {"hits": 0, "misses": 1}
    assert {p.name.split("-")[0] for p in _cache_files(folder / "kernels")} == {"gravity.accel"}
    assert (folder / "kernels" / STAMP).is_file()
    assert _cache_files(root) == []  # nothing inside the package
    assert not (xdg / "numba").exists()  # and not in Numba's own per-user folder
    second = _python(root, PROBE, xdg)
    assert second == {"hits": 1, "misses": 0}  # loaded, not compiled

    # EMORBIT_JIT_CACHE=0: no disk cache at all
    shutil.rmtree(xdg)
    off = _python(root, PROBE, xdg, EMORBIT_JIT_CACHE="0")
    assert off == {"hits": 0, "misses": 1}
    assert _cache_files(xdg) == [] and _cache_files(root) == []


def test_other_numba_functions_keep_numbas_own_cache(tmp_path):
    """Only emorbit's kernels are redirected: a cached function of another module still
    caches where Numba puts it (here beside its file)."""
    root, xdg = _copy(tmp_path), tmp_path / "xdg"
    other = tmp_path / "other"
    other.mkdir()
    (other / "mine.py").write_text("import numba\n\n@numba.njit(cache=True)\ndef twice(x):\n    return 2 * x\n")
    code = "import json, sys\nsys.path.insert(0, {0!r})\nimport emorbit.kernels.jit\nimport mine\nmine.twice(1.0)\n"
    _python(root, code.format(str(other)) + "print('{}')\n", xdg)
    assert [p.name for p in (other / "__pycache__").glob("*.nbi")] == ["mine.twice-3.py311.nbi"]
    assert not any("mine" in p.name for p in _cache_files(xdg))


def test_numbas_default_applies_where_its_internals_differ(tmp_path):
    """Without the locator classes this relies on, nothing fails: Numba caches as it would
    without emorbit's folder (beside each module)."""
    root, xdg = _copy(tmp_path), tmp_path / "xdg"
    before = "import numba.core.caching as caching\ndel caching._SourceFileBackedLocatorMixin\n"
    assert _python(root, PROBE, xdg, before=before) == {"hits": 0, "misses": 1}
    assert _python(root, PROBE, xdg, before=before) == {"hits": 1, "misses": 0}
    assert {p.name.split("-")[0] for p in _cache_files(root)} == {"gravity.accel"}
    assert _cache_files(xdg) == []


def test_numba_cache_dir_is_honoured_and_guarded(tmp_path):
    root, xdg, ncd = _copy(tmp_path), tmp_path / "xdg", tmp_path / "numba-cache"
    first = _python(root, PROBE, xdg, NUMBA_CACHE_DIR=str(ncd))
    assert first == {"hits": 0, "misses": 1}
    assert {p.name.split("-")[0] for p in _cache_files(ncd)} == {"gravity.accel"}
    assert _cache_files(xdg) == [] and _cache_files(root) == []
    assert _python(root, PROBE, xdg, NUMBA_CACHE_DIR=str(ncd))["hits"] == 1
    # the stale-cache guard works in Numba's folder too
    eft = root / "emorbit" / "kernels" / "eft.py"
    eft.write_text(eft.read_text() + "\n# edited\n")
    third = _python(root, PROBE, xdg, NUMBA_CACHE_DIR=str(ncd))
    assert third["misses"] == 1 and third["hits"] == 0


def test_a_read_only_package_still_caches(tmp_path):
    root, xdg = _copy(tmp_path), tmp_path / "xdg"
    guard = READ_ONLY.format(root=str(root / "emorbit"))
    modes = {}
    if os.name == "posix" and os.geteuid() != 0:  # where permission bits count, set them too
        for p in [root / "emorbit", *(root / "emorbit").rglob("*")]:
            modes[p] = p.stat().st_mode
            p.chmod(p.stat().st_mode & ~0o222)
    try:
        first = _python(root, PROBE, xdg, before=guard)
        second = _python(root, PROBE, xdg, before=guard)
    finally:
        for p, mode in modes.items():
            p.chmod(mode)
    folder = _folder(root, xdg)
    assert first == {"hits": 0, "misses": 1}
    assert second == {"hits": 1, "misses": 0}
    assert {p.name.split("-")[0] for p in _cache_files(folder / "kernels")} == {"gravity.accel"}
    assert _cache_files(root) == []


def test_cache_files_dropped_when_an_inlined_source_changes(tmp_path):
    root, xdg = _copy(tmp_path), tmp_path / "xdg"
    _python(root, "import emorbit.kernels.jit", xdg)
    cache = _folder(root, xdg) / "kernels"
    stamp = cache / STAMP
    assert stamp.is_file()

    # a cache entry written after the stamp survives an import with unchanged sources
    fake = cache / "coupled.fill_forces-1.py311.nbi"
    fake.write_bytes(b"x")
    other = cache / "pointmass"
    other.mkdir(exist_ok=True)
    fake_packed = other / "packed._points_em-1.py311.1.nbc"
    fake_packed.write_bytes(b"x")
    _python(root, "import emorbit.kernels.jit", xdg)
    assert fake.exists() and fake_packed.exists()

    # a second install (another checkout, edited) has its own folder and leaves these alone
    second = _copy(tmp_path, "second")
    edited = second / "emorbit" / "kernels" / "gravity.py"
    edited.write_text(edited.read_text() + "\n# another version\n")
    _python(second, "import emorbit.kernels.jit", xdg)
    assert (_folder(second, xdg) / "kernels" / STAMP).is_file() and _folder(second, xdg) != _folder(root, xdg)
    assert fake.exists() and fake_packed.exists()

    # an edit to gravity.py (inlined by the point-mass and coupled kernels, whose own files
    # are unchanged)
    gravity = root / "emorbit" / "kernels" / "gravity.py"
    gravity.write_text(gravity.read_text() + "\n# edited\n")
    _python(root, "import emorbit.kernels.jit", xdg)
    assert not fake.exists() and not fake_packed.exists()
    assert stamp.is_file()


def test_cache_files_left_in_the_package_by_older_versions_are_removed(tmp_path):
    root, xdg = _copy(tmp_path), tmp_path / "xdg"
    old = root / "emorbit" / "kernels" / "__pycache__"
    old.mkdir()
    (old / "gravity.accel-45.py311.nbi").write_bytes(b"x")
    (old / STAMP).write_text("0" * 40)
    _python(root, "import emorbit.kernels.jit", xdg)
    assert list(old.iterdir()) == []


def _site_packages_without_emorbit(where: Path) -> Path:
    """The running interpreter's site-packages, emorbit left out, as a folder of links."""
    where.mkdir()
    site = Path(sysconfig.get_paths()["purelib"])
    for entry in site.iterdir():
        if entry.name.startswith(("emorbit", "__editable__", "_emorbit")) or entry.suffix == ".pth":
            continue
        (where / entry.name).symlink_to(entry)
    return where


def _build_requirements_here() -> bool:
    """Whether this interpreter has pyproject.toml's build requirements (setuptools>=68, wheel)."""
    try:
        import setuptools
        import wheel  # noqa: F401
    except ImportError:
        return False
    return int(setuptools.__version__.split(".")[0]) >= 68


@pytest.mark.skipif(os.name != "posix", reason="the virtual environment's layout is POSIX's")
def test_readme_commands_in_order_leave_a_working_cli(tmp_path):
    """README's two commands in one fresh virtual environment: ``pip install .`` and
    ``emorbit run``, then ``pip install -e .``; the command line still works.

    The dependencies come from the running interpreter (a ``.pth`` file), so pip installs
    only emorbit (``--no-deps``), from a copy of the sources."""
    src = tmp_path / "src"
    for part in ("emorbit", "validation"):
        shutil.copytree(REPO / part, src / part, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.nb[ic]"))
    for part in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / part, src / part)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    (site,) = venv.glob("lib/python*/site-packages")
    deps = _site_packages_without_emorbit(tmp_path / "deps")
    (site / "deps.pth").write_text(f"{deps}\n")
    env = {k: v for k, v in os.environ.items() if k not in ("EMORBIT_JIT_CACHE", "NUMBA_CACHE_DIR", "PYTHONPATH")}
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    work = tmp_path / "work"
    work.mkdir()

    def pip(*args):
        cmd = [sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install", "--no-deps", "-q"]
        if _build_requirements_here():  # otherwise pip fetches them into an isolated build environment
            cmd.append("--no-build-isolation")
        done = subprocess.run([*cmd, *args], env=env, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-3000:]

    def emorbit_cli(*args):
        done = subprocess.run(
            [str(venv / "bin" / "emorbit"), *args], cwd=work, env=env, capture_output=True, text=True, timeout=300
        )
        assert done.returncode == 0, done.stderr[-3000:]
        return done.stdout

    pip(str(src))
    emorbit_cli("run", "paper-ellipse", "-o", "paper.h5", "--overwrite", "--t-end", "5 s", "-q")
    left_in_site_packages = list(site.joinpath("emorbit").rglob("*.nb[ic]"))
    cached = list((tmp_path / "xdg" / "emorbit" / "numba").rglob("*.nbi"))
    pip("-e", str(src))
    assert "paper-ellipse" in emorbit_cli("scenes")  # a folder left in site-packages would hide the install
    assert left_in_site_packages == [] and cached and not site.joinpath("emorbit").exists()
    emorbit_cli("run", "paper-ellipse", "-o", "paper.h5", "--overwrite", "--t-end", "5 s", "-q")
    where = subprocess.run(
        [str(venv / "bin" / "python"), "-c", "import emorbit; print(emorbit.__file__)"],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert where.stdout.strip() == str(src / "emorbit" / "__init__.py"), where.stderr[-2000:]


def test_step_kernels_copy_arrays_with_loops_not_slice_assignment():
    """Slice assignment between arrays compiles Numba's broadcasting setitem (about 5 s on the
    first one in a process): the step kernels use :mod:`emorbit.kernels.copies` instead."""
    import re

    pattern = re.compile(r"^\s+\w+\[[^\]]*:[^\]]*\]\s*=\s*[A-Za-z_]\w*(\[[^\]]*\])?\s*(#.*)?$")
    found = []
    for path in sorted((PACKAGE / "kernels").rglob("*.py")):
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if pattern.match(line) and not line.strip().startswith("locators["):
                found.append(f"{path.relative_to(PACKAGE)}:{n}: {line.strip()}")
    assert found == []
