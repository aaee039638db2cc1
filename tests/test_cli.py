"""The command line and the HDF5 file it writes, read with plain h5py."""

import subprocess
import sys

import h5py
import numpy as np
import pytest

import emorbit
from emorbit.cli import main
from emorbit.io.hdf5 import LAYOUT_UNITS


@pytest.fixture(scope="module")
def paper_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "x.h5"
    assert main(["run", "paper-ellipse", "-o", str(out), "-q"]) == 0
    return out


def test_run_writes_documented_layout(paper_file):
    with h5py.File(paper_file, "r") as f:
        n = f["time"].shape[0]
        assert n == 1001  # 10000 steps recorded every 10, plus the start
        for name, unit in LAYOUT_UNITS.items():
            assert f[name].attrs["unit"] == unit
            assert f[name].shape[0] == n
        assert f["invariants/momentum"].shape == (n, 3)
        assert f["invariants/angular_momentum"].shape == (n, 3)
        sat = f["bodies/satellite"]
        assert sat.attrs["kind"] == "point" and sat.attrs["mass"] == 1.0
        assert sat["position"].shape == (n, 3) and sat["position"].attrs["unit"] == "m"
        assert sat["velocity"].attrs["unit"] == "m / s"
        assert f["time"].maxshape == (None,)  # growable: written in chunks
        attrs = f.attrs
        assert attrs["emorbit_version"] == emorbit.__version__
        assert (attrs["method"], attrs["order"], attrs["dt"]) == ("em", 2, 0.464758)
        assert attrs["status"] == "completed"
        assert "[[body]]" in attrs["scene"]
        np.testing.assert_array_equal(sat["position"][0], [10.0, 0.0, 0.0])
        e = f["invariants/energy"][()]
        assert np.abs(e / e[0] - 1).max() < 1e-12
        np.testing.assert_allclose(f["time"][-1], 4647.58, rtol=1e-15)


def test_file_reads_back_and_scene_reruns(paper_file, tmp_path):
    res = emorbit.read(paper_file)
    assert res.names == ["satellite"] and res.method == "em"
    again = emorbit.parse_scene(res.attrs["scene"]).build()
    r2 = again.run(steps=10, every=10)
    np.testing.assert_array_equal(r2.si.positions["satellite"][-1], res.si.positions["satellite"][1])


def test_overrides_and_no_overwrite(tmp_path, paper_file, capsys):
    out = tmp_path / "m.h5"
    assert (
        main(
            [
                "run",
                "paper-ellipse",
                "-o",
                str(out),
                "-q",
                "--method",
                "midpoint",
                "--order",
                "4",
                "--dt",
                "0.232379 s",
                "--t-end",
                "46.4758 s",
                "--every",
                "5",
            ]
        )
        == 0
    )
    with h5py.File(out, "r") as f:
        assert (f.attrs["method"], f.attrs["order"], f.attrs["dt"], f.attrs["output_every"]) == (
            "midpoint",
            4,
            0.232379,
            5,
        )
        assert f["time"].shape == (41,)
        assert "override" in f.attrs["scene"]
    before = out.read_bytes()
    assert main(["run", "paper-ellipse", "-o", str(out), "-q"]) == 2
    assert "exists" in capsys.readouterr().err
    assert out.read_bytes() == before  # the earlier run is untouched
    assert main(["run", "paper-ellipse", "-o", str(out), "-q", "--overwrite", "--t-end", "4.64758 s"]) == 0


def test_plot(tmp_path, paper_file):
    mid = tmp_path / "mid.h5"
    assert main(["run", "paper-ellipse-midpoint", "-o", str(mid), "-q", "--t-end", "464.758 s"]) == 0
    fig = tmp_path / "fig.png"
    assert main(["plot", str(paper_file), str(mid), "-o", str(fig)]) == 0
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and fig.stat().st_size > 10_000
    assert main(["plot", str(tmp_path / "missing.h5"), "-o", str(fig)]) == 2


@pytest.mark.parametrize(
    "figure, what",
    [
        ("f.xyz", "has the extension .xyz, which matplotlib cannot write"),
        ("nodir/f.png", "the folder 'nodir' does not exist"),
        ("run.h5", "is one of the run files being plotted"),
        (".", "is a folder"),
        ("sub", "is a folder"),
        ("fig", "has no extension"),
    ],
)
def test_plot_refuses_a_figure_path_and_writes_nothing(tmp_path, monkeypatch, capsys, paper_file, figure, what):
    monkeypatch.chdir(tmp_path)
    run = tmp_path / "run.h5"
    run.write_bytes(paper_file.read_bytes())
    (tmp_path / "sub").mkdir()
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    assert main(["plot", "run.h5", "-o", figure]) == 2
    err = capsys.readouterr().err
    assert err.startswith("emorbit: error: -o/--output: ") and what in err and len(err.splitlines()) == 1, err
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")} == before  # nothing written or replaced


