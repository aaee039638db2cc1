"""A point mass ``gm`` at the centre ``c``: its potential, conserving discrete force and Jacobian.

Per unit mass of the moving point, with ``d = x - c`` and ``r = |d|``::

    V(x) = -gm / r
    F(x0, x1) = -gm (d0 + d1) / (r0 r1 (r0 + r1))

Since ``(d0 + d1) . (d1 - d0) = r1^2 - r0^2``, the work is
``F . (x1 - x0) = -gm (r1 - r0) / (r0 r1) = -(V(x1) - V(x0))`` exactly in exact
arithmetic, and the quotient is formed without a difference ``r1 - r0`` (no cancellation).
``F(x, x) = -gm d / r^3`` is the field, and F is parallel to ``d0 + d1``, so an em step
keeps the angular momentum about ``c``. This is Greenspan's conserving pair force
(Greenspan 1984) and the ``g_em`` of Goettlicher & Schweizerhof
(:mod:`emorbit.kernels.gravity`).

Mutual gravity: the force per unit mass of body i due to body j is this force with
``d = x_i - x_j`` (centre ``c = 0``) and ``gm = G m_j``; the force per unit mass of j is
the opposite times ``m_i / m_j``. :func:`pair_sums` sums it over every pair of a packed set
of points in branch-free loops that LLVM vectorises, :func:`pair_pass` keeps those sums at
the iterates of the em step (afresh, or for the points that moved), :func:`pair_blocks`
(every point) and :func:`pair_block` (one point) give the diagonal blocks of their Jacobian.

Jacobian, with ``k = gm / (r0 r1 (r0 + r1))`` and ``s = d0 + d1``::

    dF/dx1 = -k I + k (1 / r1 + 1 / (r0 + r1)) s d1^T / r1

Data layout: components as float64 scalars, a (3, 3) float64 array ``J`` that the
Jacobian is added into (``J[i, j] += dF_i / dx1_j``); the pair sums take packed contiguous
(K,) float64 arrays, one per coordinate. References: D. Greenspan,
J. Comput. Phys. 56 (1984) 28-41; J. C. Simo, N. Tarnow, ZAMP 43 (1992) 757-792.
"""

from __future__ import annotations

import math

from ..jit import kernel

__all__ = [
    "central_potential",
    "central_force",
    "central_jacobian",
    "central_piece",
    "central_potential_piece",
    "central_rate",
    "pair_unit",
    "pair_force",
    "pair_sums",
    "pair_pass",
    "pair_blocks",
    "pair_block",
    "PAIR_MOVE",
    "PAIR_ROWS",
]

_inline = kernel(inline="always")
# an effect-set piece: compiled on its own (cached per install) and inlined by LLVM into the set
_piece = kernel(forceinline=True)


@_inline
def central_potential(x, y, z, c0, c1, c2, gm):
    """The potential of a point mass per unit mass of the moving point.

    Parameters
    ----------
    x, y, z : float
        Position of the point (m).
    c0, c1, c2 : float
        Position of the centre (m).
    gm : float
        Gravitational parameter of the centre (m^3/s^2).

    Returns
    -------
    float
        ``V = -gm / r`` (J/kg), ``r = |x - c|``.
    """
    d0 = x - c0
    d1 = y - c1
    d2 = z - c2
    return -gm / math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@_inline
def central_force(x0, y0, z0, x1, y1, z1, c0, c1, c2, gm):
    """The conserving discrete force of a point mass over the step x0 -> x1.

    Parameters
    ----------
    x0, y0, z0 : float
        Position at the start of the step (m).
    x1, y1, z1 : float
        Position at the end of the step (m).
    c0, c1, c2 : float
        Position of the centre (m).
    gm : float
        Gravitational parameter of the centre (m^3/s^2).

    Returns
    -------
    tuple of float
        ``(fx, fy, fz)``, ``F = -gm (d0 + d1) / (r0 r1 (r0 + r1))`` per unit mass
        (m/s^2), ``d = x - c``; ``F . (x1 - x0) = -(V(x1) - V(x0))``.
    """
    a0 = x0 - c0
    a1 = y0 - c1
    a2 = z0 - c2
    b0 = x1 - c0
    b1 = y1 - c1
    b2 = z1 - c2
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    k = -gm / (r0 * r1 * (r0 + r1))
    return k * (a0 + b0), k * (a1 + b1), k * (a2 + b2)


