"""The kernels of :mod:`emorbit.kernels.effects.radiation`: the shadow functions, solar
radiation pressure on a cannonball and on flat plates, and flat-plate drag.

The conical shadow is checked against two independent computations of the visible fraction
of the Sun's disc, each a quadrature over the disc in polar coordinates about its centre
(rings of radius r, the hidden arc of each ring in closed form; Gauss-Legendre in a variable
that smooths the square-root kinks where a ring touches the occulting disc's edge):

- the plane-disc model that the kernel implements (discs of radii a and b at distance c),
  which the kernel must match to round-off;
- the exact fraction of the solid angle (spherical caps on the sky), which the plane-disc
  model approximates; their difference in Earth's penumbra is measured here.

Plates are checked by what closed bodies of them must give: a closed convex body of one-sided
black plates gets ``-P A_proj e`` from sunlight and ``-1/2 rho Cd A_proj |v| v`` from the air.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from emorbit.kernels.effects.radiation import (
    drag_plate,
    shadow_conical,
    shadow_conical_gradient,
    shadow_cylindrical,
    srp_cannonball,
    srp_plate,
)

R_EARTH = 6378137.0
R_SUN = 695700e3
AU = 149597870700.0
#: the solar radiation pressure at 1 au (1361 W/m^2 / c), N/m^2
P_AU = 1361.0 / 299792458.0
R_GEO = 42164e3

_GL_T, _GL_W = np.polynomial.legendre.leggauss(96)


def _unit(rng, n=None):
    u = rng.normal(size=(3,) if n is None else (n, 3))
    return u / np.linalg.norm(u, axis=-1, keepdims=True)


def _rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _geometry(a, b, c, rng, radius=R_EARTH, sun_radius=R_SUN):
    """(d, s): a satellite that sees the Sun (angular radius a) and the occulting body (angular
    radius b) with centres c apart, in a random orientation."""
    u1 = _unit(rng)
    w = _unit(rng)
    w = w - (w @ u1) * u1
    w /= np.linalg.norm(w)
    u2 = math.cos(c) * u1 + math.sin(c) * w
    d = -(radius / math.sin(b)) * u1
    s = d + (sun_radius / math.sin(a)) * u2
    return d, s


def _ring_quadrature(breaks, hidden_arc, weight, upper):
    """The integral over [0, upper] of ``hidden_arc(r) weight(r)``, split at ``breaks``, each piece
    mapped by ``r = r0 + (r1 - r0) (1 - cos t) / 2`` (t in [0, pi]) so that square-root kinks
    at its ends become smooth, then Gauss-Legendre in t."""
    pts = sorted({0.0, upper, *(x for x in breaks if 0.0 < x < upper)})
    total = 0.0
    t = 0.5 * math.pi * (_GL_T + 1.0)
    wt = 0.5 * math.pi * _GL_W
    for r0, r1 in zip(pts[:-1], pts[1:]):
        r = r0 + (r1 - r0) * 0.5 * (1.0 - np.cos(t))
        dr = (r1 - r0) * 0.5 * np.sin(t)
        total += float(np.sum(wt * dr * hidden_arc(r) * weight(r)))
    return total


def planar_visible(a, b, c):
    """The visible fraction of a disc of radius a behind a disc of radius b, centres c apart,
    by quadrature over rings about the Sun's centre (plane geometry)."""

    def arc(r):
        return 2.0 * np.arccos(np.clip((r * r + c * c - b * b) / (2.0 * r * c), -1.0, 1.0))

    hidden = _ring_quadrature((abs(c - b), c + b), arc, lambda r: r, a)
    return 1.0 - hidden / (math.pi * a * a)


def spherical_visible(a, b, c):
    """The exact visible fraction of the solid angle of a cap of angular radius a behind a cap
    of angular radius b, centres c apart on the sky."""

    def arc(rho):
        # cos b - cos c cos rho, written without cancellation for small angles
        num = -np.sin((b + c - rho) / 2) * np.sin((b - c + rho) / 2) - np.sin((b + c + rho) / 2) * np.sin(
            (b - c - rho) / 2
        )
        cosphi = num / (math.sin(c) * np.sin(rho))
        return 2.0 * np.arccos(np.clip(cosphi, -1.0, 1.0))

    hidden = _ring_quadrature((abs(c - b), c + b), arc, np.sin, a)
    return 1.0 - hidden / (4.0 * math.pi * math.sin(a / 2) ** 2)


