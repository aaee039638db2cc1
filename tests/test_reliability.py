"""Bad and edge-case input meets a clean error or a clean run: never a hang, a traceback or lost data.

Each test reproduces one failure found by running generated bad input through the command
line, the API and damaged run files, and fails on the code before its fix.
"""

import os
import stat
import subprocess
import sys
import time

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

import pytest
from fuzz_support import clean_error, cli, listing, watchdog

POINT_SCENE = """
[field]
body = "earth"
[integrator]
method = "em"
dt = "60 s"
t_end = "600 s"
epoch = "{epoch}"
[[body]]
name = "sat"
kind = "point"
position = ["7000 km", "0 km", "0 km"]
velocity = ["0 km/s", "7.5 km/s", "0 km/s"]
mass = "1 kg"
"""


def _emorbit(args, cwd, timeout=120):
    return subprocess.run(
        [sys.executable, "-m", "emorbit.cli", *args], cwd=cwd, capture_output=True, text=True, timeout=timeout
    )


def test_a_warning_during_a_run_is_printed_once_and_the_run_returns(tmp_path):
    """astropy's "dubious year" inside `emorbit run` used to loop without end: the CLI printed
    recorded warnings inside the very recording block, appending to the list it read."""
    (tmp_path / "s.toml").write_text(POINT_SCENE.format(epoch="2200-01-01T00:00:00 UTC"))
    out = _emorbit(["run", "s.toml", "-o", "s.h5", "-q"], tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stderr.count("leap-second table") == 1, out.stderr
    assert "Traceback" not in out.stderr


def test_any_python_warning_in_the_block_is_printed_once(capsys):
    """A warning that is not emorbit's own (NumPy's RuntimeWarning) is printed once, in Python's
    format, after the block; the block returns."""
    import warnings

    import numpy as np

    from emorbit.cli import _warnings_on_stderr

    with warnings.catch_warnings(), _warnings_on_stderr():
        warnings.simplefilter("always")  # as a plain process would; pytest makes warnings errors
        for _ in range(3):
            with np.errstate(divide="warn"):
                np.float64(1.0) / np.float64(0.0)
        warnings.warn("plain", UserWarning, stacklevel=1)
    err = capsys.readouterr().err
    assert err.count("RuntimeWarning") == 1 and err.count("UserWarning: plain") == 1


def test_a_second_that_does_not_exist_is_an_input_error(tmp_path):
    (tmp_path / "s.toml").write_text(POINT_SCENE.format(epoch="2015-12-31T23:59:60 UTC"))
    out = _emorbit(["run", "s.toml", "-o", "s.h5", "-q"], tmp_path)
    assert out.returncode == 2, out.stderr
    assert "epoch" in out.stderr and "leap second" in out.stderr and "Traceback" not in out.stderr
    assert not (tmp_path / "s.h5").exists()


def test_a_real_leap_second_is_accepted():
    from emorbit.epochs import to_epoch

    t = to_epoch("2016-12-31T23:59:60 UTC")
    assert t.utc.isot.startswith("2016-12-31T23:59:60")


def test_an_epoch_beyond_the_leap_second_table_warns_naming_the_key():
    from emorbit.epochs import to_epoch
    from emorbit.errors import EpochWarning

    with pytest.warns(EpochWarning, match="integrator.epoch: '2200-01-01T00:00:00 UTC'"):
        to_epoch("2200-01-01T00:00:00 UTC", "integrator.epoch")


def test_a_tdb_epoch_far_away_does_not_warn():
    from emorbit.epochs import to_epoch

    t = to_epoch("3000-01-01T00:00:00 TDB")  # TDB needs no leap-second table
    assert t.tdb.isot.startswith("3000-01-01T00:00:00")


# -- outputs that are not regular files ---------------------------------------------------------
def _scene(tmp_path, epoch="2026-01-01T00:00:00 TDB"):
    path = tmp_path / "s.toml"
    path.write_text(POINT_SCENE.format(epoch=epoch))
    return path


def test_overwrite_onto_a_fifo_is_refused_without_opening_it(tmp_path):
    """A FIFO at the output path used to block the run forever in the open that takes the old
    file's lock; now the path is looked at first (stat), and refused."""
    fifo = tmp_path / "out.h5"
    os.mkfifo(fifo)
    for extra in (["--overwrite"], []):
        code, _, err = cli(["run", _scene(tmp_path), "-o", fifo, "-q", *extra], seconds=30)
        assert clean_error(code, err) == "output"
        assert str(fifo) in err and "FIFO" in err
        assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert listing(tmp_path) == {"s.toml", "out.h5"}


def _char_device(tmp_path):
    """A character device to write to: a node of the null device in ``tmp_path`` where this
    process may make one (root), else /dev/null itself, which a process that is not root cannot
    replace (so the test cannot harm it)."""
    node = tmp_path / "devnull"
    null = os.stat("/dev/null")
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, null.st_rdev)
    except (PermissionError, OSError):
        if os.geteuid() == 0:
            pytest.skip("cannot make a device node here")
        return "/dev/null"
    return str(node)