@_inline
def central_jacobian(x0, y0, z0, x1, y1, z1, c0, c1, c2, gm, J):
    """Add the derivative of :func:`central_force` with respect to the end point into ``J``.

    Parameters
    ----------
    x0, y0, z0 : float
        Position at the start of the step (m).
    x1, y1, z1 : float
        Position at the end of the step (m).
    c0, c1, c2 : float
        Position of the centre (m).
    gm : float
        Gravitational parameter of the centre (m^3/s^2).
    J : numpy.ndarray
        (3, 3) float64, updated in place: ``J[i, j] += dF_i / dx1_j`` (1/s^2).
    """
    a0 = x0 - c0
    a1 = y0 - c1
    a2 = z0 - c2
    b0 = x1 - c0
    b1 = y1 - c1
    b2 = z1 - c2
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    rs = r0 + r1
    k = gm / (r0 * r1 * rs)
    w = k * (1.0 / r1 + 1.0 / rs) / r1
    s0 = w * (a0 + b0)
    s1 = w * (a1 + b1)
    s2 = w * (a2 + b2)
    J[0, 0] += s0 * b0 - k
    J[0, 1] += s0 * b1
    J[0, 2] += s0 * b2
    J[1, 0] += s1 * b0
    J[1, 1] += s1 * b1 - k
    J[1, 2] += s1 * b2
    J[2, 0] += s2 * b0
    J[2, 1] += s2 * b1
    J[2, 2] += s2 * b2 - k


@_piece
def central_piece(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac):
    """The effect-set piece (:mod:`.signatures`): :func:`central_force` and, where ``jac``,
    :func:`central_jacobian`, with ``p = [c0, c1, c2, gm]``."""
    if jac:
        central_jacobian(x0, y0, z0, x1, y1, z1, p[0], p[1], p[2], p[3], J)
    return central_force(x0, y0, z0, x1, y1, z1, p[0], p[1], p[2], p[3])


@_piece
def central_rate(x, y, z, vx, vy, vz, c, p):
    """The effect-set piece that sets adaptive steps' time scale: ``W = gm / r**3`` (the
    squared Kepler rate, 1/s^2) and its rate of change along the motion, ``-3 W (d . v) /
    r**2`` (1/s^3)."""
    d0 = x - p[0]
    d1 = y - p[1]
    d2 = z - p[2]
    r2 = d0 * d0 + d1 * d1 + d2 * d2
    w = p[3] / (r2 * math.sqrt(r2))
    return w, -3.0 * w * (d0 * vx + d1 * vy + d2 * vz) / r2


@_piece
def central_potential_piece(x, y, z, c, p, tab, s):
    """The effect-set piece: :func:`central_potential` with ``p = [c0, c1, c2, gm]``."""
    return central_potential(x, y, z, p[0], p[1], p[2], p[3])


