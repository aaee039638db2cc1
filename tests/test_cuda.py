"""The CUDA point-mass kernels against the CPU ensemble kernels, on numba's CUDA simulator
(in CI) and on a real GPU where there is one.

The simulator is switched on by ``NUMBA_ENABLE_CUDASIM=1`` when numba is imported, and then
replaces numba.cuda for the whole process; so the comparisons run in a child process and
nothing of the simulator reaches the other tests. Without a GPU this is what CI can check:
the device code (the CPU kernels' own Python functions compiled for CUDA) takes the same
steps. On a real GPU, compiled without fused multiply-adds, they give the CPU's bits too.
"""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import emorbit
from emorbit.errors import InputError

CASES = (
    ("em", 2, 0.46),
    ("em", 4, 0.46),
    ("em", 2, 60.0),
    ("midpoint", 2, 0.46),
    ("leapfrog", 2, 0.46),
    ("leapfrog", 6, 0.46),
)


def run_case(method, order, dt, **gpu_options):
    """33 points around a centre off the origin (one of them at the centre), ``nrec = 3``
    records of ``every = 4`` composed steps, on the CPU's ensemble kernel and on the GPU:
    ((arrays, records) on the CPU, the same on the GPU)."""
    import warnings

    from emorbit.integrators import coefficients
    from emorbit.integrators.dispatch import method_code
    from emorbit.kernels.pointmass import cuda as kcuda
    from emorbit.kernels.pointmass import packed as kens

    rng = np.random.default_rng(5)
    n, gm, center = 33, 3.9478, np.array([0.5, -0.25, 0.1])
    r = rng.uniform(4.0, 10.0, n)
    x = np.vstack([r, np.zeros(n), rng.uniform(-1, 1, n)]) + center[:, None]
    v = np.vstack(
        [rng.uniform(-0.02, 0.02, n), np.sqrt(gm / r) * rng.uniform(0.5, 1.15, n), rng.uniform(-0.05, 0.05, n)]
    )
    x[:, 7] = center  # a point at the centre fails at once (status 2), on both
    every, nrec, g = 4, 3, coefficients(order)
    runs = []
    for device in ("cpu", "gpu"):
        a = [x.copy(), v.copy(), np.zeros_like(x), np.zeros_like(v)]
        rec = [
            np.zeros((nrec, 3, n)),
            np.zeros((nrec, 3, n)),
            np.zeros((nrec, n), np.int64),
            np.full((n, 2), -1, np.int64),
        ]
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")  # the point at the centre divides by zero, as on the CPU
            if device == "gpu":
                kcuda.chunk(method_code(method), *a, gm, center, dt, g, every, nrec, 50, *rec, **gpu_options)
            else:
                kens.ensemble_chunk(method_code(method), *a, gm, center, dt, g, every, nrec, 50, *rec)
        runs.append((a, rec))
    return runs


def compare(runs, every=4):
    """How the GPU's run differs from the CPU's: the largest difference of positions and
    velocities (state and records) relative to the largest value, over the points that did
    not fail and over the records of failed points before their failure; whether iteration
    counts and failures are equal; what failed."""
    (a1, r1), (a2, r2) = runs
    ok = r1[3][:, 0] < 0
    rel, its_equal = 0.0, True
    for p, q in zip(a1[:2], a2[:2]):
        rel = max(rel, float(np.abs(p[:, ok] - q[:, ok]).max() / np.abs(p[:, ok]).max()))
    for i in range(ok.size):
        rows = r1[0].shape[0] if ok[i] else r1[3][i, 0] // every  # records written before a failure
        for p, q in zip(r1[:2], r2[:2]):
            if rows:
                rel = max(rel, float(np.abs(p[:rows, :, i] - q[:rows, :, i]).max() / np.abs(p[:, :, ok]).max()))
        its_equal &= bool(np.array_equal(r1[2][:rows, i], r2[2][:rows, i]))
    return {
        "rel": rel,
        "iterations_equal": its_equal,
        "fail_equal": bool(np.array_equal(r1[3], r2[3])),
        "fail_centre": r2[3][7].tolist(),
        "failed": int((r2[3][:, 0] >= 0).sum()),
        "failed_cpu": int((r1[3][:, 0] >= 0).sum()),
        "iterations": int(r2[2][:, ok].sum()),
    }