def test_overwrite_onto_a_character_device_is_refused_and_the_node_is_untouched(tmp_path):
    """`-o <char device> --overwrite` replaced the device node with an HDF5 file (as root, with
    /dev/null, the system's null device)."""
    device = _char_device(tmp_path)
    before = os.lstat(device)
    code, _, err = cli(["run", _scene(tmp_path), "-o", device, "-q", "--overwrite"], seconds=60)
    assert clean_error(code, err) == "output"
    assert device in err and "character device" in err
    after = os.lstat(device)
    assert stat.S_ISCHR(after.st_mode) and (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)
    assert not [n for n in os.listdir(os.path.dirname(device)) if n.endswith(".tmp")]


def test_reading_a_fifo_is_refused_without_opening_it(tmp_path):
    import emorbit
    from emorbit.errors import InputError

    fifo = tmp_path / "run.h5"
    os.mkfifo(fifo)
    with watchdog(30), pytest.raises(InputError, match="FIFO"):
        emorbit.read(fifo)
    code, _, err = cli(["resume", fifo, "--t-end", "10 s", "-q"], seconds=30)
    assert clean_error(code, err) == "file" and str(fifo) in err


# -- scenes nested without end ---------------------------------------------------------------
@pytest.mark.parametrize(
    "text, key",
    [
        ("x = " + "[" * 10000 + "]" * 10000, "s.toml"),  # tomllib's recursion runs out
        ("x = " + "{a = " * 2000 + "1" + "}" * 2000, "s.toml"),
        ("[integrator]\nfoo = " + "[" * 100 + "]" * 100, "integrator.foo"),  # read, but too deep
    ],
    ids=["10000 arrays", "2000 inline tables", "100 arrays"],
)
def test_a_scene_nested_too_deep_is_an_input_error(tmp_path, text, key):
    (tmp_path / "s.toml").write_text(text)
    code, _, err = cli(["run", tmp_path / "s.toml", "-o", tmp_path / "out.h5", "-q"])
    assert clean_error(code, err).endswith(key), err
    assert "levels" in err and listing(tmp_path) == {"s.toml"}


def test_a_sweep_nested_too_deep_is_an_input_error():
    from emorbit.errors import InputError
    from emorbit.sweep import parse_sweep

    with pytest.raises(InputError, match="too deep"):
        parse_sweep('[sweep]\nscene = "paper-ellipse"\nx = ' + "[" * 10000 + "]" * 10000)


# -- body names ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["\u0000", "a\u0000b", "tab\there", "line\nbreak", "del\u007f", "sep\u2028"])
def test_a_body_name_with_a_control_character_is_refused_naming_the_key(tmp_path, name):
    """A NUL in a name used to be accepted: HDF5 cut the group's name at it (a run exited 0 with
    its body recorded as "a", which resume then refused), "\\0" alone was an h5py traceback,
    and "a\\0x" and "a\\0y" collided."""
    from emorbit.sweep.scene_text import scene_toml

    d = tomllib.loads(_scene(tmp_path).read_text())
    d["body"][0]["name"] = name
    (tmp_path / "s.toml").write_text(scene_toml(d))
    code, _, err = cli(["run", tmp_path / "s.toml", "-o", tmp_path / "out.h5", "-q"])
    assert clean_error(code, err) == "body[0].name" and "control" in err
    assert listing(tmp_path) == {"s.toml"}