@_inline
def pair_unit(a0, a1, a2, b0, b1, b2, J):
    """A pair's force over the step per unit G m_j, and its Jacobian, in one pass (mutual gravity).

    With the pair's separation ``d = x_i - x_j`` at the start (``a``) and at the end (``b``)
    of the step: ``S = -(a + b) k``, ``k = 1 / (r0 r1 (r0 + r1))`` (:func:`central_force`
    with ``gm = 1`` and the centre at 0), and ``J = dS/db = -k I + w (a + b) b^T``,
    ``w = k (1/r1 + 1/(r0 + r1)) / r1`` (:func:`central_jacobian`). Two square roots and two
    divisions for both.

    Parameters
    ----------
    a0, a1, a2 : float
        The separation at the start of the step (m).
    b0, b1, b2 : float
        The separation at the end of the step (m).
    J : numpy.ndarray
        (3, 3) float64, overwritten with ``dS_i / db_j`` (1/m^3).

    Returns
    -------
    tuple of float
        ``S`` (3 components, 1/m^2) and a bound of the entries of ``J``, ``k (3 + r0 / r1)``.
    """
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    rs = r0 + r1
    k = 1.0 / (r0 * r1 * rs)
    w = k * k * r0 * (r0 + 2.0 * r1) / r1
    u0 = a0 + b0
    u1 = a1 + b1
    u2 = a2 + b2
    s0 = w * u0
    s1 = w * u1
    s2 = w * u2
    J[0, 0] = s0 * b0 - k
    J[0, 1] = s0 * b1
    J[0, 2] = s0 * b2
    J[1, 0] = s1 * b0
    J[1, 1] = s1 * b1 - k
    J[1, 2] = s1 * b2
    J[2, 0] = s2 * b0
    J[2, 1] = s2 * b1
    J[2, 2] = s2 * b2 - k
    return -k * u0, -k * u1, -k * u2, k * (3.0 + r0 / r1)


@_inline
def pair_force(a0, a1, a2, b0, b1, b2):
    """:func:`pair_unit` without the Jacobian: the force per unit G m_j and the bound.

    Parameters
    ----------
    a0, a1, a2 : float
        The separation at the start of the step (m).
    b0, b1, b2 : float
        The separation at the end of the step (m).

    Returns
    -------
    tuple of float
        ``S`` (3 components, 1/m^2) and ``k (3 + r0 / r1)``, a bound of the entries of dS/db.
    """
    r0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    r1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    rs = r0 + r1
    k = 1.0 / (r0 * r1 * rs)
    return -k * (a0 + b0), -k * (a1 + b1), -k * (a2 + b2), k * (3.0 + k * r0 * r0 * rs)


@_inline
def _pair_row(a, xa0, ya0, za0, xa1, ya1, za1, ga, x0, y0, z0, x1, y1, z1, lo, fx, fy, fz, rho):
    """Add point a's pair force per unit mass on every other point j; its own term is 0."""
    la0, lb0, lc0, la1, lb1, lc1 = lo[0, a], lo[1, a], lo[2, a], lo[3, a], lo[4, a], lo[5, a]
    l0, l1, l2, l3, l4, l5 = lo[0], lo[1], lo[2], lo[3], lo[4], lo[5]
    for j in range(x0.shape[0]):  # from 0, branch-free, over contiguous arrays: LLVM vectorises it
        ax = (xa0 - x0[j]) + (la0 - l0[j])
        ay = (ya0 - y0[j]) + (lb0 - l1[j])
        az = (za0 - z0[j]) + (lc0 - l2[j])
        bx = (xa1 - x1[j]) + (la1 - l3[j])
        by = (ya1 - y1[j]) + (lb1 - l4[j])
        bz = (za1 - z1[j]) + (lc1 - l5[j])
        r0 = math.sqrt(ax * ax + ay * ay + az * az)
        r1 = math.sqrt(bx * bx + by * by + bz * bz)
        rs = r0 + r1
        same = 1.0 if j == a else 0.0  # 1 for a itself: q = 0 instead of 0/0
        q = (1.0 - same) / (r0 * r1 * rs + same)
        k = ga * q
        fx[j] += k * (ax + bx)
        fy[j] += k * (ay + by)
        fz[j] += k * (az + bz)
        rho[j] += k * (3.0 + q * r0 * r0 * rs)


