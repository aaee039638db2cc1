"""Two-body relations: elements, Kepler's equation, analytic propagation."""

import numpy as np
import pytest
from conftest import PAPER_GM, PAPER_T, PAPER_V0, PAPER_X0

from emorbit import orbits


def test_paper_orbit_numbers(paper_kepler_period):
    """The rounded v0 = 0.36276 m/s gives a = 6.0000135 m, e = 2/3 and T = 46.47620 s,
    about 1e-5 above the paper's 46.4758 s."""
    el = orbits.elements(PAPER_X0, PAPER_V0, PAPER_GM)
    assert el.a == pytest.approx(6.0000135, abs=1e-7)
    assert el.e == pytest.approx(2 / 3, abs=1e-5)
    assert paper_kepler_period == pytest.approx(46.47620, abs=1e-5)
    assert paper_kepler_period / PAPER_T - 1 == pytest.approx(0.9e-5, abs=0.1e-5)
    assert el.nu == pytest.approx(np.pi)  # starts at aphelion


def test_elements_round_trip():
    """2000 random orbits (a from 1e3 to 1e8 m, e from 0.001 to 0.99) to elements and back:
    a to 3e-13 relative, e to 1e-14, i to 5e-14 rad, the node to 5e-15 rad, argp and nu to
    2e-12 rad (each alone ill-conditioned at e = 0.001; measured 4.5e-14, 1.6e-15, 9.3e-15,
    8.9e-16, 3.4e-13 and 3.4e-13), and the state again to 2e-13 of |x| (measured 3.0e-14):
    round-off with a margin of 5-10."""
    rng = np.random.default_rng(3)
    n = 2000
    el = orbits.OrbitalElements(
        a=rng.uniform(1e3, 1e8, n),
        e=rng.uniform(0.001, 0.99, n),
        i=rng.uniform(0.01, np.pi - 0.01, n),
        raan=rng.uniform(0, 2 * np.pi, n),
        argp=rng.uniform(0, 2 * np.pi, n),
        nu=rng.uniform(0, 2 * np.pi, n),
        M=np.zeros(n),
    )
    gm = 3.986e14
    x, v = orbits.state_from_elements(el, gm, center=[1e3, 2e3, -3e3])
    back = orbits.elements(x, v, gm, center=[1e3, 2e3, -3e3])
    da = np.abs(back.a / el.a - 1).max()
    assert da <= 3e-13, f"a off by {da:.3g} relative, measured 4.5e-14"
    de = np.abs(back.e - el.e).max()
    assert de <= 1e-14, f"e off by {de:.3g}, measured 1.6e-15"
    di = np.abs(back.i - el.i).max()
    assert di <= 5e-14, f"i off by {di:.3g} rad, measured 9.3e-15"
    for name, bound, measured in (("raan", 5e-15, 8.9e-16), ("argp", 2e-12, 3.4e-13), ("nu", 2e-12, 3.4e-13)):
        d = np.abs(np.angle(np.exp(1j * (getattr(back, name) - getattr(el, name))))).max()
        assert d <= bound, f"{name} off by {d:.3g} rad, measured {measured:.2g}"
    x2, v2 = orbits.state_from_elements(back, gm, center=[1e3, 2e3, -3e3])
    dx = (np.linalg.norm(x2 - x, axis=1) / np.linalg.norm(x, axis=1)).max()
    assert dx <= 2e-13, f"positions off by {dx:.3g} of |x|, measured 3.0e-14"


def test_degenerate_orbits_are_finite():
    """Circular, equatorial and retrograde orbits: the undefined angles become 0 and the
    anomaly is measured from the node or the x axis."""
    gm = 1.0
    circ_eq = orbits.elements([1.0, 0, 0], [0, 1.0, 0], gm)
    assert circ_eq.e < 1e-15 and circ_eq.i == 0 and circ_eq.raan == 0 and circ_eq.argp == 0 and circ_eq.nu == 0
    retro = orbits.elements([0, 2.0, 0], [0.5, 0, 0], gm)
    assert retro.i == pytest.approx(np.pi)
    assert all(np.isfinite(retro))