def test_a_body_name_with_a_control_character_is_refused_from_python():
    import emorbit
    from emorbit.errors import InputError

    sim = emorbit.Simulation(emorbit.CentralField(gm=1.0), dt=0.1)
    with pytest.raises(InputError, match="control"):
        sim.add_point("a\x00b", mass=1.0, position=[1.0, 0, 0], velocity=[0, 1.0, 0])
    sim.add_point("ünïcode ok", mass=1.0, position=[1.0, 0, 0], velocity=[0, 1.0, 0])


# -- a run file's scene text ------------------------------------------------------------------------
@pytest.mark.parametrize("value", ["-" * 10001 + "1", "+" * 10000 + "1", "[1," * 3000 + "]" * 3000, "1" + "+1" * 5000])
def test_a_long_override_line_in_a_run_files_scene_is_not_evaluated(tmp_path, value):
    """A run file whose scene holds a 10,001-character override line: ast.literal_eval raised
    MemoryError or RecursionError (a traceback from emorbit resume)."""
    import h5py

    from emorbit.scene import scene_overrides

    assert scene_overrides(f"# override: integrator.dt = {value}\n# override: integrator.order = 4") == {"order": 4}
    code, _, err = cli(["run", _scene(tmp_path), "-o", tmp_path / "out.h5", "-q"])
    assert code == 0, err
    with h5py.File(tmp_path / "out.h5", "r+") as f:
        f.attrs["scene"] = f"# override: integrator.dt = {value}\n" + f.attrs["scene"]
    code, _, err = cli(["resume", tmp_path / "out.h5", "--t-end", "1200 s", "-q"])
    assert code == 0, err


def test_an_override_too_long_to_read_back_is_refused():
    import emorbit
    from emorbit.errors import InputError

    scene = emorbit.load_scene("paper-ellipse")
    with pytest.raises(InputError, match="integrator.t_end: longer than"):
        scene.with_overrides(t_end="1" * 1000 + " s")


# -- paths as bytes ------------------------------------------------------------------------------------
def test_paths_may_be_bytes(tmp_path):
    """Simulation.run(output=b"x.h5") was a TypeError from deep inside the writer; a path is str,
    bytes or os.PathLike wherever a file is written or read, and anything else an InputError."""
    import emorbit
    from emorbit.errors import InputError

    out = os.fsencode(tmp_path / "x.h5")
    sim = emorbit.load_scene(str(_scene(tmp_path))).build()
    sim.run(t_end=120.0, output=out)
    assert len(emorbit.read(out)) == 3
    emorbit.resume(out, 240.0, progress=False)
    assert emorbit.read(out).si.time[-1] == 240.0
    with pytest.raises(InputError, match="output: a path"):
        emorbit.load_scene(str(_scene(tmp_path))).build().run(t_end=120.0, output=12)
    with pytest.raises(InputError, match="file: a path"):
        emorbit.read(3.5)
    with pytest.raises(InputError, match="NUL"):  # os.stat raised ValueError: embedded null byte
        emorbit.load_scene(str(_scene(tmp_path))).build().run(t_end=120.0, output=str(tmp_path / "a\0b.h5"))


# -- sweeps ------------------------------------------------------------------------------------------
SWEEP = """
[sweep]
scene = "paper-ellipse"
{seed}
[set]
"integrator.t_end" = {t_end}
[[parameter]]
key = "body[0].velocity[1]"
values = {values}
"""


def _sweep(tmp_path, seed="", t_end='"4.64758 s"', values='["0.36 m/s", "0.37 m/s"]'):
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP.format(seed=seed, t_end=t_end, values=values))
    return path


def test_a_seed_beyond_64_bits_is_refused_before_anything_runs(tmp_path):
    """seed = 2**70 ran every run, then failed writing the summary (a TypeError traceback) and
    left summary.h5.tmp behind."""
    code, _, err = cli(["sweep", _sweep(tmp_path, f"seed = {2**70}"), "-o", tmp_path / "out", "--serial", "-q"])
    assert clean_error(code, err) == "sweep.seed"
    assert not (tmp_path / "out").exists()
    code, _, err = cli(["sweep", _sweep(tmp_path, f"seed = {2**63 - 1}"), "-o", tmp_path / "out", "--serial", "-q"])
    assert code == 0, err
    assert "summary.h5.tmp" not in os.listdir(tmp_path / "out")