@kernel
def pair_sums(x0, y0, z0, x1, y1, z1, lo, gm, fx, fy, fz, rho):
    """Every point's sum of the pair forces over the step, per unit mass, and their coupling.

    For each point j of a packed set: ``f_j = -sum_{a != j} gm_a (d0 + d1) / (r0 r1 (r0 + r1))``
    with ``d = x_j - x_a`` (:func:`pair_force` times ``gm_a``), and ``rho_j = sum_a gm_a
    k (3 + r0 / r1)``, a bound of the row sum of ``|d f_j / d x1_a|``. Each pair is evaluated
    once from each side: the loop over j is branch-free over contiguous arrays and
    accumulates only into j's entries, so LLVM vectorises it without reordering any sum
    (no reduction across lanes: the results do not depend on the vector width). The two
    sides of a pair are bitwise opposite (``(x_a - x_j) = -(x_j - x_a)`` exactly), so the
    pair forces are equal and opposite and lie along ``d0 + d1``.

    Parameters
    ----------
    x0, y0, z0 : numpy.ndarray
        (K,) positions at the start of the step (m), contiguous.
    x1, y1, z1 : numpy.ndarray
        (K,) positions at the end of the step (m).
    lo : numpy.ndarray
        (6, K) the positions' low parts (m): the point is at ``x0 + lo[0]``, ... at the start
        and ``x1 + lo[3]``, ... at the end, and each separation is formed as
        ``(x_j - x_a) + (lo_j - lo_a)``, so a close pair far from the origin is not evaluated
        at positions rounded to eps |x| (zeros: the positions as given).
    gm : numpy.ndarray
        (K,) G m of each point (m^3/s^2).
    fx, fy, fz : numpy.ndarray
        (K,) overwritten with the force per unit mass (m/s^2).
    rho : numpy.ndarray
        (K,) overwritten with the coupling bound (1/s^2).
    """
    n = x0.shape[0]
    for j in range(n):
        fx[j] = 0.0
        fy[j] = 0.0
        fz[j] = 0.0
        rho[j] = 0.0
    for a in range(n):
        xa0 = x0[a]
        ya0 = y0[a]
        za0 = z0[a]
        xa1 = x1[a]
        ya1 = y1[a]
        za1 = z1[a]
        _pair_row(a, xa0, ya0, za0, xa1, ya1, za1, gm[a], x0, y0, z0, x1, y1, z1, lo, fx, fy, fz, rho)


@_inline
def _move_row(a, xo, yo, zo, lxo, lyo, lzo, w, fx, fy, fz):
    """Add to every other point j the change of point a's pair force as a moves from
    (xo, yo, zo) + (lxo, lyo, lzo) to its new end position (``w`` rows 11-13 and 23-25) at the
    end of the step, both terms as :func:`_pair_row` forms them (``w`` as :func:`pair_pass`)."""
    x0, y0, z0, x1, y1, z1 = w[0], w[1], w[2], w[3], w[4], w[5]
    l0, l1, l2, l3, l4, l5 = w[17], w[18], w[19], w[20], w[21], w[22]
    xa0, ya0, za0, la0, lb0, lc0 = w[0, a], w[1, a], w[2, a], w[17, a], w[18, a], w[19, a]
    xn, yn, zn, lxn, lyn, lzn = w[11, a], w[12, a], w[13, a], w[23, a], w[24, a], w[25, a]
    ga = w[6, a]
    for j in range(x0.shape[0]):
        ax = (xa0 - x0[j]) + (la0 - l0[j])
        ay = (ya0 - y0[j]) + (lb0 - l1[j])
        az = (za0 - z0[j]) + (lc0 - l2[j])
        bx = (xn - x1[j]) + (lxn - l3[j])
        by = (yn - y1[j]) + (lyn - l4[j])
        bz = (zn - z1[j]) + (lzn - l5[j])
        cx = (xo - x1[j]) + (lxo - l3[j])
        cy = (yo - y1[j]) + (lyo - l4[j])
        cz = (zo - z1[j]) + (lzo - l5[j])
        r0 = math.sqrt(ax * ax + ay * ay + az * az)
        rn = math.sqrt(bx * bx + by * by + bz * bz)
        ro = math.sqrt(cx * cx + cy * cy + cz * cz)
        same = 1.0 if j == a else 0.0
        kn = ga * ((1.0 - same) / (r0 * rn * (r0 + rn) + same))
        ko = ga * ((1.0 - same) / (r0 * ro * (r0 + ro) + same))
        fx[j] += kn * (ax + bx) - ko * (ax + cx)
        fy[j] += kn * (ay + by) - ko * (ay + cy)
        fz[j] += kn * (az + bz) - ko * (az + cz)