def resident_case():
    """PointMasses with device "gpu" (the state kept on the device: DeviceEnsemble) against the
    same points on the CPU, 32 points (one at the centre, which fails at once), em: three
    chunks of 5, 1 and 3 records (the first in three pieces, so a record slot is used twice),
    snapshot and restore, state_arrays into a fresh system, a write into the host arrays.
    Returns what differs."""
    import warnings

    from emorbit.bodies.pointmasses import PointMasses
    from emorbit.integrators import coefficients

    rng = np.random.default_rng(5)
    n, gm, center, dt = 32, 3.9478, np.array([0.5, -0.25, 0.1]), 0.46
    r = rng.uniform(4.0, 10.0, n)
    x = np.vstack([r, np.zeros(n), rng.uniform(-1, 1, n)]) + center[:, None]
    v = np.vstack(
        [rng.uniform(-0.02, 0.02, n), np.sqrt(gm / r) * rng.uniform(0.5, 1.15, n), rng.uniform(-0.05, 0.05, n)]
    )
    x[:, 7] = center
    g = coefficients(2)

    def system(device):
        p = PointMasses()
        p.names = [f"p{i}" for i in range(n)]
        p.masses, p.x, p.v, p.cx, p.cv = np.ones(n), x.copy(), v.copy(), np.zeros((3, n)), np.zeros((3, n))
        p.plan = p.plan.with_(device=device)
        return p

    def step(p, every, nrec):
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")  # the point at the centre divides by zero, as on the CPU
            return p.advance("em", gm, center, dt, g, every, nrec, 50)

    def same(a, b, every):  # records before each point's failure, failures; iterations after one are 0 on the GPU
        ok = np.array_equal(a.fail, b.fail)
        for i in range(n):
            rows = a.x.shape[0] if a.fail[i, 0] < 0 else a.fail[i, 0] // every
            for p, q in ((a.x, b.x), (a.v, b.v), (a.iterations, b.iterations)):
                ok &= bool(np.array_equal(p[:rows, ..., i], q[:rows, ..., i]))
            ok &= bool((b.iterations[rows:, i] == 0).all())
        return ok

    def states(p, q):
        return all(
            np.array_equal(a, b, equal_nan=True) for a, b in zip(p.state_arrays().values(), q.state_arrays().values())
        )

    cpu, gpu = system("cpu"), system("gpu")
    out = {"records": [], "states": [], "failed": []}
    held = []
    for every, nrec in ((2, 5), (3, 1), (1, 3)):
        a, b = step(cpu, every, nrec), step(gpu, every, nrec)
        out["records"].append(same(a, b, every))
        out["states"].append(states(cpu, gpu))
        out["failed"].append(int((b.fail[:, 0] >= 0).sum()))
        held.append((b, [b.x.copy(), b.v.copy(), b.iterations.copy()]))
    out["resident"] = gpu._dev is not None
    # records handed out are never overwritten by later chunks (their pinned buffers are not reused)
    out["held_intact"] = all(
        np.array_equal(p, q, equal_nan=True) for b, copies in held for p, q in zip((b.x, b.v, b.iterations), copies)
    )
    # snapshot and restore on the device: the chunk taken again from the snapshot gives the same bits
    snap = gpu.snapshot()
    first = step(gpu, 2, 1)
    first = (first.x.copy(), first.v.copy(), first.iterations.copy(), first.fail.copy(), gpu.state_arrays())
    gpu.restore(snap)
    again = step(gpu, 2, 1)
    out["snapshot_on_device"] = snap[1] is None
    out["restore"] = same(type(again)(*first[:4]), again, 2) and all(
        np.array_equal(p, q, equal_nan=True) for p, q in zip(first[4].values(), gpu.state_arrays().values())
    )
    step(cpu, 2, 1)
    # state_arrays into a fresh system on the GPU, which continues with the CPU's bits
    other = system("gpu")
    other.set_state_arrays(gpu.state_arrays())
    out["round_trip"] = same(step(cpu, 1, 2), step(other, 1, 2), 1) and states(cpu, other)
    # a write into the host arrays reaches the device before the next chunk
    for p in (cpu, other):
        p.x[0, 3] += 0.25
    out["host_write"] = same(step(cpu, 1, 1), step(other, 1, 1), 1) and states(cpu, other)
    return out


