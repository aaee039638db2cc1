"""The validation cases ``libration-pitch`` and ``libration-roll-yaw``: a rigid box of mass points
librating under the gravity gradient on a circular Earth orbit, emorbit against the linear and
the pendulum theory and against Basilisk. Their quick forms pass every check; a referee given an
inertia 1e-3 off fails the checks that referee the libration and leaves the invariants alone;
without Basilisk its checks are skipped and the cases pass; the theory's formulas agree with an
independent linearisation and integration of the attitude equations."""

import dataclasses
import math
import sys

import numpy as np
import pytest
from validation_support import PNG, failed_ids, passed_cases, quick_report

from emorbit.cli import main
from emorbit.validation import libration as L
from emorbit.validation import libration_referees as LR
from emorbit.validation import libration_runner

GM = 398600441800000.0  # any GM: the theory scales with n


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    return quick_report(tmp_path_factory, L.NAMES)


def test_the_quick_cases_pass_every_check(quick):
    cases = passed_cases(quick, L.NAMES, L.NOTE)
    pitch = {ch["id"]: ch for ch in cases["libration-pitch"]["checks"]}
    assert {"same-inertia", "pitch-linear", "size-period-slope", "energy", "angular-momentum"} <= set(pitch)
    assert {"attitude-invariant", "basilisk-torque", "size-torque-slope"} <= set(pitch)
    assert {"pitch-period-0.573deg", "pitch-period-10deg", "pitch-period-30deg", "pitch-period-60deg"} <= set(pitch)
    assert {"basilisk-series-30deg", "basilisk-period-30deg"} <= set(pitch)
    roll_yaw = {ch["id"] for ch in cases["libration-roll-yaw"]["checks"]}
    assert {"roll-yaw-fast", "roll-yaw-slow", "basilisk-roll-yaw-fast", "basilisk-roll-yaw-slow"} <= roll_yaw
    # the measured pitch frequency is the linear one less the pendulum's correction (theta0 = 0.01 rad)
    assert pitch["pitch-linear"]["value"] == pytest.approx(0.01**2 / 4, rel=0.01)
    if LR.basilisk_missing():  # CI: Basilisk's checks are skipped, the case still passes
        assert pitch["basilisk-torque"]["skipped"].startswith("skipped: Basilisk not installed")
        return
    # the grown boxes approach the first-order torque like (size / r)^2
    torque = [row["relative difference"] for row in cases["libration-pitch"]["metrics"]["sizes.torque"]["value"]]
    np.testing.assert_allclose(np.log2(np.array(torque[1:]) / np.array(torque[:-1])), 2.0, atol=1e-3)


