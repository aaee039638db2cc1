"""The ``perturbed`` section of ``emorbit bench``: every peer's force model is emorbit's (at
100 random states and times per case, each referee's acceleration against the effect set's own,
to 1e-13 of it; on the GEO with EGM2008's C22/S22 turning with the Earth, a comparison that
sees C22/S22 and the field's angle), and the section in its tiny configuration (7200 s of LEO, one setting per
engine) returns the rows and columns it promises, em's energy balance at round-off, and
``skipped`` rows for a peer that is not installed. Timings are never asserted. About 30 s of
CPU with Numba's cache filled."""

import math
import sys
import types

import numpy as np
import pytest

from emorbit.bench import SECTIONS, perturbed
from emorbit.bench.common import CONFIGS
from emorbit.bench.perturbed_models import em_acceleration
from emorbit.bench.perturbed_peers import _rebound
from emorbit.bench.runner import _jsonable, _sections, targets

#: the agreement asked of every referee's acceleration, relative to emorbit's
AGREE = 1e-13
#: the states of the comparison, per case
STATES = 100


def _states(case, duration, seed=3):
    """(t, x, v) at random times, within 100 km (LEO) or 3 % of a of the orbit's radius,
    random directions and speeds about the circular one (some in the Earth's shadow)."""
    rng = np.random.default_rng(seed)
    x0, v0, a = perturbed.initial_state(case)
    e = case.elements[1]
    out = []
    for _ in range(STATES):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        r = rng.uniform(a * (1 - e) + 50e3, a * (1 + e)) if e > 0.1 else a + rng.uniform(-100e3, 100e3)
        w = rng.normal(size=3)
        out.append((rng.uniform(0.0, duration), u * r, w / np.linalg.norm(w) * np.linalg.norm(v0)))
    return out


@pytest.fixture(scope="module", params=list(perturbed.CASES))
def case_model(request):
    case = perturbed.CASES[request.param]
    duration = min(case.duration, 2 * 86400.0)
    model, sim = perturbed.model(case, duration)
    states = _states(case, duration)
    em = [em_acceleration(sim, perturbed.COEFFICIENTS, t, x, v) for t, x, v in states]
    return case, model, states, em


def _worst(em, other) -> float:
    return max(float(np.linalg.norm(np.asarray(b) - a) / np.linalg.norm(a)) for a, b in zip(em, other))


def test_the_float_model_is_emorbits(case_model):
    """The model scipy's DOP853 and REBOUND's callback evaluate."""
    case, model, states, em = case_model
    ours = [model.acceleration(t, list(x), list(v)) for t, x, v in states]
    assert _worst(em, ours) <= AGREE
    shade = [model.shadow(list(x), model.srp[4].state(t)[0]) for t, x, v in states] if model.srp else []
    if case.name == "leo":
        assert 0.0 in shade and 1.0 in shade  # both sides of the shadow's edge are compared


def test_the_model_has_every_effect(case_model):
    case, model, _, _ = case_model
    if case.field_order:  # the rotating field carries J2: no zonal effect beside it
        assert model.zonal is None and model.field[2:4] == (case.degree, case.field_order)
        assert model.field[4][2, 2] != 0.0 and model.field[5][2, 2] != 0.0
    else:
        assert model.field is None and len(model.zonal[2]) == case.degree - 1
    assert len(model.bodies) == 2
    assert (model.drag is not None) == case.drag and (model.srp is not None) == case.srp


def test_rebounds_forces_are_emorbits(case_model):
    """REBOUND's own central gravity (G = 1, a mass GM) plus the ``additional_forces`` callback."""
    pytest.importorskip("rebound")
    _, model, states, em = case_model
    x0 = np.concatenate(states[0][1:])
    sim, forces = _rebound(model, x0, 1e-9, False)
    ours = []
    for t, x, v in states:
        p = sim.particles[1]
        p.x, p.y, p.z = x
        p.vx, p.vy, p.vz = v
        p.ax = p.ay = p.az = 0.0
        sim.t = t
        forces(types.SimpleNamespace(contents=sim))
        r = np.linalg.norm(x)
        ours.append(np.array([p.ax, p.ay, p.az]) - sim.particles[0].m * x / r**3)
    assert _worst(em, ours) <= AGREE