def conical(d, s, radius=R_EARTH, sun_radius=R_SUN):
    return shadow_conical(*d, *s, radius, sun_radius)


# --- the quadratures themselves ----------------------------------------------------------------


def test_reference_quadratures_agree_with_closed_forms():
    """Annular and point-like cases have closed forms: 1 - b^2/a^2 in the plane, and the ratio
    of cap areas (1 - cos b) / (1 - cos a) on the sphere."""
    for a, b, c in [(0.3, 0.1, 0.05), (0.01, 0.004, 0.002), (1.0, 0.5, 0.2)]:
        assert planar_visible(a, b, c) == pytest.approx(1 - b * b / (a * a), abs=1e-14)
        ratio = (math.sin(b / 2) / math.sin(a / 2)) ** 2
        assert spherical_visible(a, b, c) == pytest.approx(1 - ratio, abs=1e-14)
    # a tangent pair: nothing hidden; full cover: nothing visible
    assert planar_visible(0.1, 0.2, 0.3) == pytest.approx(1.0, abs=1e-15)
    assert planar_visible(0.1, 0.3, 0.1) == pytest.approx(0.0, abs=1e-14)
    # equal discs through each other's centres: the lens (2 pi / 3 - sqrt(3) / 2) a^2
    assert planar_visible(0.2, 0.2, 0.2) == pytest.approx(1 / 3 + math.sqrt(3) / (2 * math.pi), abs=1e-14)


def test_spherical_quadrature_against_a_sky_grid():
    """A penumbra seen from 400 km: the ring quadrature against a 2000 x 2000 grid of equal solid
    angles over the Sun's cap (measured |diff| 1.4e-6), and both away from the plane-disc value
    (measured 2.2e-4)."""
    b = math.asin(R_EARTH / (R_EARTH + 400e3))
    a = math.asin(R_SUN / AU)
    c = b + 0.1 * a
    n = 2000
    cos_rho = 1.0 - (np.arange(n) + 0.5) / n * (1.0 - math.cos(a))  # rings of equal solid angle
    phi = (np.arange(n) + 0.5) / n * math.pi  # one half of the cap; the other is its mirror
    cos_to_body = math.cos(c) * cos_rho[:, None] + math.sin(c) * np.sqrt(1.0 - cos_rho[:, None] ** 2) * np.cos(phi)
    grid = float(np.mean(cos_to_body < math.cos(b)))
    exact = spherical_visible(a, b, c)
    assert abs(grid - exact) < 5e-6, (grid, exact)
    assert abs(exact - planar_visible(a, b, c)) > 2e-4, (exact, planar_visible(a, b, c))


# --- conical shadow ----------------------------------------------------------------------------


def _random_abc(rng, regime):
    a = 10 ** rng.uniform(-3, -0.5)
    b = 10 ** rng.uniform(-3, 0.15)
    if regime == "penumbra":
        c = rng.uniform(abs(a - b), a + b)
    elif regime == "annular":
        a, b = max(a, b), min(a, b)
        c = rng.uniform(0.0, a - b)
    elif regime == "umbra":
        a, b = min(a, b), max(a, b)
        c = rng.uniform(0.0, b - a)
    else:
        c = rng.uniform(a + b, min(3.0, a + b + 1.0))
    return a, b, c


def _acos_form(a, b, c):
    """The penumbra's nu as Montenbruck & Gill write it, with acos, in Python floats."""
    x = (c * c + a * a - b * b) / (2.0 * c)
    y = math.sqrt(max(a * a - x * x, 0.0))
    area = a * a * math.acos(min(max(x / a, -1.0), 1.0)) + b * b * math.acos(min(max((c - x) / b, -1.0), 1.0)) - c * y
    return 1.0 - area / (math.pi * a * a)


def _lipschitz(a, b):
    """The bound on |d nu / d c|: moving the occulting disc by dc sweeps at most its chord inside
    the Sun's disc, 2 min(a, b), times dc."""
    return 2.0 * min(a, b) / (math.pi * a * a)


