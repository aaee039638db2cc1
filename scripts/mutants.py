"""Mutation check: deliberate breakage that the test suite must catch.

Each mutant is one textual change to one source file of the package: g_em perturbed by
1e-12 relative in each kernel that has one, a compensation dropped, a checkpoint field
dropped, a Jacobian entry perturbed, the algorithmic stress replaced by the end-of-step
stress, an effect's work or force made wrong. For each mutant the script copies the tracked
files of the repository into a scratch folder, applies the change there (never to this
checkout), and runs the test files (and ``-k`` selection) that claim to test that code,
stopping at the first failure. A mutant is *killed* when a test fails with an assertion;
it is *alive* when every selected test passes, and an *error* (a collection error, a
crash) counts as alive too, since it proves nothing about the tests. The script prints
which test killed each mutant as soon as that mutant's run ends (in the order they finish, not
the order of the list) and exits with 1 when any mutant is alive.

Every scratch copy is a new install path, so its kernels compile afresh (emorbit's JIT
cache is per install and cleared when a kernel source changes): a mutant in a function
that other kernels inline reaches them all.

Usage::

    python scripts/mutants.py                 # every mutant, two at a time
    python scripts/mutants.py --list          # the mutants and their tests
    python scripts/mutants.py --only M2,M5    # some of them
    python scripts/mutants.py --jobs 1

The run of `.ci/run` (and the README's test command) calls it after the test suite.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Mutant:
    """One deliberate change and the tests that must catch it.

    Attributes
    ----------
    name : str
        A short label (``M1``...).
    what : str
        What the change breaks, in words.
    path : str
        The file changed, relative to the repository root.
    old, new : str
        The text replaced (it must occur exactly once in the file) and its replacement.
    tests : tuple of str
        pytest arguments: test files or node ids, and ``-k`` expressions.
    """

    name: str
    what: str
    path: str
    old: str
    new: str
    tests: tuple[str, ...]


MUTANTS = (
    Mutant(
        "M1",
        "the packed point-mass kernel's g_em off by 1e-12 relative",
        "emorbit/kernels/pointmass/roots.py",
        "    return gm / ((Q + tau0) + tlo)\n",
        "    return gm / ((Q + tau0) + tlo) * (1.0 + 1e-12)\n",
        ("tests/test_pointmass.py", "-k", "conserves_energy or keeps_a_and_e"),
    ),
    Mutant(
        "M2",
        "Kahan compensation zeroed in kahan_add",
        "emorbit/kernels/eft.py",
        "    return t, (t - s) - y\n",
        "    return t, 0.0 * ((t - s) - y)\n",
        ("tests/test_compensation.py",),
    ),
    Mutant(
        "M3",
        "the central effect's g_em with (r0 + r1) * (1 + 1e-12) (elastic and coupled bodies)",
        "emorbit/kernels/effects/central.py",
        "    k = -gm / (r0 * r1 * (r0 + r1))\n    return k * (a0 + b0)",
        "    k = -gm / (r0 * r1 * ((r0 + r1) * (1.0 + 1e-12)))\n    return k * (a0 + b0)",
        ("tests/test_eccentric_bodies.py", "-k", "elastic or coupled"),
    ),
    Mutant(
        "M4",
        "a checkpoint drops the point masses' compensations cx, cv",
        "emorbit/bodies/pointmasses.py",
        'BASE_FIELDS = ("x", "v", "cx", "cv")',
        'BASE_FIELDS = ("x", "v")',
        ("tests/test_resume.py",),
    ),
    Mutant(
        "M5",
        "the central effect's g_em with (r0 + r1) * (1 + 1e-8) (elastic and coupled bodies)",
        "emorbit/kernels/effects/central.py",
        "    k = -gm / (r0 * r1 * (r0 + r1))\n    return k * (a0 + b0)",
        "    k = -gm / (r0 * r1 * ((r0 + r1) * (1.0 + 1e-8)))\n    return k * (a0 + b0)",
        ("tests/test_eccentric_bodies.py", "-k", "elastic or coupled"),
    ),
    Mutant(
        "E1",
        "the elastic bar's algorithmic strain replaced by the end-of-step strain",
        "emorbit/kernels/elastic.py",
        "            eb = 0.5 * (e0 + e1)\n",
        "            eb = e1 + 0.0 * e0\n",
        ("tests/test_eccentric_bodies.py", "-k", "chain"),
    ),
    Mutant(
        "E2",
        "the tetrahedron's algorithmic stress replaced by the end-of-step stress",
        "emorbit/kernels/elastic.py",
        "E[i, j] = 0.25 * (c0 + c1) - (0.5 if i == j else 0.0)",
        "E[i, j] = 0.5 * c1 + 0.0 * c0 - (0.5 if i == j else 0.0)",
        ("tests/test_eccentric_bodies.py", "-k", "block"),
    ),
    Mutant(
        "E3",
        "an entry of the tetrahedron's tangent (Jacobian) perturbed by 1e-3 relative",
        "emorbit/kernels/elastic.py",
        "kt[e, a, b, i, k] = -0.5 * V * (s + (gsg if i == k else 0.0))",
        "kt[e, a, b, i, k] = -0.5 * V * (s + (gsg if i == k else 0.0)) * (1.001 if i == 0 and k == 1 else 1.0)",
        ("tests/test_elastic.py", "-k", "quadratically or finite_differences"),
    ),
    Mutant(
        "R1",
        "as M3, caught by the rigid body (its step takes the central effect's force too)",
        "emorbit/kernels/effects/central.py",
        "    k = -gm / (r0 * r1 * (r0 + r1))\n    return k * (a0 + b0)",
        "    k = -gm / (r0 * r1 * ((r0 + r1) * (1.0 + 1e-12)))\n    return k * (a0 + b0)",
        ("tests/test_eccentric_bodies.py", "-k", "rigid"),
    ),
    Mutant(
        "Z1",
        "the zonal force off by 1e-9 relative, 1e-12 of gravity (rigid and elastic bodies)",
        "emorbit/kernels/effects/zonal.py",
        "    k = p[6] / (p[7] * p[7])\n    ku = -k * A / (r0 + r1)\n",
        "    k = p[6] / (p[7] * p[7]) * (1.0 + 1e-9)\n    ku = -k * A / (r0 + r1)\n",
        ("tests/test_effects.py", "-k", "tumbling_box_with_j2"),
    ),
    Mutant(
        "Z2",
        "the packed zonal kernel's g_em off by 1e-12 relative (point masses with J2..J6)",
        "emorbit/kernels/effects/zonal_packed.py",
        "    K = gm * iQ\n",
        "    K = gm * iQ * (1.0 + 1e-12)\n",
        ("tests/test_zonal_packed.py", "-k", "energy_and_the_pole"),
    ),
    Mutant(
        "G1",
        "mutual gravity's pair force off by 1e-12 relative",
        "emorbit/kernels/effects/mutual.py",
        "                ga = gb = g * m[a] * m[b]\n",
        "                ga = gb = g * m[a] * m[b] * (1.0 + 1e-12)\n",
        ("tests/test_mutual_bodies.py", "-k", "rigid_binary and 20000"),
    ),
    Mutant(
        "T1",
        "a third body's indirect force off by 1e-4 relative (it is 1e-7 of gravity in LEO)",
        "emorbit/kernels/effects/third_body.py",
        "        k = gm / (sigma * sigma * sigma)\n        fx -= k * sx",
        "        k = gm / (sigma * sigma * sigma) * (1.0 + 1e-4)\n        fx -= k * sx",
        ("tests/test_energy_balance.py", "-k", "balance_closes and third_body and point"),
    ),
    Mutant(
        "D1",
        "the recorded work of a force on a point off by 1e-9 relative (not m F . (x1 - x0) exactly)",
        "emorbit/effects/program.py",
        "{row} = mb[j] * (gx * d0 + gy * d1 + gz * d2) if kc",
        "{row} = mb[j] * (gx * d0 + gy * d1 + gz * d2) * (1.0 + 1e-9) if kc",
        ("tests/test_energy_balance.py", "-k", "balance_closes and drag and point"),
    ),
    Mutant(
        "S1",
        "the recorded work of a force on a rigid body's facet off by 1e-3 relative",
        "emorbit/effects/program.py",
        'f] = gx * (b0 - a0) + gy * (b1 - a1) + gz * (b2 - a2)"',
        'f] = (gx * (b0 - a0) + gy * (b1 - a1) + gz * (b2 - a2)) * (1.0 + 1e-3)"',
        ("tests/test_energy_balance.py", "-k", "balance_closes and srp and rigid"),
    ),
    Mutant(
        "F1",
        "the reference kernel's accurate g_em (em_accel_dd_lo) off by 1e-12 relative",
        "emorbit/kernels/gravity.py",
        "    k = gm * iP\n    kl = (fma(-k, P, gm) - k * Pl) * iP\n",
        "    k = gm * iP\n    kl = (fma(-k, P, gm) - k * Pl) * iP + k * 1e-12\n",
        ("tests/test_ensemble.py", "-k", "same_trajectories_as_reference"),
    ),
    Mutant(
        "A1",
        "the adaptive control's closing kick reads the composed step's start (not time-symmetric)",
        "emorbit/kernels/pointmass/adaptive.py",
        "            g = _g(t0, t1, t2, u0, u1, u2, c0, c1, c2, gm, eta)\n",
        "            g = _g(s[0], s[1], s[2], s[3], s[4], s[5], c0, c1, c2, gm, eta)\n",
        ("tests/test_adaptive.py", "-k", "run_back"),
    ),
    Mutant(
        "A4",
        "em's adaptive composed step no longer restores the compensated state's energy",
        "emorbit/kernels/pointmass/adaptive.py",
        "        q, eh, el = _restore_energy(q, eh, el, gm, c0, c1, c2)\n",
        "        pass\n",
        ("tests/test_adaptive.py", "-k", "restores"),
    ),
    Mutant(
        "A5",
        "a failed adaptive step halves at once, never starting its control afresh",
        "emorbit/kernels/adaptive.py",
        "            if not reset:\n                # first failure",
        "            if False:\n                # first failure",
        ("tests/test_adaptive.py", "-k", "e099"),
    ),
    Mutant(
        "A3",
        "a rigid body's adaptive closing kick reads g at the sub-step's start (not time-symmetric)",
        "emorbit/kernels/rigid_adaptive.py",
        "            r1, g = _control(tp, tu, E, Jinv, gm, c, eta)\n            a = ak * g\n",
        "            r1, g1 = _control(tp, tu, E, Jinv, gm, c, eta)\n            a = ak * g\n",
        ("tests/test_adaptive_bodies.py", "-k", "rigid_steps_run_back"),
    ),
    Mutant(
        "Z3",
        "the packed zonal kernel's pole-along-z variant also taken for the pole (0, 0, -1)",
        "emorbit/kernels/effects/zonal_packed.py",
        "zonal_p[5] == 1.0))",
        "abs(zonal_p[5]) == 1.0))",
        ("tests/test_zonal_poles.py", "-k", "south"),
    ),
    Mutant(
        "Z4",
        "the zonal effect's default pole written (0, 0, -1)",
        "emorbit/effects/zonal.py",
        'table.get("pole", [0.0, 0.0, 1.0])',
        'table.get("pole", [0.0, 0.0, -1.0])',
        ("tests/test_zonal_poles.py", "-k", "default_pole"),
    ),
    Mutant(
        "A6",
        "the time left to the landing takes the Kahan compensation with the wrong sign",
        "emorbit/kernels/adaptive.py",
        "rem = (length - elapsed) + comp",
        "rem = (length - elapsed) - comp",
        ("tests/test_adaptive_landing.py",),
    ),
    Mutant(
        "W1",
        "the work of a sub-step evaluated over the previous sub-step's length (orders 4 and 8)",
        "emorbit/kernels/pointmass/effect_step.py",
        "work_of(x, dx, m, body, coef, h, mode, P, I, T, S, out)",
        "work_of(x, dx, m, body, coef, hp[0], mode, P, I, T, S, out)",
        ("tests/test_drag.py", "-k", "every_order"),
    ),
    Mutant(
        "W2",
        "the work sum's Kahan compensation computed but never added back",
        "emorbit/kernels/pointmass/effect_step.py",
        "work[k, i], cwork[k, i] = _kahan(work[k, i], cwork[k, i], out[k, i])",
        "work[k, i], cwork[k, i] = _kahan(work[k, i], 0.0, out[k, i])",
        ("tests/test_drag.py", "-k", "every_order"),
    ),
    Mutant(
        "EP1",
        "an epoch without a time scale read as TDB, not UTC (69 s off in 2026)",
        "emorbit/epochs.py",
        '    scale = "utc"\n',
        '    scale = "tdb"\n',
        ("tests/test_epochs.py",),
    ),
    Mutant(
        "MU1",
        "a rigid mesh's mesh_unit scale passed positionally as the message argument: mm read as m",
        "emorbit/bodies/rigid_input.py",
        'nodes = shapes.mesh_coordinates(nodes, f"{key}.nodes") * scale',
        'nodes = shapes.mesh_coordinates(nodes, f"{key}.nodes", scale)',
        ("tests/test_mesh_units.py", "-k", "starts_as"),
    ),
    Mutant(
        "MU2",
        "an HDF5 mesh file's unit scale passed positionally as the message argument: mm read as m",
        "emorbit/bodies/meshes.py",
        'X = mesh_coordinates(arrays["nodes"], where, f"/nodes of {path!r}", scale)',
        'X = mesh_coordinates(arrays["nodes"], where, scale)',
        ("tests/test_mesh_units.py", "-k", "elastic"),
    ),
    Mutant(
        "EL1",
        "a result's elements about the origin, the field's centre dropped",
        "emorbit/result.py",
        "return orbits.elements(self.positions[name], self.velocities[name], self.gm, self.center)",
        "return orbits.elements(self.positions[name], self.velocities[name], self.gm)",
        ("tests/test_elements.py", "-k", "off_the_origin"),
    ),
    Mutant(
        "C1",
        "the CUDA kernel leaves the last point of an ensemble unstepped",
        "emorbit/kernels/pointmass/cuda.py",
        "        if i < x.shape[1]:\n",
        "        if i < x.shape[1] - 1:\n",
        ("tests/test_cuda.py", "-k", "simulator_kernels"),
    ),
)


def _copy_tree(dest: Path) -> None:
    """The tracked files of the repository (and untracked ones git does not ignore) into dest."""
    names = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        check=True,
    ).stdout.split(b"\0")
    for raw in names:
        if not raw:
            continue
        rel = raw.decode()
        src = ROOT / rel
        if not src.is_file():
            continue
        out = dest / rel
        out.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, out)


def apply(mutant: Mutant, tree: Path) -> None:
    """Apply ``mutant`` to the copy under ``tree``.

    Raises
    ------
    SystemExit
        Where ``mutant.old`` does not occur exactly once (the list is out of date) or the
        changed file no longer compiles.
    """
    path = tree / mutant.path
    text = path.read_text()
    n = text.count(mutant.old)
    if n != 1:
        raise SystemExit(f"mutant {mutant.name}: its text occurs {n} times in {mutant.path}, not once")
    text = text.replace(mutant.old, mutant.new)
    compile(text, str(path), "exec")
    path.write_text(text)


def run_one(mutant: Mutant, scratch: Path, threads: int) -> dict:
    """Run the mutant's tests on a mutated copy; returns ``name``, ``status`` (killed or
    alive), ``by`` (the test that failed, or the reason it is alive) and ``seconds``."""
    tree = scratch / mutant.name
    _copy_tree(tree)
    apply(mutant, tree)
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree) + os.pathsep + env.get("PYTHONPATH", "")
    env["NUMBA_NUM_THREADS"] = str(threads)
    env.pop("NUMBA_CACHE_DIR", None)
    env["XDG_CACHE_HOME"] = str(scratch / f"{mutant.name}-cache")
    check = subprocess.run(
        [sys.executable, "-c", "import emorbit, sys; print(emorbit.__file__)"],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
    )
    if not check.stdout.strip().startswith(str(tree)):
        return {
            "name": mutant.name,
            "status": "alive",
            "by": f"the copy was not imported: {check.stdout}{check.stderr}",
        }
    t0 = time.perf_counter()
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-x",
            "-q",
            "-rf",
            "-p",
            "no:cacheprovider",
            "-p",
            "no:randomly",
            *mutant.tests,
        ],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
    )
    seconds = time.perf_counter() - t0
    out = done.stdout + done.stderr
    failed = re.findall(r"^FAILED (\S+)", out, re.M)
    if done.returncode == 1 and failed:
        return {"name": mutant.name, "status": "killed", "by": failed[0], "seconds": seconds}
    if done.returncode == 1 and "RoundoffWarning" in out:  # the drift monitor saw it (warnings are errors)
        return {
            "name": mutant.name,
            "status": "killed",
            "by": "the drift monitor (a RoundoffWarning)",
            "seconds": seconds,
        }
    if done.returncode == 0:
        why = "every selected test passed"
    else:
        tail = "\n    ".join(out.strip().splitlines()[-6:])
        why = f"pytest exited with {done.returncode} without a failing assertion:\n    {tail}"
    return {"name": mutant.name, "status": "alive", "by": why, "seconds": seconds}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--list", action="store_true", help="print the mutants and their tests, run nothing")
    parser.add_argument("--only", default="", help="comma-separated names of the mutants to run")
    parser.add_argument("--jobs", type=int, default=2, help="mutants run side by side (default 2)")
    parser.add_argument("--keep", action="store_true", help="keep the scratch folder and print its path")
    args = parser.parse_args(argv)
    chosen = list(MUTANTS)
    if args.only:
        wanted = [s.strip() for s in args.only.split(",") if s.strip()]
        known = {m.name for m in MUTANTS}
        unknown = [w for w in wanted if w not in known]
        if unknown:
            parser.error(f"--only: unknown mutant(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        chosen = [m for m in MUTANTS if m.name in wanted]
    if args.list:
        for m in chosen:
            print(f"{m.name:4} {m.what}\n     {m.path}; tests: {' '.join(m.tests)}")
        return 0
    if args.jobs < 1:
        parser.error(f"--jobs must be at least 1, not {args.jobs}")
    scratch = Path(tempfile.mkdtemp(prefix="emorbit-mutants-"))
    threads = max(1, (os.cpu_count() or 1) // args.jobs)
    t0 = time.perf_counter()
    print(f"{len(chosen)} mutants, {args.jobs} at a time; each line as its mutant finishes", flush=True)
    results = []
    try:
        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            running = {pool.submit(run_one, m, scratch, threads): m for m in chosen}
            for done in as_completed(running):
                m, r = running[done], done.result()
                results.append(r)
                secs = f"{r['seconds']:6.1f} s" if "seconds" in r else "       "
                print(f"{m.name:4} {r['status']:6} {secs}  {m.what}\n     by {r['by']}", flush=True)
    finally:
        if args.keep:
            print(f"scratch copies in {scratch}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)
    alive = [r for r in results if r["status"] != "killed"]
    print(
        f"{len(results) - len(alive)} of {len(results)} mutants killed in {time.perf_counter() - t0:.0f} s"
        + (f"; alive: {', '.join(r['name'] for r in alive)}" if alive else "")
    )
    return 1 if alive else 0


if __name__ == "__main__":
    sys.exit(main())