@_inline
def _terms_row(a, w, tx, ty, tz):
    """Each point j's pair force on point a, as :func:`_pair_row` forms it in j's row
    (``w`` as :func:`pair_pass`)."""
    x0, y0, z0, x1, y1, z1, gm = w[0], w[1], w[2], w[3], w[4], w[5], w[6]
    l0, l1, l2, l3, l4, l5 = w[17], w[18], w[19], w[20], w[21], w[22]
    xa0, ya0, za0, xa1, ya1, za1 = w[0, a], w[1, a], w[2, a], w[3, a], w[4, a], w[5, a]
    la0, lb0, lc0, la1, lb1, lc1 = w[17, a], w[18, a], w[19, a], w[20, a], w[21, a], w[22, a]
    for j in range(x0.shape[0]):
        ax = (x0[j] - xa0) + (l0[j] - la0)
        ay = (y0[j] - ya0) + (l1[j] - lb0)
        az = (z0[j] - za0) + (l2[j] - lc0)
        bx = (x1[j] - xa1) + (l3[j] - la1)
        by = (y1[j] - ya1) + (l4[j] - lb1)
        bz = (z1[j] - za1) + (l5[j] - lc1)
        r0 = math.sqrt(ax * ax + ay * ay + az * az)
        r1 = math.sqrt(bx * bx + by * by + bz * bz)
        same = 1.0 if j == a else 0.0
        k = gm[j] * ((1.0 - same) / (r0 * r1 * (r0 + r1) + same))
        tx[j] = k * (ax + bx)
        ty[j] = k * (ay + by)
        tz[j] = k * (az + bz)


#: a point's move is left out of the pair forces while the change it makes in every point's
#: em residual is below this fraction of eps relative to that point's increment
PAIR_MOVE = 1e-4
#: the rows of :func:`pair_pass`'s packed array
PAIR_ROWS = 26