CHILD = (
    textwrap.dedent(r"""
    import json, sys, warnings
    import numpy as np
    warnings.simplefilter("ignore")  # the point put at the centre divides by zero, as on the CPU
    from numba import config
    assert config.ENABLE_CUDASIM
    import emorbit
    from emorbit.kernels.pointmass import cuda as K
    from emorbit.sweep import parse_sweep, run_sweep, use_device
    """)
    + f"CASES = {CASES!r}\n"
    + "\n".join(textwrap.dedent(inspect.getsource(f)) for f in (run_case, compare, resident_case))
    + textwrap.dedent(r'''
    out = {"available": K.available()}
    _, kernels = K._compile()
    scopes = [d.fn.__globals__ for d in K._devices.values()] + [k.dispatcher.fn.__globals__ for k in kernels.values()]
    before = [sorted(g) for g in scopes]
    out["chunks"] = {f"{m}{o} dt={dt}": compare(run_case(m, o, dt)) for m, o, dt in CASES}
    # the simulator iterates a device function's globals on every call, in every simulated
    # thread: a name added while the threads run (a warning's registry) races with that
    out["scopes_changed"] = [i for i, (g, b) in enumerate(zip(scopes, before)) if sorted(g) != b]
    gm, n = 3.9478, 33
    r = np.random.default_rng(5).uniform(4.0, 10.0, n)

    # a whole run through the Simulation: 40 points, em order 4, 200 steps
    def cloud():
        sim = emorbit.Simulation(emorbit.CentralField(gm=gm), method="em", order=4, dt=0.2)
        for i in range(40):
            sim.add_point(f"p{i}", mass=1.0, position=[r[i % n], 0.1 * i, 0.0], velocity=[0.0, 0.55, 0.01 * i])
        return sim
    cpu, gpu = cloud(), cloud()
    use_device(gpu, "gpu")
    rc = cpu.run(steps=200, every=50, progress=False).si
    rg = gpu.run(steps=200, every=50, progress=False).si
    rel = max(float(np.max(np.abs(rc.positions[k] - rg.positions[k]) / np.abs(rc.positions[k]).max()))
              for k in rc.names)
    out["simulation"] = {"rel": rel, "energy_error": float(np.abs(rg.relative_energy_error()).max()),
                         "angular_momentum_error": float(rg.relative_angular_momentum_error().max())}

    out["resident"] = resident_case()

    # checkpointed runs on the GPU whose steps fail and are redone in sub-steps (from device
    # snapshots): the CPU's file bit for bit, and a run resumed on the GPU from a checkpoint
    import h5py
    import emorbit.io.resume as resume_module

    def eccentric(device):
        sim = emorbit.Simulation(emorbit.CentralField(gm=gm), method="em", order=2, dt=3.0)
        for i in range(6):
            sim.add_point(f"q{i}", mass=1.0, position=[10.0 - i, 0.0, 0.1 * i], velocity=[0.0, 0.05 + 0.02 * i, 0.0])
        sim.device = device
        return sim

    d = sys.argv[1]
    retried = {}
    for device in ("cpu", "gpu"):
        sim = eccentric(device)
        sim.run(steps=30, every=5, progress=False, output=f"{d}/{device}.h5", checkpoint_every=10)
        retried[device] = sim.retried_steps
        if device == "gpu":
            resident = sim.points._dev is not None
    sim = eccentric("gpu")
    sim.run(steps=17, every=5, progress=False, output=f"{d}/part.h5", checkpoint_every=10)
    load = resume_module._load

    def load_on_gpu(path):  # resume() rebuilds the scene on the CPU: the same, with device "gpu"
        loaded = load(path)
        loaded.sim.device = "gpu"
        return loaded

    resume_module._load = load_on_gpu
    resume_module.resume(f"{d}/part.h5", 90.0, progress=False)
    resume_module._load = load

    def differ(a, b):
        bad = []
        with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
            fa.visititems(lambda k, o: bad.append(k) if isinstance(o, h5py.Dataset) and not k.startswith("checkpoint")
                          and not np.array_equal(o[()], fb[k][()]) else None)
        return bad

    out["checkpointed"] = {"retried": retried, "resident": resident, "cpu_vs_gpu": differ(f"{d}/cpu.h5", f"{d}/gpu.h5"),
                           "resumed": differ(f"{d}/gpu.h5", f"{d}/part.h5")}

    # the bench's gpu section says why it is skipped, and its rows run (timings meaningless here)
    from emorbit.bench import gpu as bench_gpu
    section = bench_gpu.run(config="tiny")
    row = bench_gpu._row(4, "em", 8, {"steps": 1, "repeats": 1})
    out["bench"] = {"skipped": section["skipped"], "met": section["targets"][0]["met"],
                    "row": [row[k] for k in ("gpu kernel", "gpu chunk", "gpu resident", "cpu ensemble")]}

    # a sweep with device = gpu, in this process
    sweep = parse_sweep("""
    [sweep]
    scene = "paper-ellipse"
    [set]
    integrator.t_end = "9.29516 s"
    [[parameter]]
    key = "integrator.method"
    values = ["em", "leapfrog"]
    """.replace("\n    ", "\n"))
    rows = {}
    for device in ("cpu", "gpu"):
        res = run_sweep(sweep, sys.argv[1] + "/" + device, backend="serial", device=device)
        rows[device] = res.rows
    out["sweep"] = {"status": [r["status"] for r in rows["gpu"]],
                    "rel": max(abs(a["satellite/a"] - b["satellite/a"]) / a["satellite/a"]
                               for a, b in zip(rows["cpu"], rows["gpu"]))}
    print("RESULT " + json.dumps(out))
''')
)


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, str(tmp_path_factory.mktemp("cudasim"))],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT ") :])