@pytest.mark.parametrize("regime", ["penumbra", "annular", "umbra", "full"])
def test_conical_is_the_plane_disc_overlap(regime):
    """On random geometries (400 per regime: a from 1e-3 to 0.32, b from 1e-3 to 1.4 rad) the
    kernel matches the plane-disc quadrature; measured max |diff| 3.3e-13 (penumbra, where the
    rounding of c, ~1e-16 c, moves nu by up to 2 min(a, b) / (pi a^2) times it), 3.8e-15 in the
    annular and umbra regimes, 0 in full sunlight."""
    rng = np.random.default_rng(["penumbra", "annular", "umbra", "full"].index(regime))
    worst = worst_acos = 0.0
    for _ in range(400):
        a, b, c = _random_abc(rng, regime)
        d, s = _geometry(a, b, c, rng)
        nu = conical(d, s)
        assert 0.0 <= nu <= 1.0
        reference = planar_visible(a, b, c)
        worst = max(worst, abs(nu - reference))
        if regime == "penumbra":
            worst_acos = max(worst_acos, abs(_acos_form(a, b, c) - reference))
    assert worst < 1e-12, f"{regime}: max |nu - plane overlap| = {worst:.2e} (measured 3.3e-13 at most)"
    # the acos form, evaluated from the exact a, b, c, loses more where b >> a (measured 2.0e-8)
    assert regime != "penumbra" or worst_acos > 1e3 * worst, (worst, worst_acos)


def test_conical_departs_little_from_the_exact_solid_angle_in_earths_penumbra():
    """Satellites 300 km up to GEO in Earth's penumbra, the Sun at 1 au +- r: the plane-disc model
    against the exact fraction of the solid angle. They differ by the curvature of Earth's limb on
    the sky (1/b in the plane, cot b on the sphere); measured max |diff| = 0.1073 a (1/b - cot b),
    on 201 separations across the penumbra 2.35e-4 at 300 km and 2.50e-5 at GEO."""
    rng = np.random.default_rng(7)
    ratio = 0.0
    for _ in range(1600):
        r = rng.uniform(R_EARTH + 300e3, R_GEO)
        b = math.asin(R_EARTH / r)
        a = math.asin(R_SUN / (AU + rng.uniform(-1, 1) * r))
        c = rng.uniform(b - a, b + a)
        d, s = _geometry(a, b, c, rng)
        diff = abs(conical(d, s) - spherical_visible(a, b, c))
        ratio = max(ratio, diff / (a * (1.0 / b - 1.0 / math.tan(b))))
    assert ratio < 0.108, f"max |diff| = {ratio:.4f} a (1/b - cot b) (measured 0.1073)"
    for r, measured in ((R_EARTH + 300e3, 2.35e-4), (R_GEO, 2.50e-5)):
        b = math.asin(R_EARTH / r)
        a = math.asin(R_SUN / AU)
        worst = 0.0
        for c in np.linspace(b - a, b + a, 201):
            d, s = _geometry(a, b, c, rng)
            worst = max(worst, abs(conical(d, s) - spherical_visible(a, b, c)))
        assert worst == pytest.approx(measured, rel=0.01), f"r = {r:.0f} m: max |diff| {worst:.3e}"


@pytest.mark.parametrize("a,b", [(0.01, 0.003), (0.004652, 0.9), (0.2, 0.2 * (1 + 1e-9)), (0.05, 0.049)])
def test_conical_is_continuous_across_its_boundaries(a, b):
    """At 1e-7 a to either side of c = a + b, b - a and a - b, nu is within the Lipschitz bound
    2 min(a, b) / (pi a^2) times the step of its value on the edge (1, 0, 1 - b^2 / a^2); measured
    0.994 times the bound where a = b (the crescent as thick as the step all along), 2e-4 to 2e-3
    times it elsewhere (there nu departs from the edge value like the step^1.5)."""
    rng = np.random.default_rng(3)
    step = 1e-7 * a
    bound = _lipschitz(a, b) * step
    worst = 0.0
    edges = [(a + b, 1.0), (b - a, 0.0) if b > a else (a - b, 1.0 - b * b / (a * a))]
    for c, limit in edges:
        for side in (-1.0, 1.0):
            cc = c + side * step
            if not 0.0 < cc < math.pi:
                continue
            d, s = _geometry(a, b, cc, rng)
            worst = max(worst, abs(conical(d, s) - limit) / bound)
    assert worst <= 1.0 + 1e-6, f"a={a}, b={b}: max |nu - edge value| = {worst:.3g} times the bound"