def test_a_summary_that_cannot_be_written_leaves_no_temporary_file(tmp_path):
    from emorbit.sweep.runner import _write_csv

    with pytest.raises(TypeError):
        _write_csv(str(tmp_path / "summary.csv"), ["a"], {}, None)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("address", ["not-a-url", "tcp://", "tcp://host:notaport", "foo://bar:1", "tcp://h:99999"])
def test_a_scheduler_address_that_is_not_one_is_an_input_error(tmp_path, address):
    """--scheduler not-a-url was a ValueError traceback from dask.distributed."""
    pytest.importorskip("distributed")
    code, _, err = cli(["sweep", _sweep(tmp_path), "-o", tmp_path / "out", "--scheduler", address, "-q"])
    assert clean_error(code, err) == "scheduler" and repr(address) in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "values, t_end, key",
    [("[0.36, 0.37]", '"4.64758 s"', "parameter[0].unit"), ('["0.36 m/s"]', "4.64758", "set.integrator.t_end")],
    ids=["parameter", "set"],
)
def test_a_sweep_value_without_a_unit_is_refused_before_anything_runs(tmp_path, values, t_end, key):
    """A parameter's values (or a [set] value) without a unit where the scene has a quantity
    failed every run (exit 1); the docs promise an error naming the key before anything runs."""
    code, _, err = cli(["sweep", _sweep(tmp_path, t_end=t_end, values=values), "-o", tmp_path / "out", "--serial"])
    assert clean_error(code, err) == key and "without a unit" in err
    assert not (tmp_path / "out").exists()