def test_plot_draws_the_paths_of_a_free_space_run(tmp_path):
    """Three bodies under their mutual gravity, no central field: the figure draws their paths
    (and the angular-momentum error), not only the energy error."""
    import matplotlib.pyplot as plt

    from emorbit.plot import draw_runs

    path = tmp_path / "eight.h5"
    assert main(["run", "three-body-figure-eight", "-o", str(path), "-q", "--t-end", "40 s"]) == 0
    assert main(["plot", str(path), "-o", str(tmp_path / "eight.png")]) == 0
    res = emorbit.read(path).si
    fig = draw_runs([(str(path), res)])
    try:
        titles = [ax.get_title() for ax in fig.axes]
        paths = fig.axes[titles.index("paths (x-y projection, dot = end)")]
        drawn = {line.get_label(): line.get_xydata() for line in paths.lines}
        for name in ("a", "b", "c"):
            np.testing.assert_array_equal(drawn[name], res.positions[name][:, :2])
        assert "relative angular-momentum error (log)" in titles
    finally:
        plt.close(fig)


def test_plot_draws_the_energy_balance_as_the_error_under_work():
    """Under drag the energy falls with the physics: the error drawn is the balance
    (E - E0 - W) / |E0|, labelled so, and the energy's change is drawn beside it as what it is."""
    import matplotlib.pyplot as plt

    from emorbit.plot import draw_runs
    from emorbit.result import ResultSI

    n = 5
    t = np.arange(n, dtype=float)
    energy = -1e7 * (1 + 1e-6 * t)  # drag takes energy: J
    work = energy - energy[0] + np.array([0, 1e-9, -2e-9, 3e-9, 0])  # W, up to round-off of the balance
    x = np.stack([7e6 * np.cos(t / 100), 7e6 * np.sin(t / 100), 0 * t], axis=1)
    res = ResultSI(
        time=t, energy=energy, momentum=np.zeros((n, 3)), angular_momentum=np.ones((n, 3)),
        newton_iterations=np.zeros(n), bodies={"sat": {"position": x, "velocity": x}}, masses={"sat": 1.0},
        kinds={"sat": "point"}, method="em", order=2, dt=1.0, gm=3.986e14, center=np.zeros(3),
        work={"drag": work}, energy_balance=energy - energy[0] - work,
    )  # fmt: skip
    fig = draw_runs([("drag.h5", res)])
    try:
        ax_lin, ax_log = fig.axes[:2]
        assert ax_lin.get_title().startswith("energy balance error") and ax_lin.get_ylabel() == "(E - E0 - W) / |E0|"
        (line,) = ax_lin.lines
        assert line.get_label().endswith(": (E - E0 - W) / |E0|")
        np.testing.assert_array_equal(line.get_ydata(), res.relative_energy_balance())
        change = next(ln for ln in ax_log.lines if ln.get_label().endswith("|E - E0| / |E0|, the work done"))
        np.testing.assert_allclose(change.get_ydata()[1:], np.abs(res.relative_energy_error())[1:])
        assert change.get_linestyle() == ":"
    finally:
        plt.close(fig)


@pytest.mark.parametrize(
    "option, value",
    [
        ("--t-end", "100"),
        ("--dt", "1"),
        ("--method", "foo"),
        ("--order", "3"),
        ("--every", "0"),
        ("--checkpoint-every", "0"),
        ("--max-output", "5"),
    ],
)
def test_a_bad_override_names_the_option_typed(tmp_path, capsys, option, value):
    out = tmp_path / "o.h5"
    assert main(["run", "paper-ellipse", "-o", str(out), option, value]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"emorbit: error: {option}: ") and "integrator." not in err, err
    assert not out.exists()


def test_resume_names_its_t_end_option(tmp_path, capsys, paper_file):
    run = tmp_path / "run.h5"
    run.write_bytes(paper_file.read_bytes())
    assert main(["resume", str(run), "--t-end", "100"]) == 2
    assert capsys.readouterr().err.startswith("emorbit: error: --t-end: '100' has no unit")
    assert run.read_bytes() == paper_file.read_bytes()