@pytest.mark.parametrize("a,b", [(0.01, 0.003), (0.003, 0.01), (0.004652, 1.1), (0.02, 0.02)])
def test_conical_grows_with_the_separation(a, b):
    """Over c = 0 .. 2 a + b (4001 steps) nu never decreases and grows by no more than the
    Lipschitz bound allows; measured worst decrease 1.1e-16 (a rounding of nu near 1), largest rise
    0.9999994 times the bound (attained where the chord is a diameter of the smaller disc)."""
    cs = np.linspace(1e-9 * a, 2 * a + b, 4001)
    nus = []
    for c in cs:
        d, s = _geometry(a, b, c, np.random.default_rng(5))  # one orientation for all c
        nus.append(conical(d, s))
    steps = np.diff(nus)
    drop = float(np.max(-steps))
    assert drop <= 2.3e-16, f"nu decreased by {drop:.2e} as c grew"
    rise = float(np.max(steps / (_lipschitz(a, b) * np.diff(cs))))
    assert rise <= 1.0 + 1e-9, f"nu rose by {rise:.4f} times the Lipschitz bound"
    assert nus[0] == pytest.approx(planar_visible(a, b, cs[0]), abs=1e-12)
    assert nus[-1] == 1.0


def test_conical_inside_the_body_and_the_annular_moon():
    assert shadow_conical(1e6, 2e6, 0.0, AU, 0.0, 0.0, R_EARTH, R_SUN) == 0.0
    # the Moon (1737.4 km) 384400 km away in front of the Sun as seen from the Earth near aphelion
    r_moon = 1737.4e3
    d = np.array([-384400e3, 0.0, 0.0])
    s = np.array([1.0167 * AU - 384400e3, 0.0, 0.0])
    a = math.asin(R_SUN / 1.0167 / AU)
    b = math.asin(r_moon / 384400e3)
    assert b < a
    assert conical(d, s, radius=r_moon) == pytest.approx(1 - b * b / (a * a), rel=1e-14)


# --- cylindrical shadow ------------------------------------------------------------------------


def test_cylindrical_in_front_behind_in_and_out():
    rng = np.random.default_rng(11)
    cases = [
        ((R_EARTH + 500e3, 0.0, 0.0), 1.0),  # day side
        ((2 * R_EARTH, 0.5 * R_EARTH, 0.0), 1.0),  # in front, within the cylinder's radius
        ((-(R_EARTH + 500e3), 0.0, 0.0), 0.0),  # on the axis behind
        ((-2 * R_EARTH, 0.99 * R_EARTH, 0.0), 0.0),  # behind, inside
        ((-2 * R_EARTH, 0.0, -0.999 * R_EARTH), 0.0),
        ((-2 * R_EARTH, 1.01 * R_EARTH, 0.0), 1.0),  # behind, outside
        ((-10 * R_EARTH, 0.0, 1.5 * R_EARTH), 1.0),
        ((0.0, 1.2 * R_EARTH, 0.0), 1.0),  # on the terminator plane
    ]
    for _ in range(5):
        rot = _rotation(rng)
        s = rot @ np.array([AU, 0.0, 0.0])
        for d, nu in cases:
            assert shadow_cylindrical(*(rot @ np.array(d)), *s, R_EARTH) == nu, d