def test_simulator_kernels_equal_the_cpu_kernels(simulated):
    assert simulated["available"]
    for case, got in simulated["chunks"].items():
        assert got["rel"] == 0.0, (case, got)  # the simulator's IEEE doubles give the CPU's bits
        assert got["iterations_equal"] and got["fail_equal"], (case, got)
        assert got["fail_centre"] == [0, 2], (case, got)  # the point at the centre, on the GPU too
    assert simulated["chunks"]["em2 dt=0.46"]["iterations"] > 0
    assert simulated["chunks"]["em2 dt=60.0"]["failed"] > 1  # Newton's failures are reported alike
    assert simulated["scopes_changed"] == []  # no launch adds a name to a device function's globals


def test_simulation_on_the_simulated_gpu(simulated):
    sim = simulated["simulation"]
    assert sim["rel"] == 0.0
    assert sim["energy_error"] < 1e-13 and sim["angular_momentum_error"] < 1e-13
    assert simulated["sweep"]["status"] == ["completed", "completed"]
    assert simulated["sweep"]["rel"] == 0.0


def test_resident_path_equals_the_cpu_kernels(simulated):
    """The state kept on the (simulated) device across three chunks: states, records,
    iteration counts and failures are the CPU's bits through PointMasses.advance; records
    handed out stay intact; snapshots, restore, state_arrays and writes into the host arrays
    keep the device's state in step."""
    got = simulated["resident"]
    assert got["resident"], got
    assert got["records"] == [True, True, True] and got["states"] == [True, True, True], got
    assert got["failed"] == [1, 1, 1], got  # the point at the centre, in every chunk
    assert got["held_intact"], got
    assert got["snapshot_on_device"] and got["restore"] and got["round_trip"] and got["host_write"], got


def test_checkpointed_gpu_run_resumes_bit_for_bit(simulated):
    """A run on the GPU with failed steps redone in sub-steps writes the CPU's file, and one
    resumed on the GPU from a checkpoint continues it bit for bit."""
    got = simulated["checkpointed"]
    assert got["resident"]
    assert got["retried"]["gpu"] == got["retried"]["cpu"] >= 1, got
    assert got["cpu_vs_gpu"] == [] and got["resumed"] == [], got