def test_scenes_command(capsys):
    """One line per shipped scene: its name, what it is (from its leading comment), its method."""
    assert main(["scenes"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == emorbit.list_scenes()
    paper = next(line for line in lines if line.startswith("paper-ellipse "))
    assert "The satellite on an ellipse from Goettlicher & Schweizerhof [em, order 2]" in paper
    midpoint = next(line for line in lines if line.startswith("paper-ellipse-midpoint "))
    assert midpoint.endswith("[midpoint, order 2]")
    assert all(len(line.split()) > 3 and "..." not in line for line in lines)
    # the first clause in full, however long
    eight = next(line for line in lines if line.startswith("three-body-figure-eight "))
    assert eight.endswith("figure-eight under their mutual gravity, in free space [em, order 4]")


def test_summary_prints_dt_with_six_significant_digits(tmp_path, capsys):
    out = tmp_path / "dt.h5"
    assert main(["run", "paper-ellipse", "-o", str(out), "--t-end", "4.6 s", "--dt", "0.4647581234567891 s"]) == 0
    summary = capsys.readouterr().out
    assert "dt = 0.464758 s," in summary and "0.4647581234567891" not in summary


def test_quiet_when_stderr_is_not_a_terminal(tmp_path, capsys):
    """No progress bar unless stderr is a terminal; the one-line summary goes to stdout."""
    assert main(["run", "paper-ellipse", "-o", str(tmp_path / "q.h5"), "--t-end", "46.4758 s"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert "max |dE/E0| = " in captured.out and ", at end " in captured.out


def test_console_entry_point_in_a_fresh_process(tmp_path, paper_file):
    """``python -m emorbit.cli`` (the ``emorbit`` script's :func:`console_main`, which freezes
    the garbage collector before the interpreter shuts down) writes the same complete file as
    :func:`main` in this process, prints its summary, and exits with main's codes."""
    out = tmp_path / "fresh.h5"
    cmd = [sys.executable, "-m", "emorbit.cli", "run", "paper-ellipse", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "max |dE/E0| = " in proc.stdout
    with h5py.File(out, "r") as f, h5py.File(paper_file, "r") as g:
        assert f.attrs["status"] == "completed"
        for name in ("time", "invariants/energy", "bodies/satellite/position", "bodies/satellite/velocity"):
            np.testing.assert_array_equal(f[name][()], g[name][()])
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert again.returncode == 2 and "exists" in again.stderr


def test_max_output_limits_the_run_before_a_file_exists(tmp_path, capsys):
    """--max-output overrides the scene's limit: a run whose records would exceed it is
    refused (exit 2) naming the keys, and no file is created; a limit above the run's
    projected size lets it run."""
    out = tmp_path / "big.h5"
    assert main(["run", "paper-ellipse", "-o", str(out), "-q", "--max-output", "10 kB"]) == 2
    err = capsys.readouterr().err
    assert "max_output" in err and "t_end" in err and "output_every" in err
    assert not out.exists() and not any(tmp_path.iterdir())
    assert main(["run", "paper-ellipse", "-o", str(out), "-q", "--max-output", "10 MB"]) == 0
    with h5py.File(out, "r") as f:
        assert f.attrs["status"] == "completed"
    assert main(["run", "paper-ellipse", "-o", str(tmp_path / "x.h5"), "-q", "--max-output", "ten"]) == 2
    assert "error: --max-output: " in capsys.readouterr().err


def test_summary_gives_the_largest_energy_error_not_the_last(tmp_path, capsys):
    """The midpoint rule's energy oscillates around each orbit: after one orbit its error is
    back near 2e-8, but it reached 8e-2 at perihelion, between records; the summary says both."""
    out = tmp_path / "mid.h5"
    assert main(["run", "paper-ellipse-midpoint", "-o", str(out), "--t-end", "46.4758 s"]) == 0
    line = capsys.readouterr().out
    with h5py.File(out, "r") as f:
        e0 = f["invariants/energy"][0]
        largest = np.abs(f["invariants/energy_range"][()] / e0 - 1).max()
        last = abs(f["invariants/energy"][-1] / e0 - 1)
    assert largest > 1e-2 and last < 1e-6
    assert f"max |dE/E0| = {largest:.3e}, at end {last:.3e}" in line
    assert "stalled" not in line and "split" not in line


def test_summary_names_stalled_solves_and_split_steps():
    from emorbit.cli import summary_text

    tiny = 2.0**-46  # 1.42e-14, exact steps of -1.0's neighbours
    energy = np.array([-1.0, -1.0 + tiny, -1.0 - 2 * tiny])
    span = np.stack([energy - 4 * tiny, energy], axis=-1)  # the least energy between records: -1 - 6 tiny
    plain = f"max |dE/E0| = {6 * tiny:.3e}, at end {2 * tiny:.3e}"
    assert summary_text(energy, span, None, 1889, 3) == plain + "; 1889 stalled solves, 3 split steps"
    assert summary_text(energy, span, None, 1, 0) == plain + "; 1 stalled solve"
    assert summary_text(energy, span, None, 0, 0) == plain
    balance = np.array([0.0, 3e-15, -4e-15])  # drag: the energy balance E - E0 - W
    assert "; max |E - E0 - W|/|E0| = 4.000e-15" in summary_text(energy, span, balance, 0, 0)