@pytest.mark.parametrize("e", [0.0, 0.1, 0.5, 0.9, 0.99, 0.999999])
def test_solve_kepler(e):
    M = np.linspace(-20, 20, 4001)
    E = orbits.solve_kepler(M, e)
    res = np.abs(E - e * np.sin(E) - M).max()
    # measured 3.6e-15 (one ulp of |M| = 20) at every e > 0, 0 at e = 0: round-off of M
    assert res <= 4 * np.spacing(20.0), f"residual {res:.3g}, measured 3.6e-15 (1 ulp of 20)"


def test_solve_kepler_hyperbolic():
    M = np.linspace(-50, 50, 1001)
    for e in (1.01, 1.5, 5.0):
        F = orbits.solve_kepler_hyperbolic(M, e)
        res = np.abs(e * np.sinh(F) - F - M).max()
        # measured 2.8e-14 (four ulps of |M| = 50) at e = 1.01 and 1.5, 1.4e-14 at e = 5
        assert res <= 1.5e-13, f"e = {e}: residual {res:.3g}, measured <= 2.8e-14"


def test_propagate_matches_kepler_equation():
    """Universal variables against the elements route, and exact invariants: positions agree
    to 2e-13 m (measured 3.2e-14 on the 10 m orbit), the energy's spread over three orbits is
    1.1e-14 of |E| and h moves by 4.0e-15 (of |h| = 3.6): round-off, bounds 2-5x that."""
    t = np.linspace(0, 3 * PAPER_T, 301)
    x, v = orbits.propagate(PAPER_X0, PAPER_V0, PAPER_GM, t)
    el0 = orbits.elements(PAPER_X0, PAPER_V0, PAPER_GM)
    n = np.sqrt(PAPER_GM / el0.a**3)
    E = orbits.solve_kepler(el0.M + n * t, el0.e)
    nu = 2 * np.arctan2(np.sqrt(1 + el0.e) * np.sin(E / 2), np.sqrt(1 - el0.e) * np.cos(E / 2))
    xe, _ = orbits.state_from_elements((el0.a, el0.e, el0.i, el0.raan, el0.argp, nu), PAPER_GM)
    dx = np.abs(x - xe).max()
    assert dx <= 2e-13, f"positions differ by {dx:.3g} m, measured 3.2e-14"
    energy = 0.5 * np.sum(v * v, axis=1) - PAPER_GM / np.linalg.norm(x, axis=1)
    dE = np.ptp(energy) / abs(energy[0])
    assert dE < 2e-14, f"energy spread {dE:.3g} of |E|, measured 1.1e-14"
    h = np.cross(x, v)
    dh = np.abs(h - h[0]).max()
    assert dh < 1e-14, f"h moves by {dh:.3g}, measured 4.0e-15"


def test_propagate_long_and_hyperbolic():
    """1000 periods in one call return to the start within 6e-11 m (measured 1.1e-11: the
    period's round-off times 1000); a hyperbolic propagation over 3 s then 4 s equals one over
    7 s to 2e-15 (positions) and 4e-15 (velocities) relative (measured 3.0e-16 and 6.0e-16)."""
    x, v = orbits.propagate(PAPER_X0, PAPER_V0, PAPER_GM, 1000 * orbits.kepler_period(6.0000135350627, PAPER_GM))
    back = np.linalg.norm(x - PAPER_X0)
    assert back < 6e-11, f"{back:.3g} m from the start after 1000 periods, measured 1.1e-11"
    # hyperbolic: composing two propagations equals one
    xh, vh = np.array([1.0, 0, 0]), np.array([0, 1.6, 0.2])
    x1, v1 = orbits.propagate(xh, vh, 1.0, 3.0)
    x2, v2 = orbits.propagate(x1, v1, 1.0, 4.0)
    x3, v3 = orbits.propagate(xh, vh, 1.0, 7.0)
    dx, dv = (np.abs(x2 - x3) / np.abs(x3)).max(), (np.abs(v2 - v3) / np.abs(v3)).max()
    assert dx <= 2e-15, f"positions differ by {dx:.3g} relative, measured 3.0e-16"
    assert dv <= 4e-15, f"velocities differ by {dv:.3g} relative, measured 6.0e-16"