def test_bench_gpu_section_is_skipped_without_a_gpu(simulated, tmp_path, capsys):
    """On the simulator and without a CUDA device the gpu section measures nothing, says why,
    and its target is "skipped" (met None); its rows run on the simulator."""
    bench = simulated["bench"]
    assert "simulator" in bench["skipped"] and bench["met"] is None
    assert all(x > 0 and np.isfinite(x) for x in bench["row"]), bench
    from emorbit.bench import gpu as bench_gpu
    from emorbit.bench.runner import run_bench
    from emorbit.kernels.pointmass import cuda as kcuda

    if kcuda.available():
        pytest.skip("a CUDA device is present")
    path = tmp_path / "gpu.json"
    assert run_bench(["gpu"], json_path=str(path), config="tiny") == 0
    data = json.loads(path.read_text())
    assert data["gpu"]["skipped"] == kcuda.device_problem() and data["gpu"]["rows"] == []
    assert data["targets"] == data["gpu"]["targets"] and data["targets"][0]["met"] is None
    assert "skipped: no CUDA device" in capsys.readouterr().out
    row = {"method": "em", "order": 2, "points": bench_gpu.TARGET_POINTS}
    assert bench_gpu._target([dict(row, resident_over_kernel=0.6)], None)["met"] is True
    assert bench_gpu._target([dict(row, resident_over_kernel=0.3)], None)["met"] is False
    assert bench_gpu._target([dict(row, points=10, resident_over_kernel=0.9)], None)["met"] is None
    assert bench_gpu._target([dict(row, order=8, resident_over_kernel=0.9)], None)["met"] is None  # order 2 only


def test_asking_for_a_gpu_without_one_is_a_clear_error(tmp_path, capsys):
    from emorbit.kernels.pointmass import cuda as kcuda

    if kcuda.available():
        pytest.skip("a CUDA device (or the simulator) is present")
    sim = emorbit.Simulation(emorbit.CentralField(gm=1.0), dt=0.1)
    sim.add_point("p", mass=1.0, position=[1.0, 0, 0], velocity=[0, 1.0, 0])
    from emorbit.sweep import use_device

    with pytest.raises(InputError, match="no CUDA device"):
        use_device(sim, "gpu")
    r = sim.run(steps=3, progress=False)  # the simulation is untouched and runs on the CPU
    assert np.abs(r.relative_energy_error()).max() < 1e-14
    f = tmp_path / "s.toml"
    f.write_text('[sweep]\nscene = "paper-ellipse"\n')
    from emorbit.cli import main

    assert main(["sweep", str(f), "-o", str(tmp_path / "o"), "--device", "gpu"]) == 2
    assert "no CUDA device" in capsys.readouterr().err


def _real_gpu() -> bool:
    """A real NVIDIA GPU (not the simulator) with numba's CUDA target: none in CI."""
    from numba import config

    from emorbit.kernels.pointmass import cuda as kcuda

    return not config.ENABLE_CUDASIM and kcuda.available()


real_gpu = pytest.mark.skipif(
    "not _real_gpu()", reason="no NVIDIA GPU here (CI has none); the simulator tests above check the device code"
)


@real_gpu
@pytest.mark.parametrize("contract", [False, True], ids=["fma0", "contracted"])
@pytest.mark.parametrize("method, order, dt", CASES)
def test_real_gpu_agrees_with_the_cpu_kernels(method, order, dt, contract):
    """On a real GPU, compiled with NVVM's -fma=0 and without link-time optimisation (what
    chunk does), the GPU gives the CPU ensemble kernel's bits: states, records, iteration
    counts and failures. With NVVM's default contraction into fused multiply-adds the states
    differ at round-off (1e-13 relative after 12 steps); at dt = 60 s, where Newton fails
    for most points and which ones is decided at round-off, the count of failures may
    differ by a few."""
    got = compare(run_case(method, order, dt, contract=contract))
    assert got["fail_centre"] == [0, 2], got
    if contract:
        assert got["rel"] <= 1e-13, got
        assert got["fail_equal"] or (dt == 60.0 and abs(got["failed"] - got["failed_cpu"]) <= 3), got
    else:
        assert got["rel"] == 0.0 and got["iterations_equal"] and got["fail_equal"], got