def test_heyokas_forces_are_emorbits(case_model):
    """heyoka's expressions, compiled as a cfunc, with the parameters its runs set."""
    hy = pytest.importorskip("heyoka")
    from emorbit.bench.perturbed_models import heyoka_system

    _, model, states, em = case_model
    system, set_pars, _ = heyoka_system(model, hy)
    cf = hy.cfunc([rhs for _, rhs in system[3:6]], [var for var, _ in system])
    npar = 13 * len(model.tables()) + (1 if model.srp else 0)
    ours = []
    for t, x, v in states:
        pars = np.zeros(npar)
        set_pars(pars, t)
        if model.srp:
            pars[-1] = model.shadow(list(x), model.srp[4].state(t)[0])
        ours.append(cf(np.concatenate([x, v, [0.0]]), pars=pars, time=t))
    assert _worst(em, ours) <= AGREE


def _changed(model, states, **change) -> list:
    """The float model's accelerations with its rotating field changed (C, S, theta0 by name)."""
    keep = model.field
    mu, radius, n, m, C, S, B, P, theta0, w = keep
    fields = {"C": C, "S": S, "theta0": theta0} | change
    model.field = (mu, radius, n, m, fields["C"], fields["S"], B, P, fields["theta0"], w)
    try:
        return [model.acceleration(t, list(x), list(v)) for t, x, v in states]
    finally:
        model.field = keep


def test_a_wrong_model_is_caught(case_model):
    """The comparison sees a change of J2 by one part in 1e7 (at GEO, 4e-6 of the acceleration)."""
    _, model, states, em = case_model
    if model.field is not None:
        C = model.field[4].copy()
        C[2, 0] *= 1 + 1e-7
        assert _worst(em, _changed(model, states, C=C)) > AGREE
        return
    pole, radius, jn = model.zonal
    model.zonal = (pole, radius, (jn[0] * (1 + 1e-7), *jn[1:]))
    try:
        ours = [model.acceleration(t, list(x), list(v)) for t, x, v in states]
    finally:
        model.zonal = (pole, radius, jn)
    assert _worst(em, ours) > AGREE


def test_the_comparison_sees_c22_s22_and_the_rotation(case_model):
    """On the GEO, C22/S22 are 1e-7 of the acceleration: the comparison sees them dropped, each
    changed by one part in 1e4, and the field's angle off by 1e-5 rad."""
    case, model, states, em = case_model
    if not case.field_order:
        pytest.skip("no rotating field in this case")
    assert _worst(em, _changed(model, states)) <= AGREE  # the unchanged model passes
    for name in ("C", "S"):
        zero, off = model.field[4 if name == "C" else 5].copy(), model.field[4 if name == "C" else 5].copy()
        zero[2, 1:] = 0.0
        off[2, 2] *= 1 + 1e-4
        assert _worst(em, _changed(model, states, **{name: zero})) > 1e3 * AGREE
        assert _worst(em, _changed(model, states, **{name: off})) > AGREE
    assert _worst(em, _changed(model, states, theta0=model.field[8] + 1e-5)) > AGREE


def test_the_fields_power_is_its_turning(case_model):
    """The peers' W takes the field's power ``w e3 . (d x g)``: -dU/dt at a fixed point, against
    a central difference in time over +-1 s (whose own error is about (w h)^2 / 6, 1e-9)."""
    case, model, states, _ = case_model
    if not case.field_order:
        pytest.skip("no rotating field in this case")

    def u(t, x):
        return model.field_potential(list(x), model.turn(t, math.cos, math.sin), math.sqrt)

    power = [model.field_power(list(x), model.turn(t, math.cos, math.sin), math.sqrt) for t, x, _ in states]
    difference = [-(u(t + 1.0, x) - u(t - 1.0, x)) / 2.0 for t, x, _ in states]
    scale = max(abs(p) for p in power)
    assert scale > 0.0 and max(abs(p - q) for p, q in zip(power, difference)) <= 1e-8 * scale


# -- the section in its tiny configuration --------------------------------------------------------
def _finite(x) -> bool:
    return isinstance(x, float) and math.isfinite(x)


@pytest.fixture(scope="module")
def data():
    return perturbed.run(CONFIGS["tiny"])


def test_the_section_is_registered():
    assert "perturbed" in SECTIONS and _sections()["perturbed"] is perturbed