def test_conical_and_cylindrical_agree_away_from_the_shadow_edge():
    """Random satellites 200 km up to GEO: both models agree wherever the distance to the
    cylinder's surface exceeds the cone's spread there (|p| (R_sun + R) / au, +10% and 1 km);
    measured: of 20000 points 289 lie within that band (262 of them in the penumbra, 0 < nu < 1),
    and 6714 of the others in the shadow."""
    rng = np.random.default_rng(13)
    s = np.array([AU, 0.0, 0.0])
    n = 20000
    r = rng.uniform(R_EARTH + 200e3, R_GEO, n)
    # half the points near the anti-Sun direction, so that many lie in and around the shadow
    u = _unit(rng, n)
    u[: n // 2, 0] = -np.abs(u[: n // 2, 0]) - 3.0
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    d = u * r[:, None]
    shaded = penumbra = 0
    for di in d:
        q = math.hypot(di[1], di[2])
        margin = 1.1 * abs(di[0]) * (R_SUN + R_EARTH) / AU + 1e3
        con = conical(di, s)
        if di[0] < 0 and abs(q - R_EARTH) <= margin:
            penumbra += 0.0 < con < 1.0
            continue
        cyl = shadow_cylindrical(*di, *s, R_EARTH)
        shaded += cyl == 0.0
        assert con == cyl, (di, con, cyl)
    assert shaded > 6000 and penumbra > 200, (shaded, penumbra)


# --- radiation pressure ------------------------------------------------------------------------


def _err(got, want):
    """The largest component error relative to the largest component of ``want``."""
    want = np.asarray(want, dtype=float)
    return float(np.max(np.abs(np.asarray(got, dtype=float) - want)) / np.max(np.abs(want)))


def test_cannonball_magnitude_direction_and_inverse_square():
    """Away from the Sun, nu P_au (au / r)^2 cram at 0.39, 1 and 5.2 au and at nu = 0.5; measured
    max relative error 1.1e-15."""
    rng = np.random.default_rng(17)
    cram = 1.3 * 2.0 / 500.0
    worst = 0.0
    for _ in range(50):
        sun = rng.normal(size=3) * AU
        u = _unit(rng)
        for dist in (AU, 0.39 * AU, 5.2 * AU):
            acc = srp_cannonball(*(sun + dist * u), *sun, P_AU, AU, cram, 1.0)
            worst = max(worst, _err(acc, P_AU * (AU / dist) ** 2 * cram * u))
        half = srp_cannonball(*(sun + AU * u), *sun, P_AU, AU, cram, 0.5)
        worst = max(worst, _err(half, 0.5 * P_AU * cram * u))
    assert worst < 4e-15, f"max relative error {worst:.2e} (measured 1.1e-15)"
    assert srp_cannonball(AU, 0.0, 0.0, 0.0, 0.0, 0.0, P_AU, AU, cram, 0.0) == (0.0, 0.0, 0.0)


def _lit_pair(rng):
    """A unit normal n and a unit e toward the Sun with n . e > 0.05."""
    while True:
        n, e = _unit(rng), _unit(rng)
        if n @ e > 0.05:
            return n, e


def test_black_mirror_and_white_plates():
    """Black: P A cos along -e; mirror: 2 P A cos^2 along -n; white (Lambert): normal component
    -P A cos (cos + 2/3), tangential that of the absorbed light; a mix is linear in the
    coefficients. Measured max relative errors 5.9e-16, 1.2e-15, 6.7e-16, 1.6e-15, 2.9e-16."""
    rng = np.random.default_rng(19)
    area, p = 2.5, P_AU
    worst = np.zeros(5)
    for _ in range(100):
        n, e = _lit_pair(rng)
        cs = n @ e
        black = np.array(srp_plate(*n, *e, area, p, 0.0, 0.0, False))
        mirror = np.array(srp_plate(*n, *e, area, p, 1.0, 0.0, False))
        white = np.array(srp_plate(*n, *e, area, p, 0.0, 1.0, False))
        mixed = srp_plate(*n, *e, area, p, 0.3, 0.5, False)
        errs = [
            _err(black, -p * area * cs * e),
            _err(mirror, -2.0 * p * area * cs * cs * n),
            _err(white @ n, -p * area * cs * (cs + 2.0 / 3.0)),
            _err(white - (white @ n) * n, -p * area * cs * (e - cs * n)),
            _err(mixed, 0.2 * black + 0.3 * mirror + 0.5 * white),
        ]
        worst = np.maximum(worst, errs)
    assert np.all(worst < 5e-15), f"max relative errors (black, mirror, white normal, tangential, mix): {worst}"


def test_plate_sides():
    """Lit from behind: nothing on a one-sided plate, the front's force on a two-sided one (bool
    or float flag); edge-on: nothing."""
    rng = np.random.default_rng(23)
    for _ in range(50):
        n, e = _lit_pair(rng)
        front = srp_plate(*n, *e, 1.0, 1.0, 0.4, 0.3, False)
        assert -np.dot(front, e) >= 0.6 * (n @ e)  # -F . e >= P A cos (1 - specular)
        assert srp_plate(*(-n), *e, 1.0, 1.0, 0.4, 0.3, False) == (0.0, 0.0, 0.0)
        assert srp_plate(*(-n), *e, 1.0, 1.0, 0.4, 0.3, 0.0) == (0.0, 0.0, 0.0)
        for flag in (True, 1.0):
            assert srp_plate(*(-n), *e, 1.0, 1.0, 0.4, 0.3, flag) == front
            assert srp_plate(*n, *e, 1.0, 1.0, 0.4, 0.3, flag) == front
    assert srp_plate(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.5, 0.5, True) == (0.0, 0.0, 0.0)


def _box_faces(rot, lx, ly, lz):
    """(normal, area) of the six faces of a box with edges lx, ly, lz, turned by ``rot``."""
    out = []
    for axis, area in ((0, ly * lz), (1, lx * lz), (2, lx * ly)):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            out.append((rot @ n, area))
    return out


def test_closed_cube_of_black_plates():
    """Six one-sided black plates of a unit cube, turned at random, lit from random directions:
    -P A_proj e, A_proj = |e'_x| + |e'_y| + |e'_z|; measured max relative error 3.5e-16."""
    rng = np.random.default_rng(29)
    worst = 0.0
    for _ in range(200):
        rot = _rotation(rng)
        e = _unit(rng)
        total = np.zeros(3)
        for n, area in _box_faces(rot, 1.0, 1.0, 1.0):
            total += srp_plate(*n, *e, area, P_AU, 0.0, 0.0, False)
        worst = max(worst, _err(total, -P_AU * np.sum(np.abs(rot.T @ e)) * e))
    assert worst < 2e-15, f"max relative error {worst:.2e} (measured 3.5e-16)"


# --- drag --------------------------------------------------------------------------------------


def test_box_of_drag_plates():
    """Six one-sided faces of a random box, turned at random: -1/2 rho Cd A_proj |v| v with
    A_proj = (|v'_x| Ly Lz + |v'_y| Lx Lz + |v'_z| Lx Ly) / |v|; measured max relative error 4.7e-16."""
    rng = np.random.default_rng(31)
    rho, cd = 3e-12, 2.2
    worst = 0.0
    for _ in range(200):
        rot = _rotation(rng)
        lx, ly, lz = rng.uniform(0.1, 3.0, 3)
        v = _unit(rng) * rng.uniform(10.0, 8000.0)
        total = np.zeros(3)
        for n, area in _box_faces(rot, lx, ly, lz):
            total += drag_plate(*n, *v, area, cd, rho, False)
        speed = np.linalg.norm(v)
        vb = np.abs(rot.T @ v) / speed
        a_proj = vb[0] * ly * lz + vb[1] * lx * lz + vb[2] * lx * ly
        worst = max(worst, _err(total, -0.5 * rho * cd * a_proj * speed * v))
    assert worst < 2e-15, f"max relative error {worst:.2e} (measured 4.7e-16)"


def test_drag_plate_sides_and_rest():
    """The projected fraction n . v / |v| on the front, the full area face-on, nothing on a
    one-sided plate's back, the front's force on a two-sided one's, nothing at rest; measured max
    relative error 1.5e-15."""
    rng = np.random.default_rng(37)
    rho, cd, area = 1e-11, 2.0, 1.7
    worst = 0.0
    for _ in range(50):
        n = _unit(rng)
        v = _unit(rng) * 7500.0
        if n @ v < 0:
            v = -v
        front = drag_plate(*n, *v, area, cd, rho, False)
        worst = max(worst, _err(front, -0.5 * rho * cd * area * (n @ v) * v))
        face_on = drag_plate(*n, *(7500.0 * n), area, cd, rho, False)
        worst = max(worst, _err(face_on, -0.5 * rho * cd * area * 7500.0**2 * n))
        assert drag_plate(*(-n), *v, area, cd, rho, False) == (0.0, 0.0, 0.0)
        assert drag_plate(*(-n), *v, area, cd, rho, 0.0) == (0.0, 0.0, 0.0)
        for flag in (True, 1.0):
            assert drag_plate(*(-n), *v, area, cd, rho, flag) == front
    assert worst < 4e-15, f"max relative error {worst:.2e} (measured 1.5e-15)"
    assert drag_plate(0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 2.2, 1e-12, True) == (0.0, 0.0, 0.0)


def _central_gradient(f, d, eps):
    out = np.empty(3)
    for j in range(3):
        e = np.zeros(3)
        e[j] = eps
        out[j] = (f(d + e) - f(d - e)) / (2 * eps)
    return out


@pytest.mark.parametrize("regime", ["penumbra", "annular"])
def test_conical_gradient_matches_central_differences(regime):
    """Earth's penumbra from 200 km to 4e7 m up, and the Moon's annular eclipse (300 random
    geometries each): the gradient against central differences of step 1e-3 of the distance,
    in angle, to the regime's nearest edge; measured max relative difference 2.2e-6 (penumbra)
    and 9.7e-7 (annular), the differences' own truncation (median 1.3e-7 and 4.7e-10)."""
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(300):
        if regime == "penumbra":
            radius, a = R_EARTH, math.asin(R_SUN / AU * rng.uniform(0.97, 1.03))
            b = math.asin(R_EARTH / (R_EARTH + 10 ** rng.uniform(5.3, 7.6)))
            c = rng.uniform(b - a, a + b)
        else:
            radius, a = 1737.4e3, math.asin(R_SUN / AU)
            b = rng.uniform(0.2, 0.95) * a
            c = rng.uniform(0.0, a - b)
        d, s = _geometry(a, b, c, rng, radius=radius)
        nu, *g = shadow_conical_gradient(*d, *s, radius, R_SUN)
        assert nu == shadow_conical(*d, *s, radius, R_SUN)
        g = np.array(g)
        eps = 1e-3 * min(abs(c - (a + b)), abs(c - abs(a - b)), c) * np.linalg.norm(d)
        fd = _central_gradient(lambda x, s=s, radius=radius: shadow_conical(*x, *s, radius, R_SUN), d, eps)
        worst = max(worst, np.abs(g - fd).max() / np.abs(fd).max())
    assert worst < 1e-5, worst


def test_conical_gradient_vanishes_off_the_edges():
    """In full sunlight, in the umbra and inside the body nu is constant: its gradient is 0."""
    rng = np.random.default_rng(4)
    for regime in ("full", "umbra"):
        for _ in range(100):
            d, s = _geometry(*_random_abc(rng, regime), rng)
            assert shadow_conical_gradient(*d, *s, R_EARTH, R_SUN)[1:] == (0.0, 0.0, 0.0)
    s = np.array([AU, 0.0, 0.0])
    assert shadow_conical_gradient(0.5 * R_EARTH, 0.0, 0.0, *s, R_EARTH, R_SUN) == (0.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("shadow", [0.0, 2.0])
def test_srp_piece_jacobian_matches_central_differences(shadow):
    """The cannonball's dF/dx1 that srp's piece adds into J, against central differences of its
    force in x1, for steps of 10 s in LEO with the midpoint in Earth's penumbra (conical) or
    anywhere (no shadow); measured max relative difference 1.5e-6 and 6.5e-10."""
    from emorbit.kernels.effects.srp import srp_piece

    rng = np.random.default_rng(5)
    p = np.array([P_AU, AU, R_EARTH, R_SUN, shadow, 0.0, 0.0, 0.0, 3600.0, 0.0, 0.0])
    worst = 0.0
    for _ in range(100):
        a, b = math.asin(R_SUN / AU), math.asin(R_EARTH / (R_EARTH + rng.uniform(300e3, 800e3)))
        c = rng.uniform(b - a, a + b) if shadow else rng.uniform(0.0, math.pi)
        m, s = _geometry(a, b, c, rng)
        v = 7.6e3 * _unit(rng)
        x0, x1 = m - 5.0 * v, m + 5.0 * v
        J = np.zeros((3, 3))
        srp_piece(*x0, *x1, 10.0, 0.02, p, np.zeros(0), s, J, True)
        margin = min(abs(c - (a + b)), abs(c - abs(a - b))) if shadow else 1.0
        # without shadow the force changes over 1 au: steps of 100 km keep round-off out
        eps = 2e-3 * margin * np.linalg.norm(m) if shadow else 1e5
        fd = np.empty((3, 3))
        for j in range(3):
            e = np.zeros(3)
            e[j] = eps
            up = np.array(srp_piece(*x0, *(x1 + e), 10.0, 0.02, p, np.zeros(0), s, np.zeros((3, 3)), False))
            down = np.array(srp_piece(*x0, *(x1 - e), 10.0, 0.02, p, np.zeros(0), s, np.zeros((3, 3)), False))
            fd[:, j] = (up - down) / (2 * eps)
        worst = max(worst, np.abs(J - fd).max() / np.abs(fd).max())
    assert worst < 1e-5, worst