@kernel
def pair_pass(first, hh, x0, x1, idx, w, moved, fp, rho):
    """The pair forces of mutual gravity at the current iterates of the em step, into ``fp``.

    ``first``: every pair afresh (:func:`pair_sums`). Later sweeps: the pair forces change
    only where points moved. A point whose end position lies within ``tol`` of the one its
    pair forces were last formed at keeps it, with ``tol = PAIR_MOVE eps min_i |dx_i| /
    (6 h^2/2 rho_i)``: the forces on any point i change by at most ``6 rho_i`` times the
    largest such move, so every residual stays below ``PAIR_MOVE eps`` of its increment (the
    stopping rule's own estimate is ``1e-3 eps``). Where at most an eighth of the points
    moved, each moved point's change is added to every other point's force (both terms as
    :func:`pair_sums` forms them) and the moved points' own forces are summed afresh in
    :func:`pair_sums`' order (their bits are those of a full pass); else every pair is
    evaluated again. The forces at the end are the pair forces at the positions recorded in
    ``w`` to round-off, and those lie within ``tol`` of the iterates.

    Positions come as a high and a low part (rows 3-5 of ``x0`` and ``x1`` where they have
    six rows: the compensation of the point-mass state), and the separations are formed from
    both (:func:`pair_sums`), so a close pair keeps its separation to eps of itself wherever
    it lies.

    Parameters
    ----------
    first : bool
        The first sweep of a sub-step.
    hh : float
        h^2 / 2 (s^2).
    x0, x1 : numpy.ndarray
        (3, n) or (6, n) positions at the start and at the end of the sub-step (m): high
        parts, then low parts where there are six rows.
    idx : numpy.ndarray
        (K,) int64, the points that attract each other.
    w : numpy.ndarray
        (:data:`PAIR_ROWS`, K) packed rows: x0, y0, z0 (start), x1, y1, z1 (where the forces
        are formed), G m, fx, fy, fz, rho (as :func:`pair_sums`), the new end positions (11-13),
        scratch (14-16), the low parts of the start (17-19), of where the forces are formed
        (20-22) and of the new end positions (23-25).
    moved : numpy.ndarray
        (K,) int64 scratch.
    fp : numpy.ndarray
        (3, n) the pair forces per unit mass of the points in ``idx`` (m/s^2), updated.
    rho : numpy.ndarray
        (n,) their coupling bounds (1/s^2), updated after a full pass.

    Returns
    -------
    int
        The number of points whose pair forces were formed afresh (K after a full pass).
    """
    kk = idx.shape[0]
    low = x0.shape[0] == 6 and x1.shape[0] == 6
    tol = math.inf
    for p in range(kk):
        i = idx[p]
        for c in range(3):
            w[11 + c, p] = x1[c, i]
            w[23 + c, p] = x1[3 + c, i] if low else 0.0
        c6 = 6.0 * hh * w[10, p]
        if c6 > 0.0:
            d0 = x1[0, i] - x0[0, i]
            d1 = x1[1, i] - x0[1, i]
            d2 = x1[2, i] - x0[2, i]
            tol = min(tol, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / c6)
    tol *= PAIR_MOVE * 2.0**-52
    nm = 0
    if not first:
        for p in range(kk):
            d = math.sqrt(
                ((w[11, p] - w[3, p]) + (w[23, p] - w[20, p])) ** 2
                + ((w[12, p] - w[4, p]) + (w[24, p] - w[21, p])) ** 2
                + ((w[13, p] - w[5, p]) + (w[25, p] - w[22, p])) ** 2
            )
            if not d <= tol:
                moved[nm] = p
                nm += 1
    if first or 8 * nm > kk:
        for p in range(kk):
            i = idx[p]
            for c in range(3):
                w[c, p] = x0[c, i]
                w[17 + c, p] = x0[3 + c, i] if low else 0.0
                w[3 + c, p] = w[11 + c, p]
                w[20 + c, p] = w[23 + c, p]
        pair_sums(w[0], w[1], w[2], w[3], w[4], w[5], w[17:23], w[6], w[7], w[8], w[9], w[10])
        for p in range(kk):
            i = idx[p]
            for c in range(3):
                fp[c, i] = w[7 + c, p]
            rho[i] = w[10, p]
        return kk
    for q in range(nm):  # each moved point's change, on every point (the moved ones' are replaced below)
        a = moved[q]
        _move_row(a, w[3, a], w[4, a], w[5, a], w[20, a], w[21, a], w[22, a], w, w[7], w[8], w[9])
    for q in range(nm):
        a = moved[q]
        for c in range(3):
            w[3 + c, a] = w[11 + c, a]
            w[20 + c, a] = w[23 + c, a]
    for q in range(nm):  # the moved points' own forces, summed in pair_sums' order
        a = moved[q]
        _terms_row(a, w, w[14], w[15], w[16])
        sx = 0.0
        sy = 0.0
        sz = 0.0
        for j in range(kk):  # a's own term is 0
            sx += w[14, j]
            sy += w[15, j]
            sz += w[16, j]
        w[7, a] = sx
        w[8, a] = sy
        w[9, a] = sz
    for p in range(kk):
        i = idx[p]
        for c in range(3):
            fp[c, i] = w[7 + c, p]
    return nm


@_inline
def _block_row(a, xa0, ya0, za0, xa1, ya1, za1, ga, x0, y0, z0, x1, y1, z1, b0, b1, b2, b3, b4, b5, b6, b7, b8):
    """Add point a's part of every other point j's diagonal Jacobian block (as in _pair_row)."""
    for j in range(x0.shape[0]):
        ax = xa0 - x0[j]
        ay = ya0 - y0[j]
        az = za0 - z0[j]
        bx = xa1 - x1[j]
        by = ya1 - y1[j]
        bz = za1 - z1[j]
        r0 = math.sqrt(ax * ax + ay * ay + az * az)
        r1 = math.sqrt(bx * bx + by * by + bz * bz)
        rs = r0 + r1
        same = 1.0 if j == a else 0.0
        k = ga * ((1.0 - same) / (r0 * r1 * rs + same))
        w = k * (r0 + 2.0 * r1) / (r1 * r1 * rs + same)
        ux = w * (ax + bx)
        uy = w * (ay + by)
        uz = w * (az + bz)
        b0[j] += ux * bx - k
        b1[j] += ux * by
        b2[j] += ux * bz
        b3[j] += uy * bx
        b4[j] += uy * by - k
        b5[j] += uy * bz
        b6[j] += uz * bx
        b7[j] += uz * by
        b8[j] += uz * bz - k