def test_points_and_columns(data):
    wp = data["cases"]["leo"]
    size = perturbed.SIZES["tiny"]["leo"]
    ref = wp["reference"]
    assert ref["method"] and ref["check"] and ref["check_difference"] < 1e-6, ref
    counts = {}
    for p in wp["points"]:
        counts[p["method"]] = counts.get(p["method"], 0) + 1
        if p["engine"] in wp["skipped"]:
            assert p["status"].startswith("skipped"), p
            continue
        assert p["status"] == "ok", p
        for key in ("cpu_s", "position_error", "energy_balance"):
            assert _finite(p[key]) and p[key] >= 0, (key, p)
        assert p["steps"] > 0
        if p["engine"] == "emorbit":
            assert p["energy_balance"] <= perturbed.LIMIT_BALANCE, p
        if p["engine"] == "heyoka":
            assert _finite(p["compile_s"]) and p["compile_s"] > 0 and p["order"] > 0
    em = sum(len(d) for _, d in size.fixed) + sum(len(e) for _, e in size.etas)
    assert counts == {"em": em, "taylor": len(size.tolerances), "ias15": len(size.epsilons), "dop853": len(size.rtols)}
    assert wp["em_compile_s"] > 0


def test_reach_and_targets(data):
    wp = data["cases"]["leo"]
    assert [r["accuracy"] for r in wp["reach"]] == list(perturbed.ACCURACIES)
    for row in wp["reach"]:
        assert set(row["engines"]) == set(perturbed.EMORBIT) | {"heyoka", "ias15", "dop853"}
        for peer in ("heyoka", "ias15", "dop853"):
            r = row[f"em_over_{peer}"]
            assert r is None or (_finite(r) and r > 0), row
    ts = data["targets"]
    assert len(ts) == 4  # IAS15, heyoka at 1e-6 and 1e-9, the balance
    balance = ts[-1]
    assert balance["met"] is True and balance["measured"] <= perturbed.LIMIT_BALANCE
    for t in ts:
        assert t["met"] in (True, False, None) and t["limit"] > 0
        assert t["met"] is None or _finite(t["measured"])
    assert targets({"perturbed": data}) == ts


def test_tfe_runs_every_case():
    """The time finite element's series, tfe order 6 over 2 hours at fixed steps of 60 s and
    adaptive steps (eta 0.005), against em order 8 at 60 s: on the Molniya within 1e-9 of a
    (measured 1.1e-10 and 1.3e-12) and on the LEO, under drag, within 2e-9 (measured 7.0e-10
    and 4.0e-10), each with its balance within 1e-13 (measured at most 6.2e-16)."""
    for name in ("molniya", "leo"):
        case = perturbed.CASES[name]
        em = perturbed._em(case, 8, 60.0, 7200.0)
        _, _, a = perturbed.initial_state(case)
        for dt, eta in ((60.0, None), (None, 0.005)):
            res = perturbed._em(case, 6, dt, 7200.0, adaptive=eta, method="tfe")
            assert res.get("status") is None, res
            assert np.linalg.norm(res["x_end"] - em["x_end"]) / a <= (1e-9 if name == "molniya" else 2e-9)
            assert res["energy_balance"] <= 1e-13


def test_table_and_json(data):
    import json

    lines = perturbed.table(data)
    assert lines[0] == "perturbed orbits (tiny)"
    assert any("least CPU time" in line for line in lines) and any("targets:" in line for line in lines)
    json.dumps(data, default=_jsonable)


def test_missing_peers_are_skipped(monkeypatch):
    """Without heyoka, REBOUND and scipy (their imports fail) their rows say skipped and the
    reference is em's."""
    for name in ("heyoka", "rebound", "scipy"):
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(
        perturbed.SIZES, "tiny", {"leo": perturbed.Size(1800.0, ((8, (120.0,)),), (), (1e-9,), (1e-9,), (1e-8,), 5.0)}
    )
    wp = perturbed.run(CONFIGS["tiny"])["cases"]["leo"]
    assert set(wp["skipped"]) == {"heyoka", "rebound", "scipy"}
    for engine in ("heyoka", "rebound", "scipy"):
        assert "not installed" in wp["skipped"][engine]
        rows = [p for p in wp["points"] if p["engine"] == engine]
        assert len(rows) == 1 and rows[0]["status"].startswith(f"skipped: {engine} is not installed")
    assert wp["reference"]["method"].startswith("em order 8") and "without heyoka" in wp["reference"]["method"]
    assert [p["status"] for p in wp["points"] if p["engine"] == "emorbit"] == ["ok"]