def test_the_cases_are_listed(capsys):
    assert main(["validate", "--list"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed.index("libration-roll-yaw") == listed.index("libration-pitch") + 1


def _reduced(name, **settings):
    case = L.cases("quick")[name]
    return dataclasses.replace(case, settings={**case.settings, **settings})


def test_a_wrong_inertia_in_the_referee_fails(tmp_path, monkeypatch):
    """The referee's (and Basilisk's) I_roll 1e-3 too large: the inertia check, the pitch
    frequency and periods (5e-4 off against tolerances of 4e-8) and the roll-yaw frequencies
    fail against em, and so do Basilisk's series and periods (Basilisk now runs another body);
    em's own invariants do not."""
    right = LR.referee_inertia

    def wrong(size, density):
        return right(size, density) @ np.diag([1.0, 1.0 + 1e-3, 1.0])

    monkeypatch.setattr(libration_runner, "referee_inertia", wrong)
    reduced = _reduced("libration-pitch", amplitudes=(0.01, math.radians(30.0)), orbits=2)
    pitch = L.run(reduced, "quick", str(tmp_path), figures=False)
    failed = failed_ids(pitch)
    assert {"same-inertia", "pitch-linear", "pitch-period-0.573deg", "pitch-period-30deg"} <= failed
    if not LR.basilisk_missing():
        assert {"basilisk-series-30deg", "basilisk-period-30deg", "basilisk-torque"} <= failed
    assert not failed & {"energy", "angular-momentum", "attitude-invariant"}
    roll_yaw = failed_ids(L.run(_reduced("libration-roll-yaw", orbits=6), "quick", str(tmp_path), figures=False))
    assert {"same-inertia", "roll-yaw-fast", "roll-yaw-slow"} <= roll_yaw
    assert not roll_yaw & {"energy", "angular-momentum", "attitude-invariant"}


def test_without_basilisk_its_checks_are_skipped(tmp_path, monkeypatch):
    """Basilisk made unimportable: its checks are skipped ("skipped: Basilisk not installed"), the
    others run, both cases pass and draw their figures."""
    for name in [m for m in sys.modules if m == "Basilisk" or m.startswith("Basilisk.")] + ["Basilisk"]:
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(ImportError):
        LR.basilisk_modules()
    for name, extra in (("libration-pitch", {"amplitudes": (0.01, math.radians(30.0))}), ("libration-roll-yaw", {})):
        out = L.run(_reduced(name, **extra), "quick", str(tmp_path))
        skipped = {ch["id"] for ch in out["checks"] if ch["skipped"]}
        basilisk = {ch["id"] for ch in out["checks"] if "basilisk" in ch["id"] or ch["id"] == "size-torque-slope"}
        assert skipped == basilisk and skipped
        assert all(ch["skipped"].startswith("skipped: Basilisk not installed") for ch in out["checks"] if ch["skipped"])
        assert out["passed"] and not failed_ids(out), failed_ids(out)
        assert out["figures"] == [f"{name}.png"] and (tmp_path / f"{name}.png").read_bytes()[:8] == PNG
        if name == "libration-pitch":
            assert {"pitch-linear", "pitch-period-30deg", "size-period-slope"} <= {ch["id"] for ch in out["checks"]}


# -- the theory, independently ------------------------------------------------------------------------
def _attitude_rhs(inertia, n):
    """Euler's equations with the first-order gravity-gradient torque 3 n^2 c x I c, the attitude
    relative to the orbit frame (e_r, e_t, e_n) rotating at n about e_n: state (alpha, w), C =
    exp([alpha]x) body to orbit frame, alpha' = w - C^T n e_n (exact to first order about
    alpha = 0, where w - C^T n e_n vanishes)."""
    from scipy.spatial.transform import Rotation

    I = np.asarray(inertia, float)
    Iinv = np.linalg.inv(I)

    def f(y):
        Ct = Rotation.from_rotvec(y[:3]).as_matrix().T
        w = y[3:]
        c = Ct @ np.array([1.0, 0.0, 0.0])
        torque = 3 * n * n * np.cross(c, I @ c)
        return np.concatenate([w - Ct @ np.array([0.0, 0.0, n]), Iinv @ (torque - np.cross(w, I @ w))])

    return f


@pytest.mark.parametrize("moments", [(52.083, 177.083, 208.333), (1.0, 3.0, 3.5), (2.0, 2.5, 4.0)])
def test_the_frequencies_are_those_of_the_linearised_attitude_equations(moments):
    """The eigenvalues of the attitude equations linearised (central differences) about the
    orbit frame are +-i w_pitch and +-i of both roll-yaw frequencies (body x radial = yaw, y
    along track = roll, z normal = pitch), for the case's box and two other Lagrange bodies."""
    n = LR.orbit_rate(GM, L.R_ORBIT)
    I = np.diag(moments)
    f = _attitude_rhs(I, n)
    y0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, n])
    steps = 1e-7 * np.r_[1.0, 1.0, 1.0, n, n, n]  # rad and rad/s
    J = np.column_stack([(f(y0 + h * e) - f(y0 - h * e)) / (2 * h) for h, e in zip(steps, np.eye(6))])
    eig = np.sort(np.abs(np.linalg.eigvals(J).imag))[::2]
    ry = LR.roll_yaw_frequencies(n, I)
    expected = np.sort([ry["slow"], LR.pitch_frequency(n, I), ry["fast"]])
    np.testing.assert_allclose(eig, expected, rtol=1e-6)


@pytest.mark.parametrize("degrees", [1.0, 30.0, 60.0, 80.0])
def test_the_pendulum_period_is_that_of_the_pitch_equation(degrees):
    """4 K(sin theta0) / w_pitch (ellipk takes k^2) against DOP853 on I_pitch theta'' = -(3/2) n^2
    (I_roll - I_yaw) sin 2 theta: the time of the first return to theta0, to 1e-10."""
    from scipy.integrate import solve_ivp

    n = LR.orbit_rate(GM, L.R_ORBIT)
    I = LR.referee_inertia(L.BOX, L.DENSITY)
    roll, pitch, yaw = LR.principal_moments(I)
    theta0 = math.radians(degrees)
    k = 1.5 * n * n * (roll - yaw) / pitch

    def turn(t, y):  # theta' = 0 on the far side
        return y[1]

    turn.direction = 1.0
    sol = solve_ivp(lambda t, y: [y[1], -k * math.sin(2 * y[0])], (0, 1e5), [theta0, 0.0], method="DOP853",
                    rtol=1e-13, atol=1e-16, events=turn)  # fmt: skip
    half = sol.t_events[0][0]
    assert 2 * half == pytest.approx(LR.pendulum_period(n, I, theta0), rel=1e-10)
    assert LR.pendulum_period(n, I, 1e-6) == pytest.approx(2 * math.pi / LR.pitch_frequency(n, I), rel=1e-12)