# -- temporary files -------------------------------------------------------------------------------------
def test_a_run_removes_only_files_named_as_its_own_temporary_files(tmp_path):
    """A run to o.h5 deleted a user's file .o.h5.999999-userdata.tmp: any hidden file that began
    with .o.h5. and ended with .tmp counted as a killed run's temporary file."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    keep = [f".o.h5.{dead.pid}-userdata.tmp", f".o.h5.{dead.pid}-deadbeef.tmp.bak", f".o.h5.x{dead.pid}-deadbeef.tmp"]
    for name in keep:
        (tmp_path / name).write_text("user data")
    orphan = tmp_path / f".o.h5.{dead.pid}-0123abcd.tmp"
    orphan.write_bytes(b"half a file")
    code, _, err = cli(["run", _scene(tmp_path), "-o", tmp_path / "o.h5", "-q"])
    assert code == 0, err
    assert all((tmp_path / name).read_text() == "user data" for name in keep)
    assert not orphan.exists()


def test_a_sweep_removes_only_its_own_temporary_files(tmp_path):
    out = tmp_path / "out"
    code, _, err = cli(["sweep", _sweep(tmp_path), "-o", out, "--serial", "-q"])
    assert code == 0, err
    mine = [".run-000000.h5.userdata.tmp", ".notes.tmp", ".run-000000.h5.0123456789ab.tmp.bak"]
    for name in mine:
        (out / "runs" / name).write_text("user data")
    orphans = [".run-000001.h5.0123456789ab.tmp", "..run-000001.h5.0123456789ab.tmp.99999999-deadbeef.tmp"]
    for name in orphans:
        (out / "runs" / name).write_bytes(b"half a file")
    code, _, err = cli(["sweep", _sweep(tmp_path), "-o", out, "--serial", "-q"])
    assert code == 0, err
    assert all((out / "runs" / name).read_text() == "user data" for name in mine)
    assert not any((out / "runs" / name).exists() for name in orphans)


# -- a file truncated under its run ------------------------------------------------------------------
def test_a_file_truncated_under_its_run_fails_the_run(tmp_path):
    """Truncating the output file in place while a run wrote it left a file that cannot be read,
    and the run exited 0; removing or replacing it was caught already (exit 1)."""
    scene = POINT_SCENE.format(epoch="2026-01-01T00:00:00 TDB").replace('dt = "60 s"', 'dt = "0.01 s"')
    (tmp_path / "s.toml").write_text(scene.replace('t_end = "600 s"', 't_end = "1e6 s"\noutput_every = 1000'))
    out = tmp_path / "out.h5"
    cmd = [sys.executable, "-m", "emorbit.cli", "run", "s.toml", "-o", "out.h5", "-q"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not out.exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.5)
        os.truncate(out, out.stat().st_size // 2)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 1, err
    assert "was truncated" in err and "Traceback" not in err


def test_a_file_another_run_writes_is_not_resumed_without_file_locks(tmp_path):
    """Where the file system does not take HDF5's file locks, resuming a file that a run was
    still writing continued it (two writers, a continuation that differs from an unbroken run);
    the file's status ("running") and its writer (a live process on this machine) refuse it."""
    scene = POINT_SCENE.format(epoch="2026-01-01T00:00:00 TDB").replace('dt = "60 s"', 'dt = "0.01 s"')
    (tmp_path / "s.toml").write_text(scene.replace('t_end = "600 s"', 't_end = "1e6 s"\noutput_every = 1000'))
    env = dict(os.environ, HDF5_USE_FILE_LOCKING="FALSE")
    out = tmp_path / "out.h5"
    cmd = [sys.executable, "-m", "emorbit.cli", "run", "s.toml", "-o", "out.h5", "-q"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not out.exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        again = [sys.executable, "-m", "emorbit.cli", "resume", "out.h5", "--t-end", "2e6 s", "-q"]
        second = subprocess.run(again, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
        assert proc.poll() is None, "the run ended before the resume was tried"
        proc.terminate()
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert second.returncode == 2, second.stderr
    named = f"process {proc.pid}" in second.stderr and "being written" in second.stderr
    # caught between two writes, the file's own structure is incomplete: refused as unreadable
    assert named or "cannot be read as an HDF5 file" in second.stderr, second.stderr
    assert proc.returncode == 143, err


def test_an_epoch_astropy_cannot_read_is_one_line_naming_the_key(tmp_path):
    """astropy's message lists every format it tried, over eleven lines."""
    code, _, err = cli(["run", _scene(tmp_path, epoch="2026-13-45T99:00:00 UTC"), "-o", tmp_path / "o.h5", "-q"])
    assert clean_error(code, err) == "integrator.epoch" and "bad month" in err


@pytest.mark.parametrize("body, key, value", [(1, "shape", []), (1, "shape", {"a": 1}), (2, "mesh", [])])
def test_a_list_or_table_for_a_shape_or_mesh_name_names_the_key(body, key, value):
    """mesh = [] was a TypeError traceback (unhashable type: 'list') from the mesh's table."""
    import copy

    from fuzz_support import BASE, to_toml

    from emorbit.errors import InputError
    from emorbit.scene import parse_scene

    d = copy.deepcopy(BASE)
    d["body"][body][key] = value
    with pytest.raises(InputError) as info:
        parse_scene(to_toml(d))
    assert info.value.key == f"body[{body}].{key}"


# -- messages that name the key ----------------------------------------------------------------------
@pytest.mark.parametrize(
    "body, changes, key",
    [
        (1, {"density": "5e-324 kg/m3"}, "body[1].density"),  # said "body[1]: mass must be > 0"
        (1, {"size": ["1e-300 m"] * 3}, "body[1].size"),
        (1, {"shape": "ellipsoid", "size": None, "semi_axes": ["1e-300 m"] * 3}, "body[1].semi_axes"),
        (1, {"shape": "sphere", "size": None, "radius": "1e-300 m", "density": None, "mass": "1 kg"}, "body[1].radius"),
        (1, {"size": ["1e-200 m"] * 3, "density": None, "mass": "1 kg"}, "body[1].size"),  # said "overflow"
        (2, {"density": "5e-324 kg/m3"}, "body[2].density"),  # said "body[2].position: ... at the field's centre"
    ],
    ids=["density", "size", "semi_axes", "radius", "size with mass", "elastic density"],
)
def test_tiny_densities_and_sizes_name_their_key(body, changes, key):
    """Values that underflow float64 used to be blamed on the mass ("mass must be > 0"), on the
    shape ("the mass points lie in a plane"), on an overflow, or on the body's position."""
    import copy
    import warnings

    from fuzz_support import BASE, to_toml

    from emorbit.errors import InputError
    from emorbit.scene import parse_scene

    d = copy.deepcopy(BASE)
    for k, v in changes.items():
        if v is None:
            del d["body"][body][k]
        else:
            d["body"][body][k] = v
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning on the way
        with pytest.raises(InputError) as info:
            parse_scene(to_toml(d))
    assert info.value.key == key, str(info.value)


def test_a_file_that_is_not_a_jpl_kernel_is_named_without_its_bytes(tmp_path):
    """An ephemeris that is no SPK file is refused naming the key and the path; jplephem's own
    message (which may quote the file's first bytes) is not repeated."""
    pytest.importorskip("jplephem")
    import emorbit
    from emorbit.errors import InputError

    path = tmp_path / "not-a-kernel.bsp"
    path.write_bytes(b"SECRET-HEADER\x00\x01\x02" + bytes(range(256)) * 8)
    sim = emorbit.Simulation(emorbit.CentralField(body="earth"), dt=10.0, epoch="2026-03-20T00:00:00 TDB")
    with pytest.raises(InputError) as info:
        sim.add_effect("third_body", body="moon", ephemeris=str(path))
    assert info.value.key.endswith(".ephemeris") and str(path) in str(info.value)
    assert "SECRET" not in str(info.value) and "\\x" not in str(info.value)


@pytest.mark.parametrize(
    "what, build, key",
    [
        ("zonal radius 1e-300 m", lambda s: s.add_effect("zonal", j=[1e-3], radius="1e-300 m"), "effect[0].radius"),
        (
            "scale height 1e-300 km",
            lambda s: s.add_effect(
                "drag", atmosphere="exponential", density="1e-12 kg/m3", reference_altitude="400 km",
                scale_height="1e-300 km",
            ),
            "effect[0].scale_height",
        ),
        (
            "ap 1e30",
            lambda s: s.add_effect("drag", atmosphere="nrlmsis", f107=150.0, f107a=150.0, ap=1e30),
            "effect[0].ap",
        ),
        ("two mutual tables", lambda s: (s.add_effect("mutual"), s.add_effect("mutual")), "effect[1]"),
        (
            "area on tetrahedra",
            lambda s: s.add_elastic(
                "b", "beam", size=[1, 1, 1], elements=[1, 1, 1], young=1e6, poisson=0.3, density=100.0, area=1e-2,
                position=[7e6, 0, 0], velocity=[0, 7.5e3, 0],
            ),
            "body['b'].area",
        ),
    ],
    ids=lambda v: v if isinstance(v, str) and " " in v else "",
)  # fmt: skip
def test_absurd_effect_values_and_ignored_keys_are_refused_up_front(what, build, key):
    """Values no atmosphere or body has failed at the first step blaming the state; a second
    mutual table raised a TypeError; an area on tetrahedra was ignored. Each is refused when
    given, naming its key."""
    import emorbit
    from emorbit.errors import InputError

    sim = emorbit.Simulation(emorbit.CentralField(body="earth"), dt=1.0, epoch="2026-01-01T00:00:00 TDB")
    with pytest.raises(InputError) as info:
        build(sim)
    assert info.value.key == key, (what, str(info.value))


def test_a_path_table_larger_than_any_run_needs_is_refused_before_it_is_sampled():
    """Radiation pressure's Sun sampled every minute over 2000 years (1e9 samples, 50 GB) is
    refused naming table_step before a sample is taken; so is the Moon over 2000 years at 1 h."""
    import resource

    import emorbit
    from emorbit.errors import InputError

    for kind, keys, coef in (("srp", {"table_step": "1 min"}, {"radiation_coefficient": 0.01}),
                             ("third_body", {"body": "moon"}, {})):  # fmt: skip
        sim = emorbit.Simulation(emorbit.CentralField(body="earth"), dt="1 yr", epoch="2026-01-01T00:00:00 TDB")
        sim.add_effect(kind, **keys)
        sim.add_point("a", mass=1.0, position=[7e6, 0, 0], velocity=[0, 7.5e3, 0], **coef)
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        with pytest.raises(InputError) as info:
            sim.run("2000 yr", progress=False)
        assert info.value.key == "effect[0].table_step", str(info.value)
        assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # kB: nothing was sampled