@kernel
def pair_blocks(x0, y0, z0, x1, y1, z1, gm, b):
    """Every point's diagonal Jacobian block of its pair forces, ``d f_j / d x1_j``.

    ``sum_{a != j} gm_a (-k I + w (d0 + d1) d1^T)`` with ``d = x_j - x_a``,
    ``k = 1 / (r0 r1 (r0 + r1))``, ``w = k (1/r1 + 1/(r0 + r1)) / r1`` (:func:`pair_unit`;
    the term is the same from either side of the pair), in loops that LLVM vectorises as
    in :func:`pair_sums`.

    Parameters
    ----------
    x0, y0, z0, x1, y1, z1, gm : numpy.ndarray
        As in :func:`pair_sums`.
    b : numpy.ndarray
        (9, K) overwritten: ``b[3 r + c, j] = d f_j[r] / d x1_j[c]`` (1/s^2).
    """
    n = x0.shape[0]
    b[:, :] = 0.0
    for a in range(n):
        xa0 = x0[a]
        ya0 = y0[a]
        za0 = z0[a]
        xa1 = x1[a]
        ya1 = y1[a]
        za1 = z1[a]
        _block_row(
            a, xa0, ya0, za0, xa1, ya1, za1, gm[a], x0, y0, z0, x1, y1, z1, b[0], b[1], b[2], b[3], b[4], b[5], b[6],
            b[7], b[8],
        )  # fmt: skip


@kernel
def pair_block(a, x0, y0, z0, x1, y1, z1, gm, b):
    """One point's column of :func:`pair_blocks`: ``b[:, a]`` overwritten with the diagonal
    Jacobian block of point a's pair forces (a scalar loop over the other points).

    Parameters
    ----------
    a : int
        The point's index in the packed arrays.
    x0, y0, z0, x1, y1, z1, gm, b : numpy.ndarray
        As in :func:`pair_blocks`.
    """
    xa0 = x0[a]
    ya0 = y0[a]
    za0 = z0[a]
    xa1 = x1[a]
    ya1 = y1[a]
    za1 = z1[a]
    diag = 0.0
    m00 = m01 = m02 = m10 = m11 = m12 = m20 = m21 = m22 = 0.0
    for j in range(x0.shape[0]):
        if j == a:
            continue
        ax = xa0 - x0[j]
        ay = ya0 - y0[j]
        az = za0 - z0[j]
        bx = xa1 - x1[j]
        by = ya1 - y1[j]
        bz = za1 - z1[j]
        r0 = math.sqrt(ax * ax + ay * ay + az * az)
        r1 = math.sqrt(bx * bx + by * by + bz * bz)
        rs = r0 + r1
        k = gm[j] / (r0 * r1 * rs)
        w = k * (r0 + 2.0 * r1) / (r1 * r1 * rs)
        ux = w * (ax + bx)
        uy = w * (ay + by)
        uz = w * (az + bz)
        diag += k
        m00 += ux * bx
        m01 += ux * by
        m02 += ux * bz
        m10 += uy * bx
        m11 += uy * by
        m12 += uy * bz
        m20 += uz * bx
        m21 += uz * by
        m22 += uz * bz
    b[0, a] = m00 - diag
    b[1, a] = m01
    b[2, a] = m02
    b[3, a] = m10
    b[4, a] = m11 - diag
    b[5, a] = m12
    b[6, a] = m20
    b[7, a] = m21
    b[8, a] = m22 - diag