@real_gpu
def test_real_gpu_energy_error_is_a_random_walk():
    """16384 perturbed copies of the paper's orbit, 1e5 em steps of T/100 on the GPU: the mean
    relative energy error stays within 3 standard errors of zero (no drift of one sign from
    the fused multiply-adds NVVM forms)."""
    from conftest import energy_drift_z

    z, per_step = energy_drift_z("brouwer", steps=100_000, members=16384, seed=0, device="gpu")
    assert abs(z) < 3.0, (z, per_step)


@real_gpu
@pytest.mark.parametrize("div", [20, 30, 60, 100])
def test_real_gpu_no_drift_at_large_steps(div):
    """65536 perturbed copies of the paper's orbit, 1e6 em steps of T/div on the GPU (the CPU
    kernel's bits, 256 times the statistics CI can afford): the ensemble mean of the relative
    energy error within 3.5 standard errors of zero. Measured on an H100: z +1.51, +0.93,
    -0.76, +0.95 for T/20, T/30, T/60, T/100 with steps of t > 1/128 finished on the
    accurate g_em; with only t > 1/32 finished -21.7, +13.8, +17.8, +5.4. The two-update step
    (2026-11-23), before its acceptance guards: T/30 +0.40, T/60 +1.12, T/100 +0.50, and T/20
    -953 (steps whose Newton update ran off, accepted: the guards' reason; with them, T/20
    was measured on the CPU only, 1024 copies, z -1.4 to +0.6 over four seeds). The one-update
    step (2026-11-23, second session) is not yet measured here (no GPU in that session); on the
    CPU, 1024 copies, two seeds: T/20 +0.78, -0.31; T/30 +0.57, -0.60; T/60 -0.09, -0.04; T/100
    -1.10, +1.52."""
    from conftest import PAPER_GM, PAPER_T, PAPER_V0, PAPER_X0

    from emorbit.kernels.pointmass import cuda as kcuda
    from emorbit.kernels.pointmass import packed as ens

    n, steps = 65536, 1_000_000
    rng = np.random.default_rng(0)
    x = np.repeat(np.asarray(PAPER_X0, float)[:, None], n, axis=1)
    v = np.asarray(PAPER_V0, float)[:, None] * (1.0 + 1e-9 * rng.normal(size=n))[None, :]

    def energy(x, v):
        return 0.5 * np.sum(v * v, axis=0) - PAPER_GM / np.linalg.norm(x, axis=0)

    e0 = energy(x, v)
    out = (np.empty((1, 3, n)), np.empty((1, 3, n)), np.zeros((1, n), np.int64), np.full((n, 2), -1, np.int64))
    kcuda.chunk(
        ens.METHOD_EM,
        x,
        v,
        np.zeros_like(x),
        np.zeros_like(v),
        PAPER_GM,
        np.zeros(3),
        PAPER_T / div,
        np.array([1.0]),
        steps,
        1,
        50,
        *out,
    )
    assert (out[3][:, 0] < 0).all()
    rel = energy(x, v) / e0 - 1.0
    z = rel.mean() / (rel.std() / np.sqrt(n))
    assert abs(z) < 3.5, (z, rel.mean() / steps)


@pytest.mark.parametrize(
    "numpy_version, numba_cuda, broken",
    [("2.5.0", "0.30.4", True), ("2.5.1", "0.29.0", True), ("2.4.6", "0.30.4", False), ("2.5.0", "0.31.0", False),
     ("2.6.0.dev0+abc", "0.30.4", True), ("2.5.0", None, False)],
)  # fmt: skip
def test_a_numpy_the_cuda_compiler_cannot_use_is_named(numpy_version, numba_cuda, broken):
    """numba-cuda <= 0.30.4 calls numpy.row_stack, gone in NumPy 2.5: the device check says so
    and how to fix it, instead of a compile error from deep in numba-cuda."""
    from emorbit.kernels.pointmass import cuda as kcuda

    problem = kcuda._numpy_problem(numpy_version, numba_cuda)
    assert (problem is not None) == broken
    if broken:
        assert numpy_version in problem and numba_cuda in problem and "numpy<2.5" in problem
