"""The CUDA point-mass kernels against the CPU reference kernels, on numba's CUDA simulator.

The simulator is switched on by ``NUMBA_ENABLE_CUDASIM=1`` when numba is imported, and then
replaces numba.cuda for the whole process; so the comparisons run in a child process and
nothing of the simulator reaches the other tests. Without a GPU this is what CI can check:
the device code (the CPU kernels' own Python functions compiled for CUDA) takes the same
steps. On a real GPU the fused multiply-adds NVVM forms make results differ at round-off.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import emorbit
from emorbit.errors import InputError

CHILD = textwrap.dedent(r'''
    import json, sys, warnings
    import numpy as np
    warnings.simplefilter("ignore")  # the point put at the centre divides by zero, as on the CPU
    from numba import config
    assert config.ENABLE_CUDASIM
    import emorbit
    from emorbit.integrators import coefficients
    from emorbit.kernels import cuda as K, pointmass as P
    from emorbit.sweep import parse_sweep, run_sweep, use_device

    out = {"available": K.available()}
    rng = np.random.default_rng(5)
    n, gm, center = 33, 3.9478, np.array([0.5, -0.25, 0.1])
    r = rng.uniform(4.0, 10.0, n)
    x = np.vstack([r, np.zeros(n), rng.uniform(-1, 1, n)]) + center[:, None]
    v = np.vstack([rng.uniform(-0.02, 0.02, n), np.sqrt(gm / r) * rng.uniform(0.5, 1.15, n),
                   rng.uniform(-0.05, 0.05, n)])
    x[:, 7] = center  # a point at the centre fails at once (status 2), on both
    cases = {}
    for method, order, dt in (("em", 2, 0.46), ("em", 4, 0.46), ("em", 2, 60.0), ("midpoint", 2, 0.46),
                              ("leapfrog", 2, 0.46), ("leapfrog", 6, 0.46)):
        every, nrec = 4, 3
        runs = []
        for device in ("cpu", "gpu"):
            a = [x.copy(), v.copy(), np.zeros_like(x), np.zeros_like(v)]
            rec = [np.zeros((nrec, 3, n)), np.zeros((nrec, 3, n)), np.zeros((nrec, n), np.int64),
                   np.full((n, 2), -1, np.int64)]
            g = coefficients(order)
            if device == "gpu":
                K.chunk(K.METHODS[method], *a, gm, center, dt, g, every, nrec, 50, *rec)
            elif method == "leapfrog":
                P.leapfrog_chunk(*a, gm, center, dt, g, every, nrec, 50, *rec)
            else:
                P.implicit_chunk(K.METHODS[method], *a, gm, center, dt, g, every, nrec, 50, *rec)
            runs.append((a, rec))
        (a1, r1), (a2, r2) = runs
        rel = 0.0
        for p, q in zip(a1[:2] + r1[:2], a2[:2] + r2[:2]):
            d = np.abs(p - q) / np.maximum(np.abs(p), 1e-300)
            rel = max(rel, float(np.nanmax(np.where(np.isnan(p) & np.isnan(q), 0.0, d))))
        cases[f"{method}{order} dt={dt}"] = {
            "rel": rel, "iterations_equal": bool(np.array_equal(r1[2], r2[2])),
            "fail_equal": bool(np.array_equal(r1[3], r2[3])), "fail_centre": r2[3][7].tolist(),
            "failed": int((r2[3][:, 0] >= 0).sum()), "iterations": int(r2[2].sum())}
    out["chunks"] = cases

    # a whole run through the Simulation: 40 points, em order 4, 200 steps
    def cloud():
        sim = emorbit.Simulation(emorbit.CentralField(gm=gm), method="em", order=4, dt=0.2)
        for i in range(40):
            sim.add_point(f"p{i}", mass=1.0, position=[r[i % n], 0.1 * i, 0.0], velocity=[0.0, 0.55, 0.01 * i])
        return sim
    cpu, gpu = cloud(), cloud()
    use_device(gpu, "gpu")
    rc = cpu.run(steps=200, every=50, progress=False)
    rg = gpu.run(steps=200, every=50, progress=False)
    rel = max(float(np.max(np.abs(rc.positions[k] - rg.positions[k]) / np.abs(rc.positions[k]).max()))
              for k in rc.names)
    out["simulation"] = {"rel": rel, "energy_error": float(np.abs(rg.relative_energy_error()).max()),
                         "angular_momentum_error": float(rg.relative_angular_momentum_error().max())}

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


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    proc = subprocess.run([sys.executable, "-c", CHILD, str(tmp_path_factory.mktemp("cudasim"))], env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


def test_simulator_kernels_equal_the_cpu_kernels(simulated):
    assert simulated["available"]
    for case, got in simulated["chunks"].items():
        assert got["rel"] <= 1e-12, (case, got)
        assert got["iterations_equal"] and got["fail_equal"], (case, got)
        assert got["fail_centre"] == [0, 2], (case, got)  # the point at the centre, on the GPU too
    assert simulated["chunks"]["em2 dt=0.46"]["iterations"] > 0
    assert simulated["chunks"]["em2 dt=60.0"]["failed"] > 1  # Newton's failures are reported alike


def test_simulation_on_the_simulated_gpu(simulated):
    sim = simulated["simulation"]
    assert sim["rel"] <= 1e-12
    assert sim["energy_error"] < 1e-13 and sim["angular_momentum_error"] < 1e-13
    assert simulated["sweep"]["status"] == ["completed", "completed"]
    assert simulated["sweep"]["rel"] <= 1e-12


def test_asking_for_a_gpu_without_one_is_a_clear_error(tmp_path, capsys):
    from emorbit.kernels import cuda as kcuda

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