def test_the_measurements_recover_known_signals():
    """Zero crossings give a sinusoid's period to 1e-11, the two-mode fit two frequencies to 1e-9,
    and lvlh_angles a known rotation about the orbit normal."""
    t = np.linspace(0.0, 20000.0, 4001)
    period = 3456.789
    p = LR.libration_period(t, 0.3 * np.sin(2 * np.pi * t / period + 0.4))
    assert p.value == pytest.approx(period, rel=1e-11) and p.events >= 10
    w = np.array([1.9e-3, 0.8e-3])
    roll = np.cos(w[0] * t + 0.3) + 0.2 * np.sin(w[1] * t)
    yaw = 0.3 * np.cos(w[0] * t) + np.cos(w[1] * t + 1.0)
    freqs, sigma, rms = LR.fit_modes(t, [roll, yaw])
    np.testing.assert_allclose(freqs, w, rtol=1e-9)
    assert rms < 1e-10
    from emorbit.bodies.rotations import rotation_vector_to_matrix

    x = np.array([[7e6, 0.0, 0.0], [0.0, 7e6, 0.0]])
    v = np.array([[0.0, 7.5e3, 0.0], [-7.5e3, 0.0, 0.0]])
    R = np.array([rotation_vector_to_matrix([0.1, 0.0, 0.2]), rotation_vector_to_matrix([0.0, 0.0, np.pi / 2 - 0.3])])
    ang = LR.lvlh_angles(x, v, R)
    np.testing.assert_allclose(ang[0], [0.1, 0.0, 0.2], atol=1e-15)
    np.testing.assert_allclose(ang[1], [0.0, 0.0, -0.3], atol=1e-15)


def test_the_attitude_invariant_is_energy_minus_n_angular_momentum():
    """K, evaluated at 20 random states of a box grown to size / r = 0.02 (where E - n L_z, 1e10 J,
    resolves its 1e6 J), differs from state to state as E - n L_z does, to 1e-9 of K's terms: the
    Legendre series' remainder (its l = 6 term for the symmetric box) leaves 1.5e-10 (measured;
    1.1e-11 at size / r = 0.01, 14 times less, as (size / r)^4)."""
    from scipy.spatial.transform import Rotation

    import emorbit
    from emorbit.bodies.shapes import box

    s = L.cases("quick")["libration-pitch"].settings
    gm, r0 = s["gm"], s["radius"]
    n = LR.orbit_rate(gm, r0)
    ell = 0.02 * r0
    pts = box([ell, ell / 2, ell / 4], mass=500.0)
    rng = np.random.default_rng(25)
    m = 20
    x = np.array([r0, 0.0, 0.0]) + rng.uniform(-1e3, 1e3, (m, 3))
    v = np.array([0.0, math.sqrt(gm / r0), 0.0]) + rng.uniform(-1.0, 1.0, (m, 3))
    R = Rotation.random(m, random_state=rng).as_matrix()
    w = rng.uniform(-2 * n, 2 * n, (m, 3))
    K, scale = LR.attitude_invariant(pts, gm, r0, x, v, R, w)
    field = emorbit.CentralField(body="earth")
    Iw = w @ pts.inertia
    E = 0.5 * pts.mass * np.einsum("ni,ni->n", v, v) + 0.5 * np.einsum("ni,ni->n", w, Iw)
    E += np.array([field.potential(xi[:, None] + Ri @ pts.X) @ pts.m for xi, Ri in zip(x, R)])
    jacobi = E - n * (pts.mass * np.cross(x, v)[:, 2] + np.einsum("nij,nj->ni", R, Iw)[:, 2])
    assert np.ptp(K) > 0.1 * scale  # the states differ in K by much more than the tolerance
    np.testing.assert_allclose(K - K[0], jacobi - jacobi[0], atol=1e-9 * scale)


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="mode"):
        L.cases("slow")
    with pytest.raises(ValueError, match="theta0"):
        LR.pendulum_period(1e-3, np.diag([1.0, 2.0, 3.0]), math.pi / 2)
    with pytest.raises(ValueError, match="inertia"):
        LR.roll_yaw_frequencies(1e-3, np.diag([3.0, 1.0, 2.0]))  # I_yaw largest: not a libration
    with pytest.raises(ValueError, match="I_roll"):
        LR.pitch_frequency(1e-3, np.diag([2.0, 1.0, 3.0]))
    case = L.cases("quick")["libration-pitch"]
    with pytest.raises(ValueError, match=r"settings\['amplitudes'\].*1.7"):
        L._validate(case.name, {**case.settings, "amplitudes": (0.1, 1.7)})
    with pytest.raises(ValueError, match="case must be one of"):
        L.run(dataclasses.replace(case, name="libration-other"), "quick", "/tmp")
