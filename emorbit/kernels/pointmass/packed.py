"""Fast point-mass chunk kernels: the energy-momentum, midpoint and leapfrog steps of
:mod:`emorbit.kernels.pointmass`, reorganised so that LLVM turns them into packed (SIMD)
arithmetic over many points at once, on one thread or on all of them.

Same arguments, same records, same failure codes as :func:`~.pointmass.implicit_chunk`
and :func:`~.pointmass.leapfrog_chunk`. The states agree with those reference kernels to
round-off (leapfrog: bit for bit), and a point's result never depends on which other
points share its block, on the block size, or on how a run is cut into chunks: every
point goes through the same scalar operations (the helpers below) whether they run packed
or alone, and no fused multiply-add is formed (``fastmath=False``) but the explicit ones
(:func:`.eft.fma`: in the error-free transformations, and in the helpers' dot products,
predictor, derivative, certificate bound and increments, where a multiply and an add
became one rounding), so packed and scalar code give the same bits (and the GPU's
``cuda.fma`` the same again).

How the implicit step is solved
-------------------------------
A point-mass step is planar. With ``a = X_Z - x0`` (towards the centre) the energy-momentum
acceleration is ``g_em = k (a + b)``, ``b = a - dx``, ``k = GM / (r0 r1 (r0 + r1))``, and
the implicit equation ``dx = h v0 + h**2/2 g_em`` solves in closed form once ``r1`` is
known. With ``Q = r0 r1 (r0 + r1)`` and ``tau = h**2/2 GM`` (so ``t = h**2/2 k = tau/Q``)::

    dx = (h v0 + 2 t a) / (1 + t),   a + b = (2 a - h v0) / (1 + t),
    g_em = w (2 a - h v0),   w = GM / (Q + tau)

The only unknown is the scalar ``r1 = |a - dx|``; it solves ``F(r1) = 0``::

    F = r1**2 (1 + t)**2 - ((1 - t)**2 A - 2 h (1 - t) P + h**2 V),   A = a.a, P = a.v0, V = v0.v0

a function of three dot products. ``F Q**2`` and ``F' Q**3`` are polynomials in ``r1``, so a
Newton update costs one division and no square root (the reference kernel iterates on
3-vectors, with a square root and two divisions per iteration). ``F Q**2`` is evaluated as
``Q**2 D + 2 tau Q (r1**2 + A - P) + tau**2 (r1**2 - A)`` with ``D = r1**2 - |a - h v0|**2``
(:func:`_em_f2`), which keeps the cancellation of the large terms inside ``D``.

* Predictor: the step's own equations solved as a series (:func:`_em_predict`): ``h**2 w``
  to fourth order in ``h a.v0 / A``, ``h**2 v0.v0 / A`` and ``tau / r0**3``, an error in
  ``r1`` of O(h**7) (until 2026-11 the explicit Taylor step with the jerk, O(h**4), which
  roundoff="fast" keeps: :func:`_em_predict_taylor`).
* Default: one Newton update on the plainly evaluated ``F`` with a certificate
  (:func:`_em_newton_certified`): a rigorous bound on the error of ``rho - delta`` (F's
  rounding, the derivative's, Newton's remainder) whose ends both round to the same double
  prove that double the exact root correctly rounded. At T/1000 of the benchmark ensemble
  99.5 % of the point-steps are certified (100,000 time-uniform states); the rest go to
  the scalar pass, which takes one update on the accurately evaluated ``F``
  (:func:`_em_newton_accurate`), the same double where both apply
  (tests/test_ensemble.py). From 2026-11-23 (second session) to the third the default took
  that accurate update in every step (13.3-14.9 ns per particle-step on one thread), and
  the rounding errors of ``A`` and ``P`` in it; before that a plain Newton and an accurate
  chord update (15.5-16.4 ns). Now, in one process, alternated: 11.5 against 14.5 ns for
  the accurate update with the low parts, 9.3 ns for roundoff="fast" (development machine,
  20,000 particles, fastest of 15 runs of 100 steps); with the helpers' fused multiply-adds
  (fourth session) 10.6 and 8.7 ns; with the big-t count in the update loop and the
  certificate's direct test of its interval's ends (same bits) 10.2 against 10.6 ns.
  roundoff="fast": a Newton update and a chord update with the same derivative (Traub's
  method, third order, one division), both on the plain ``F``.
* A cheap check per point decides: default, the certificate (and in the scalar pass, after
  an update on the accurate ``F``, Newton's remainder about ``d1**2 / (2 r1)``, which must
  be below ``2**-66 r1``: :func:`_em_ok_newton`); fast, the
  Newton-chord pair leaves about ``3 |delta1 delta2| / r1``, which must be below
  ``eps r1 / 4``; the updates below ``r1 / 64`` (:func:`_em_small`), and ``r1`` where a root can be,
  ``0 < r1**2 <= 18 A + 2 V`` (:func:`_em_plausible`): a Newton update that runs off to a
  far or negative ``r1`` can leave a chord update that looks converged there, or one where
  ``F Q**2`` overflows and the update is 0 (until 2026-11 steps at T/4 near pericentre were
  accepted so, the energy off by a factor 2.5, and with the new predictor, before these
  guards, steps at T/20 of the paper's orbit; tests/test_ensemble.py).
  Points that fail it get more Newton updates in a scalar pass (default: certified ones,
  and once an update is below ``2**-32.5 r1`` one on the accurate ``F``; fast: until
  ``|delta| <= 2**-26 r1`` within that range); a point whose scalar Newton iteration misbehaves
  (leaves that range, stops shrinking, runs out of iterations) is solved by the reference
  kernel's 3-vector Newton (:func:`~.pointmass.em_step`), whose stopping and failure rules
  then apply unchanged. Every point's energy stays at round-off; e up to 0.99 is tested.
* Then ``g = w (2 a - h v0)`` and the step in the reference kernel's form,
  ``dx = h v0 + h (h/2 w) u``, ``dv = (h w) u`` with ``u = 2 a - h v0`` (:func:`_increments`;
  ``u`` and ``dx`` each with one fused multiply-add since 2026-11-23, fourth session).

Round-off (Brouwer's law). Newton converges on the rounding errors of whatever ``F`` it
evaluates, so the root it picks is correlated with them, and the energy error of the step
is proportional to the error of the root: a drift, not a random walk. By default
(``METHOD_EM``, roundoff="brouwer"):

* the root is the exact root of ``F`` (for ``A``, ``P``, ``V`` as rounded) correctly
  rounded: certified, or from an update on ``F`` evaluated with every rounding of a
  quantity that depends on ``r1`` carried to well below a rounding of ``r1``
  (:func:`_em_f2_accurate`: ``Q``, ``r1**2``, ``D``, the products) and accepted only with
  less than a ten-thousandth of a rounding left (:func:`_em_ok_newton`), so neither F's
  roundings nor a one-sided remainder of the iteration are left in it (until 2026-11:
  Newton, a plain chord update and a second chord update, 3 updates; then Newton and the
  accurate chord, 2; on 2026-11-23 one Newton update on the accurate ``F``, then the
  certified update). The rounding errors of ``A`` and ``P`` were carried into ``F`` until
  2026-11-23 (third session): they do not depend on ``r1``, so nothing the iteration can
  converge on, and are unbiased; dropped, the step took 2 ns less (drift measured below);
* a step with ``t > 1/128`` (large steps, pericentres) is finished instead as the
  reference kernel finishes (:func:`~.pointmass.em_finish`, a scalar pass over those
  points): without it the step drifts by an amount that grows about as ``t**2`` (below).

Measured with this kernel (``scripts/energy_drift.py``), perturbed copies of the paper's
orbit (256 per seed, 4 seeds, 1e6 steps; 64 at T/8 over 1e5 steps), the mean of ``E/E0 - 1``
per step and its distance from zero in standard errors (``E < 0``: positive means the energy
falls):

* the first form of ``F`` below, Newton + chord (the step before this design): +6.2e-20 at
  T/100; the same iterated to convergence: +1.4e-19 (the one-sided remainder of Newton +
  chord had hidden part of it);
* roundoff="fast" (the ``D`` form without ``AL``, ``PL``, Newton + chord): -4.3e-20 at T/100,
  the remainder of the iteration, of the other sign;
* ``F`` in the ``D`` form with ``AL``, ``PL``, converged, plain last update, no finish of
  large-t steps: +6e-21 at T/100, -1.7e-20 at T/60, and at T/8 a drift 23 standard errors
  from zero;
* this design with steps of t > 1/32 finished: +1.9e-21 (1.2 standard errors) at T/100,
  +6e-22 (0.3) at T/60, and within 1.4 standard errors at T/50, T/30 and T/8, as the
  reference kernel with its finish (these statistics were too small: see below).

With 65536 copies per seed on a GPU, whose kernels (:mod:`.cuda`) give this kernel's bits,
1e6 steps (``python scripts/energy_drift.py --kernel gpu --members 65536 --seeds 1 --div N``,
H100), the drift left, and what removed the rest:

* The finish of large-t steps rounded ``b = a - dx`` and dropped the low part of ``g_em``
  from its residual (:func:`~.pointmass.em_finish`, :func:`~.pointmass._residual`); with
  those carried, T/8 went from -4.9e-20 per step (-11 standard errors) to -4.6e-21 (-1.1),
  T/30 from -7.1e-20 (-155) to +6.1e-21 (+14).
* Steps below the threshold of the finish still drift, about as ``t**2``: with no step
  finished, T/30 +1.05e-19 (+187) and T/60 +7.4e-21 (+23); with t > 1/32 finished (the
  threshold until then), T/20 -1.2e-20 (-22), T/30 +6.1e-21 (+14), T/40 -8.9e-21 (-25),
  T/60 +4.9e-21 (+18), T/100 +1.0e-21 (+5.4); with every step finished, T/30, T/60 and
  T/100 within 2.6 standard errors. With t > 1/128 finished (the default): T/20, T/22.36,
  T/30, T/31.42, T/40, T/60 and T/100 within 2.1 standard errors (README, "Round-off").
  Cost on the development machine: about 5 % on one orbit at T/100 (10 % of its steps are
  finished) and 1 to 3 % on the benchmark ensemble at T/1000.
* Not the cause, measured at T/30 with no step finished: carrying ``tau**2`` exactly into
  ``F`` (its rounding is the same in every step, so it is a systematic error: the drift
  went from +1.05e-19 to -8.7e-20), and with it the rounding of ``V``, ``w`` from an exact
  ``Q`` and increments rounded once (-7.5e-20, -4.2e-20, -2.2e-20, each with the ones
  before): smaller, never zero, and at T/100 with the finish none of them changed anything
  (+1.09e-21 against +1.02e-21). So they are not in the kernel.
* What was left: T/100 +4e-22 per step (seeds 0-3: +1.5e-22, +6.1e-22, +4.0e-22, +3.4e-22;
  z +1.0, +3.8, +2.5, +2.1), overtaking the random walk after about 1e10 steps; T/1000 -8e-23
  (-4.3; the measurement's offset, see the end of this list). With the two-update step and the series predictor (2026-11-23): T/100 +7.9e-23 and
  +1.3e-22 (seeds 0, 1; z +0.5, +0.85), T/60 +2.8e-22 (+1.1), T/30 +1.7e-22 (+0.4), T/1000
  -7.4e-23 (-3.9; -0.7e-23 and -0.4 without the offset); that code lacked the acceptance guards, which
  change no step from T/60 down, and at T/20 it accepted run-off steps (-3e-6 per step); with
  the guards, CPU only (1024 copies, 1e6 steps, 2 to 4 seeds): T/20, T/30, T/100, T/1000 and
  T/8 (1e5 steps) all within 1.4 standard errors (README, "Round-off"). With one accurate
  Newton update (the same correctly rounded root: tests/test_ensemble.py), CPU, 1024 copies,
  1e6 steps, seeds 0 and 1: T/20, T/30, T/60, T/100, T/200 and T/8 within 1.6 standard
  errors; T/1000 (4096 copies) -6.8e-23 and -2.7e-22 (z -0.9, -3.6), the same as the
  two-update step on the same copies (-7.2e-23, -2.7e-22), and with every step finished
  (``_BIG_T = 0``) -2.75e-23 and -4.3e-24. Compiled with fused multiply-adds (differing
  bits) it looked drift-free at T/100 and T/8 (within 1.3 standard errors) but drifted at
  T/30 (-3.1e-20, measured with the old threshold).
* The T/1000 "drift" was the measurement's: ``scripts/energy_drift.py`` evaluated E0 in
  float64, and every copy starts at x0 = (10, 0, 0), so the rounding of GM / 10 (+2.2e-17)
  offset the ensemble mean of E/E0 - 1 by -6.7e-17 in every run, -6.7e-23 per step over
  1e6 steps (-6.7e-22 over 1e5): below the standard error of every figure above from T/200
  to T/8 (0.7 of one at T/200 with 65536 copies), and the whole of the T/1000 one. Since
  2026-11-23 the energies are evaluated exactly (:func:`emorbit.analysis.relative_energy_change_exact`);
  T/1000, 4096 copies, 1e6 steps, seeds 0-15, CPU: a mean of -4.7e-23 per step, z -2.5 (the
  H100's -7.4e-23 less the offset: -0.7e-23, z -0.4); with the increments carried to eps**2
  (a throw-away build, 19 against 14.5 ns per particle-step) +0.8e-23, z +0.55. A drift of
  a few 1e-23 per step, if it is there, overtakes the random walk after about 1e10 steps.

Tried for speed and dropped: the last update's ``F`` with only ``D`` carried (``Q``, ``Y``
and the products plain, an error of a few hundredths of a rounding of ``r1`` at t = 1/128):
12.6 instead of 15.4 ns per particle-step on the benchmark ensemble, within 1.7 standard
errors at T/8, T/20, T/100 (two seeds), but +2.1e-21 per step at T/60 (+8.5) and +6.7e-22
at T/200 (+7.0). Every O(t) term of ``F`` has to be carried. With the one-update step
(2026-11-23): choosing per point, before the update, between one accurate Newton update and
the old Newton + accurate chord pair from a bound on the predictor's error (``s u**2.5``,
``u = p**2 + v + s``: measured to exceed the error by a factor 2.3 at least) cost 1.5 ns per
particle-step in the packed pass even where every point took one update; the predictor and
the update in one loop instead of two, 16.4 instead of 13.7 ns.

The one-point reference kernel of :mod:`.pointmass`, which finishes every step, drifted by
+6.6e-21 at T/100 (4096 copies on the CPU, 2e5 steps, 4.8 standard errors); after the
first fix above, -1.8e-21 (1.4). Not from the rounding of the increments: with ``u`` and
``dx`` rounded once (fused) or ``dx`` compensated the T/100 drift of the old threshold stayed
(+5.7e-22 to +6.5e-22; ``scripts/gpu_drift_increments.py``).

``F Q**2`` in its first form, ``(r1 Qp)**2 - (Qm (A Qm - 2 P Q) + V Q**2)``, loses a rounding
of ``(r1 Qp)**2`` to the cancellation; carrying only the rounding errors of ``A``, ``P``,
``V``, ``tau`` or ``|a|`` into it changed nothing (+5.5 to +6.2e-20). Cost, measured on the
development machine for the benchmark ensemble (T/1000) on one thread: 11.5 ns per
particle-step with the certified update (14.5 with the accurate update and the low parts of
A and P, 14.5-16.4 ns with the two updates before 2026-11-23) against 9.3 ns with
roundoff="fast" and about 22 ns with the reference kernel's finish in every step, as this
kernel did before; with the helpers' fused multiply-adds (2026-11-23, fourth session) 10.6
against 8.7 ns, and 10.2 after the two changes of that session that kept the bits. With roundoff="fast" (``METHOD_EM_PLAIN``) the iteration stops after
Newton + chord on the plain ``F``, uncertified.

The implicit midpoint step reduces the same way: ``m = a - dx/2`` (the centre seen from the
midpoint) has ``|m| (1 + t/2) = |a - h/2 v0|`` with ``t = tau / |m|**3``, a cubic in
``|m|`` solved by two Newton updates from ``|a - h/2 v0|`` (the first leaves O(h**4)), and
``g = w (a - h/2 v0)`` with ``w = GM / (|m|**3 + tau/2)``.

What the reference kernel's notes ask of a step, and how it holds here:

* No rounded ``h**2/2`` multiplies gravity in the position but not in the velocity (an
  energy error ``-eps h**2/2 |g|**2`` of one sign in every step: a drift). ``dx`` and ``dv``
  come from the same ``g`` in the form ``dx = h (v0 + h/2 g)``, whose roundings depend on
  the state, and ``tau`` is carried as an unevaluated sum ``hi + lo`` exact to eps**2 (it
  sets the size of ``g``; measured: computing ``dx`` from ``t = tau/Q`` instead, with tau
  rounded once, drifted by 1.5-3.4e-13 in 2e5 steps of the paper's orbit, all of one sign;
  this form stays at 0.5-4e-14 of both signs, as the reference kernel does).
* The velocity uses ``g_em`` at the final ``dx``: no further evaluation of gravity is needed
  (``g`` is exact for the solved ``r1``; the reference kernel linearises ``g_em`` at its
  final iterate, or with its finish evaluates it accurately, for the same purpose).

Layout and passes
-----------------
Points are processed in blocks of :data:`BLOCK`; a block's state lives in a small work
array ``W`` for the whole chunk (in the L1/L2 cache while every step of the chunk is
taken). ``W`` is one-dimensional, row ``r`` at ``r * LD``, and every row offset used in a
packed loop is a compile-time constant, so LLVM knows the distance between any two rows and
vectorises without run-time alias checks (loops that read or write the state are inlined at
the Numba level with constant buffer offsets, see ``_inline``). Each sub-step is a few
short loops ("passes"): short dependency chains and few live values per loop let the
out-of-order core overlap many points (measured on the development machine: the solve as
two loops instead of four made the step 20 % slower). The state lives in two buffers; a
sub-step reads one and writes the other, every point unconditionally (a "store if" would
become a masked store, microcoded and slow on AMD processors); a scalar pass, run only when
a point failed or is dead, puts the old state back. Blocks of fewer than :data:`_PACKED_MIN`
points (a single orbit) take each point through the same helpers one by one.

A new state that is not finite fails its step (STATUS_SINGULAR, the state from before the
step kept), as in the reference kernel. em tests it after the step instead of in its
update loop, where the count cost 0.3-0.9 ns per particle-step (benchmark ensemble, one
thread; as much in a loop of its own): such a state makes ``A`` or ``V`` inf or nan, which
the certified update never accepts, so the point reaches the scalar pass of the next
sub-step, which finds its state not finite and fails it at the step before (its old state is
still in the other buffer; within a composed step, at its own step, whose start is kept in
``_BK``); the last sub-step of a composed step (orders 4-8) counts in its update as before,
and at the end of each record a check of the block catches the record's last step (once per
record). Same bits and failure reports as the count in the update; on the benchmark
ensemble (1e5 points, calls of 40 steps, the builds alternated in one process, medians of 60)
one thread 10.02 -> 9.71 ns per particle-step, all threads 5.58 -> 5.40 in a quiet spell and
no difference in a busy one (2026-11-23, seventh session). Such states are rare: in a search
over 200,000 steps from random states (distances 1e-200 to 1e200 m, steps 1e-200 to 1e100 s,
GM 1e-300 to 1e300), none of the 8,321 that the packed solve accepted left a state that was
not finite; the test makes one with a position compensation of half a unit in the last place
of the largest double.

Counted per em point and sub-step on the packed path (the bench derives the bound from
division and square-root throughput from these): :data:`EM_PLAIN_SQRTS` square roots
(``|a|``, the predictor's ``r1``) and :data:`EM_PLAIN_DIVISIONS` divisions (``1/|a|``, the
Newton update, ``w``); the default em counts the same (:data:`EM_SQRTS`,
:data:`EM_DIVISIONS`): its certified Newton update has the one division (the steps
finished by the reference kernel's finish, t > 1/128, are not counted).

One work array serves a whole range of blocks (:func:`_work_array`); on all threads
(:func:`ensemble_chunk_parallel`) each thread claims up to :data:`_GRAIN` blocks at a time
from a shared atomic counter (:mod:`.atomic`) instead of a fixed half of them, so a thread
slowed by other work on its core does not hold up the others. Both changed no bit; on the
benchmark ensemble (1e5 points, T/1000, development machine, the builds alternated in one
process, 2026-11-23) one thread went from 10.65 to 10.30 ns per particle-step in calls of
40 steps (15.65 to 14.23 in calls of 5), both threads from 4.87 to 4.73 ns in a quiet
hour (two medians of 20 calls of 64 steps each, averaged) and from 6.30 to 5.70 in a busy
one. Blocks of 96 or 128 points were no faster with it (one thread: 11.0-11.5 and
11.3-11.5 against 10.7-11.2 ns).

Each method has its own compiled entry kernels (``_range_em``, ``_points_em`` for fewer
than :data:`_PACKED_MIN` points, ``_parallel_em``, and the same for midpoint and leapfrog),
in which the method is a constant, so a run compiles only its method's code. A range's last
block, when too small to pack, goes to the method's ``_points_*`` kernel as a call (until
2026-11-23, seventh session, the point-by-point step was inlined into the range kernel a
second time): the one-orbit path and the packed path share that compiled kernel, and an
empty Numba cache compiled the ensemble kernels of em, em roundoff="fast" and leapfrog (one
thread and all threads) in 81 s instead of 97 s (development machine, one process).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from ..atomic import fetch_add
from ..codes import METHOD_EM, METHOD_EM_PLAIN, METHOD_LEAPFROG, METHOD_MIDPOINT, STATUS_OK, STATUS_SINGULAR
from ..eft import fma, two_prod, two_prod_dekker, two_sum
from ..eft import kahan_add as _kahan
from ..gravity import accel
from ..jit import kernel
from .reference import em_finish, em_step, midpoint_step

__all__ = [
    "BLOCK",
    "EM_DIVISIONS",
    "EM_PLAIN_DIVISIONS",
    "EM_PLAIN_SQRTS",
    "EM_SQRTS",
    "LEAPFROG_DIVISIONS",
    "LEAPFROG_SQRTS",
    "METHOD_EM",
    "METHOD_EM_PLAIN",
    "METHOD_LEAPFROG",
    "METHOD_MIDPOINT",
    "PARALLEL_MIN",
    "ensemble_chunk",
    "ensemble_chunk_parallel",
]


#: points per block
BLOCK = 64
#: row length of the work array: a multiple of 8 (rows start on 64-byte boundaries, so no
#: packed load splits a cache line) and not of 512 (rows do not share their low twelve
#: address bits: 4K aliasing would stall loads behind unrelated stores)
LD = BLOCK + 8
#: smaller blocks go point by point (same helpers, same bits)
_PACKED_MIN = 4
#: from this many points on, PointMasses.advance runs ensemble_chunk_parallel
PARALLEL_MIN = 1024
#: the most blocks a thread claims at a time in a parallel run (see :mod:`.atomic`)
_GRAIN = 8

#: square roots and divisions per em point and sub-step on the packed path: |a| and the
#: predictor's root; the predictor's 1 / |a|, the Newton update's and w's (the fast step's
#: chord update and the default's certificate need none)
EM_SQRTS = 2
EM_DIVISIONS = 3
#: the same for em with roundoff="fast"
EM_PLAIN_SQRTS = 2
EM_PLAIN_DIVISIONS = 3
#: the same for leapfrog (|r| and GM / r**3 at the new position)
LEAPFROG_SQRTS = 1
LEAPFROG_DIVISIONS = 1

#: midpoint: accept a Newton update |delta| <= 2**-26 |m| (the next is below eps |m| / 2)
_ACCEPT2 = 2.0**-52
#: em: accept a Newton-chord pair |delta1 delta2| <= 2**-56 r1**2 (error ~ 4 |d1 d2| / r1)
_ACCEPT3 = 2.0**-56
#: em (roundoff="brouwer"): a Newton update d1 on the accurate F leaves about d1**2 / (2 r1):
#: |d1| <= 2**-32.5 r1 leaves below 2**-66 r1
_ACCEPT_NEWTON = 2.0**-65
#: ... and only where both updates are below r1 / 64 (a Newton update that ran off to a far
#: or negative r1 can leave a chord update tiny against that r1: at T/20 near pericentre
#: one went to -4907 from 1.7 and the chord to 1.8e23, "converged")
_SMALL = 2.0**-6
#: em (roundoff="brouwer"): steps with t = tau / Q above 1/128 (t / (1 + t) = tau w / GM above
#: 1/129) are finished by pointmass.em_finish (see the module notes; 1/32 left a drift of
#: up to 1e-20 |E| per step from T/20 to T/100)
_BIG_T = 1.0 / 129.0
#: the unit roundoff of float64
_U = 2.0**-53

# rows of the work array
_NS = 15  # rows of a state buffer:
_OX0, _OX1, _OX2 = 0 * LD, 1 * LD, 2 * LD  # position
_OV0, _OV1, _OV2 = 3 * LD, 4 * LD, 5 * LD  # velocity
_OCX0, _OCX1, _OCX2 = 6 * LD, 7 * LD, 8 * LD  # compensation of the position
_OCV0, _OCV1, _OCV2 = 9 * LD, 10 * LD, 11 * LD  # compensation of the velocity
_OG0, _OG1, _OG2 = 12 * LD, 13 * LD, 14 * LD  # leapfrog: acceleration at the state
_BUF0 = 0 * LD  # state buffer 0
_BUF1 = 15 * LD  # state buffer 1
_BK = 30 * LD  # the state at the start of a composed step (orders 4-8)
_R0 = 45 * LD  # |a| (em)
_RHO = 46 * LD  # the unknown: r1 (em) or |m| (midpoint)
_AA = 47 * LD  # a.a (em); |a - h/2 v0| (midpoint)
_PP = 48 * LD  # h a.v0
_VV = 49 * LD  # h**2 v0.v0
_DEL = 50 * LD  # last Newton update
_PEND = 51 * LD  # 1 where the packed solve was not accepted
_ST = 52 * LD  # failure code of the current step (0: none)
_EXTRA = 53 * LD  # Newton iterations beyond the packed ones, in the current record interval
_ALIVE = 54 * LD  # 1 until the point fails
_WG = 55 * LD  # w, the size of gravity over the step (g = w (ua a - uv v0))
_QG = 56 * LD  # Q / (F' Q**3) of the Newton update, reused by the chord update (fast em)
_NROWS = 57

#: Newton iterations every packed point does per sub-step (fast em: Newton + chord;
#: midpoint: 2 Newton; leapfrog: none; the default em does one, see _packed_iters)
_PACKED_ITERS = 2

_inline = kernel(inline="always")


# ----------------------------------------------------------------------------------------
# scalar pieces: every point goes through these, packed or alone


@kernel
def _packed_iters(method):
    if method == METHOD_LEAPFROG:
        return 0
    return 1 if method == METHOD_EM else _PACKED_ITERS


@kernel
def _kahan3(s0, s1, s2, c0, c1, c2, d0, d1, d2):
    """Compensated sums s + d of a 3-vector with compensations c: (t0, t1, t2, e0, e1, e2)."""
    t0, e0 = _kahan(s0, c0, d0)
    t1, e1 = _kahan(s1, c1, d1)
    t2, e2 = _kahan(s2, c2, d2)
    return t0, t1, t2, e0, e1, e2


@kernel
def _store_state(W, D, i, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2):
    """Point i's position, velocity and their compensations into buffer D."""
    W[D + _OX0 + i] = t0
    W[D + _OX1 + i] = t1
    W[D + _OX2 + i] = t2
    W[D + _OV0 + i] = u0
    W[D + _OV1 + i] = u1
    W[D + _OV2 + i] = u2
    W[D + _OCX0 + i] = e0
    W[D + _OCX1 + i] = e1
    W[D + _OCX2 + i] = e2
    W[D + _OCV0 + i] = f0
    W[D + _OCV1 + i] = f1
    W[D + _OCV2 + i] = f2


@kernel
def _tau(h, gm):
    """h**2/2 GM as a sum hi + lo, exact to about eps**2.

    A rounded h**2/2 that multiplies gravity in the position but not in the velocity would
    give the energy an error -eps h**2/2 |g|**2 of one sign in every step (see
    pointmass.py); carrying the rounding error lo makes that eps**2."""
    p, e = two_prod_dekker(h, h)
    q, f = two_prod_dekker(p, gm)
    lo = f + e * gm
    hi = q + lo
    return 0.5 * hi, 0.5 * (lo - (hi - q))


@kernel
def _finite6(a, b, c, d, e, f):
    """All six finite (as pointmass._finite: a sum of finite values overflows only far
    beyond any state)."""
    return abs(a + b + c + d + e + f) < math.inf


@kernel
def _finite3(a, b, c):
    return abs(a + b + c) < math.inf


@kernel
def _em_dots(ax, ay, az, vx, vy, vz, h):
    """a.a, h a.v0, h**2 v0.v0 and |a| (the step enters the equations only in these forms).
    (``h (h v0.v0)``: a rounded ``h*h`` would carry the same relative error in every step.)"""
    A = fma(ax, ax, fma(ay, ay, az * az))
    return A, h * fma(ax, vx, fma(ay, vy, az * vz)), h * (h * fma(vx, vx, fma(vy, vy, vz * vz))), math.sqrt(A)


@kernel
def _em_predict(A, P, V, r0, h, gm):
    """r1 of the em step predicted from its own equations, P = h a.v0, V = h**2 v0.v0.

    With W = h**2 w (g_em = w (2 a - h v0)) the step gives exactly
    r1**2 = (1 - W)**2 A - 2 (1 - W)(1 - W/2) P + (1 - W/2)**2 V, and W = h**2 GM / (Q + tau)
    depends on r1 through Q = r0 r1 (r0 + r1). Solved as a series in p = P / A ~ h,
    v = V / A ~ h**2 and s = tau / r0**3 ~ h**2 (tau = h**2/2 GM), to fourth order::

        W / s = 1 + 3/2 p + 5/2 p**2 + 35/8 p**3 + 63/8 p**4
                  + s (1 + 7/2 p + 79/8 p**2 + 2 s - 17/8 v) - v (3/4 + 5/2 p + 105/16 p**2 - 5/8 v)

    (the p-only terms are the expansion of 2 / (y (1 + y)), y = sqrt(1 - 2 p)). r1 is then
    wrong by O(h**7) of r0 (the first term left out is s times a fifth-order one) instead of
    O(h**4) with W to first order (tests/test_ensemble.py measures both orders); on the
    paper's orbit at T/100 the largest relative error 4.5e-5 instead of 3.8e-3 (at T/1000
    below 5e-12; a few more multiply-adds per step), so that one Newton update finishes most
    steps (see the module notes). The polynomials are evaluated by Horner's rule with fused
    multiply-adds (:func:`.eft.fma`), as are the dot products (:func:`_em_dots`), the
    derivative (:func:`_em_g3`), the certificate's bound and the increments: on the
    benchmark ensemble (20,000 particles, T/1000, one thread, fastest of 15 runs of 100 steps,
    the builds alternated in one process) 10.6 instead of 11.9 ns per particle-step, and
    8.7 instead of 9.1 ns with roundoff="fast" (development machine, 2026-11-23). ``F Q**2``
    itself stays unfused (:func:`_em_f2`): fused it saved nothing measurable (10.9 ns), and
    the certificate's error analysis is written for its plain operations."""
    ir = 1.0 / r0
    ir2 = ir * ir
    s = (0.5 * h) * (h * (gm * (ir2 * ir)))
    p = P * ir2
    v = V * ir2
    t1 = fma(p, fma(p, fma(p, fma(p, 7.875, 4.375), 2.5), 1.5), 1.0)
    t2 = fma(p, fma(p, 9.875, 3.5), fma(-2.125, v, fma(2.0, s, 1.0)))
    t3 = fma(p, fma(p, 6.5625, 2.5), fma(-0.625, v, 0.75))
    W = s * (t1 + fma(s, t2, -v * t3))
    c = 1.0 - W
    b = fma(-0.5, W, 1.0)
    return math.sqrt(fma(c * c, A, fma(-2.0 * (c * b), P, (b * b) * V)))


@kernel
def _em_predict_taylor(A, P, V, r0, h, gm):
    """r1 of the explicit Taylor step with the jerk (roundoff="fast"): :func:`_em_predict`
    with W to first order, W = h**2/2 GM / r0**3 (1 + 3/2 P / A) for the ``a`` term and
    h**2/2 GM / r0**3 for the ``v0`` term, an error in r1 of O(h**4). At T/1000 it is
    accurate enough for the fast step's looser check (error below 5e-7 r1 on the paper's
    orbit), and its 22 fewer operations per point keep the fast ensemble step at 8.6 instead
    of 9.9 ns per particle-step (development machine, one thread, 20,000 particles of the
    benchmark ensemble, fastest of five runs)."""
    ir = 1.0 / r0
    ir2 = ir * ir
    f = gm * ir2 * ir
    hf = 0.5 * h
    alpha = ((h * hf) * f) * (1.0 + 1.5 * P * ir2)
    b = 1.0 - hf * (hf * f)
    c = 1.0 - alpha
    return math.sqrt((c * c) * A - 2.0 * (c * b) * P + (b * b) * V)


@_inline
def _em_f2_terms(A, P, V, rho, Q, tau0, tlo):
    """:func:`_em_f2` and what its error bound needs: (F Q**2, rho**2 rounded, D, Q**2)."""
    p, e = two_prod(rho, rho)
    D = (((p - A) + (P + P)) - V) + e
    X = Q * ((p + A) - P)
    Q2 = Q * Q
    return Q2 * D + (((tau0 + tau0) * X + (tlo + tlo) * X) + (tau0 * tau0) * (p - A)), p, D, Q2


@_inline
def _em_newton_certified(A, P, V, r0, rho, tau0, tlo):
    """A Newton update of r1 on the plainly evaluated F, and whether its result is certified
    to be the exact root correctly rounded: (r1_new, delta, certified).

    The exact root lies within ``E / 2`` of the real number ``rho - delta``, so between
    ``rho - b`` and ``rho - a`` with the doubles ``a = fl(delta - E)``, ``b = fl(delta + E)``
    (their roundings, below ``u (|delta| + E)``, fit in the other half of ``E``, which is at
    least ``128 u |delta|``). Rounding is monotonic: where ``fl(rho - a) == fl(rho - b)``,
    every real number between rounds to that double, the root and ``rho - delta``
    included, so ``r1_new = fl(rho - delta)`` is then the exact root correctly rounded,
    the double the accurate update (:func:`_em_newton_accurate`) lands on, at about a third
    of its extra operations. (Until 2026-11-23, fourth session, the same test took the
    rounding error of ``rho - delta`` from a two-sum and added ``+-E`` to it: 7 operations
    more, the same verdict up to the slack.) ``E`` adds up, each taken at least twice:

    * F's rounding, ``B |Q / (F' Q**3)|`` with ``B`` twice a first-order bound (unit
      roundoff u = 2**-53) on the error of ``F Q**2`` as :func:`_em_f2` evaluates it:
      ``2 u (Q**2 (12 |D| + V) + tau0 (24 Q + 5 tau0) (rho**2 + A + |P|) + |F Q**2|)``. Term
      by term: ``rho**2 - A`` is exact (Sterbenz: certified only where ``A/2 <= rho**2 <=
      2 A``), D's two further sums err by u of results below ``|D| + V``, D itself by u;
      ``Q`` carries 3 roundings, so ``Q**2 D`` 8 u of itself; ``Y = rho**2 + A - P`` errs by
      u of ``rho**2 + A`` and of itself and by the low part of rho**2 it omits, ``X = Q Y``
      by 4 u more, ``2 tau0 X`` and the sums after it by 14 u of ``tau0 |X|`` in all;
      ``tau0**2 (rho**2 - A)``, with the dropped ``2 tau0 tlo`` and low part of rho**2, 5 u of
      ``tau0**2 (rho**2 + A)``; the last sum u of ``|F Q**2|``.
    * the derivative's rounding (relative, below 20 u for t <= 1/8): 64 u of ``|delta|``;
    * Newton's remainder ``F'' / (2 F') delta**2`` with ``F'' <= 3`` and ``1 / F' = |Q**2 Q / (F' Q**3)|``:
      ``4 delta**2 Q**2 |Q / (F' Q**3)|`` (no division).

    ``E`` is about 25 t of a unit in the last place plus the remainder, so at T/1000 of the
    benchmark ensemble 99.5 % of the steps are certified (measured on 100,000 states); the
    others take the accurate update in the scalar pass. Steps with t > 1/128 are finished by
    :func:`~.pointmass.em_finish` whatever this returns."""
    g3, Q = _em_g3(A, P, r0, rho, tau0)
    f2, p, D, Q2 = _em_f2_terms(A, P, V, rho, Q, tau0, tlo)
    qg = Q / g3
    delta = f2 * qg
    B = fma(Q2, fma(12.0, abs(D), V), tau0 * fma(24.0, Q, 5.0 * tau0) * ((p + A) + abs(P))) + abs(f2)
    E = fma(2.0 * abs(qg), fma(2.0 * _U, B, 4.0 * ((delta * delta) * Q2)), (128.0 * _U) * abs(delta))
    return rho - delta, delta, ((rho - (delta - E)) == (rho - (delta + E))) & (p <= A + A) & (A <= p + p)


@kernel
def _em_f2(A, P, V, rho, Q, tau0, tlo):
    """F Q**2 at r1 = rho, for Q = r0 rho (r0 + rho) (A = a.a, P = h a.v0, V = h**2 v0.v0 as
    :func:`_em_dots` rounds them; tau = tau0 + tlo)::

        F Q**2 = (rho Qp)**2 - (Qm (A Qm - 2 P Q) + V Q**2)        (Qp, Qm = Q +- tau)
               = Q**2 D + 2 tau Q (rho**2 + A - P) + tau**2 (rho**2 - A),
        D = rho**2 - A + 2 P - V = rho**2 - |a - h v0|**2

    The second form keeps the cancellation in D, which is evaluated to within a rounding of
    D (rho**2 - A is exact once rho**2 is split); the first lost a rounding of (rho Qp)**2 to
    it, and Newton converged on that error: the root it picked was correlated with it and the
    energy drifted (see the module notes)."""
    return _em_f2_terms(A, P, V, rho, Q, tau0, tlo)[0]


@_inline
def _em_f2_accurate(A, P, V, r0, rho, tau0, tlo):
    """F Q**2 at r1 = rho as :func:`_em_f2`, with every rounding of a quantity that depends
    on rho carried (error-free transformations) to well below eps r1**2 Q**2: Q, rho**2, D,
    Q**2 D, Q (rho**2 + A - P) and the products with tau. (A, P and V, which do not depend on
    rho, keep the roundings of :func:`_em_dots`: an error of the data, the same whatever rho
    the iteration tries, so nothing it can converge on; until 2026-11-23 their rounding
    errors were carried too, see the module notes. tau**2 (rho**2 - A) is O(t**2) of the
    rest.)"""
    q, eq = two_prod(r0, rho)
    s, es = two_sum(r0, rho)
    Q, eQ = two_prod(q, s)
    Ql = eQ + (q * es + eq * s)
    Q2, eQ2 = two_prod(Q, Q)
    Q2l = eQ2 + 2.0 * (Q * Ql)
    p, e = two_prod(rho, rho)
    D1 = p - A  # exact near the root
    D2, eD2 = two_sum(D1, P + P)
    D3, eD3 = two_sum(D2, -V)
    Dl = (eD2 + eD3) + e
    T1, eT1 = two_prod(Q2, D3)
    T1l = eT1 + (Q2 * Dl + Q2l * D3)
    Y1, eY1 = two_sum(p, A)
    Y2, eY2 = two_sum(Y1, -P)
    Yl = (eY1 + eY2) + e
    X, eX = two_prod(Q, Y2)
    Xl = eX + (Q * Yl + Ql * Y2)
    T2, eT2 = two_prod(tau0 + tau0, X)
    T2l = eT2 + ((tau0 + tau0) * Xl + (tlo + tlo) * X)
    F, eF = two_sum(T1, T2)
    return F + ((eF + (T1l + T2l)) + (tau0 * tau0) * D1)


@_inline
def _em_g3(A, P, r0, rho, tau0):
    """F' Q**3 at r1 = rho, and Q = r0 rho (r0 + rho), in plain floating point:
    F' Q**3 = 2 rho Qp**2 Q - 2 tau0 r0 (r0 + 2 rho) (rho**2 Qp + A Qm - P Q)."""
    s = r0 + rho
    Q = r0 * rho * s
    Qp = Q + tau0
    rq = rho * Qp
    g = fma(-(tau0 * r0) * (s + rho), fma(rho, rq, fma(A, Q - tau0, -P * Q)), rq * Qp * Q)
    return g + g, Q


@kernel
def _em_fg(A, P, V, r0, rho, tau0, tlo):
    """F Q**2 (:func:`_em_f2`) and F' Q**3 (:func:`_em_g3`) at r1 = rho, and Q."""
    g3, Q = _em_g3(A, P, r0, rho, tau0)
    return _em_f2(A, P, V, rho, Q, tau0, tlo), g3, Q


@kernel
def _em_newton(A, P, V, r0, rho, tau0, tlo):
    """A Newton update of r1: (r1_new, delta, Q / (F' Q**3))."""
    f2, g3, Q = _em_fg(A, P, V, r0, rho, tau0, tlo)
    qg = Q / g3
    delta = f2 * qg
    return rho - delta, delta, qg


@kernel
def _em_newton_accurate(A, P, V, r0, rho, tau0, tlo):
    """A Newton update of r1 on the accurate F (:func:`_em_f2_accurate`; the derivative
    in plain floating point, :func:`_em_g3`: its rounding changes the update by a few eps of
    itself): (r1_new, delta). Only the scalar pass takes it (the steps whose certified update
    is not certified), so it is one compiled function, not inlined: inlined in its two uses
    there the first compile of an em run took 16.1-16.5 s instead of 13.7-16.1 s (measured
    when every step took it)."""
    g3, Q = _em_g3(A, P, r0, rho, tau0)
    delta = _em_f2_accurate(A, P, V, r0, rho, tau0, tlo) * (Q / g3)
    return rho - delta, delta


@kernel
def _em_chord(A, P, V, r0, rho, tau0, tlo, qg):
    """A chord update of r1 with the previous Newton update's derivative: (r1_new, delta).
    (F Q1**2 times Q0 / (F'(r1_0) Q0**3): Q1 taken for Q0, a relative 3 |delta1| / r1 of delta.)"""
    delta = _em_f2(A, P, V, rho, r0 * rho * (r0 + rho), tau0, tlo) * qg
    return rho - delta, delta


@kernel
def _em_small(d1, d2, rho):
    """Both updates below r1 / 64, so that the error estimates from them mean something."""
    return (abs(d1) <= _SMALL * rho) & (abs(d2) <= _SMALL * rho)


@kernel
def _em_plausible(rho, A, V):
    """Whether r1 = rho can be the step's: 0 < r1 and r1**2 <= 18 A + 2 V. (dx = (h v0 + 2 t a)
    / (1 + t) with t > 0, so |dx| <= |h v0| + 2 |a| and r1 = |a - dx| <= 3 r0 + sqrt(V).)
    Every such root of F Q**2 (Q > 0) is a root of F, a solution of the step's equations,
    which conserves the energy; far off or negative values are not (a NaN is neither)."""
    return (rho > 0.0) & (rho * rho <= 18.0 * A + 2.0 * V)


@kernel
def _em_ok(d1, d2, rho, A, V):
    return (abs(d1 * d2) <= _ACCEPT3 * (rho * rho)) & _em_small(d1, d2, rho) & _em_plausible(rho, A, V)


@kernel
def _em_ok_newton(d1, rho, A, V):
    """After a Newton update d1 on the accurate F (default em, packed and scalar pass):
    Newton leaves about |F''/(2 F')| d1**2 ~ d1**2 / (2 r1), so |d1| <= 2**-32.5 r1 leaves
    below 2**-66 r1, a ten-thousandth of a rounding. The root is then that of the accurate F,
    with no one-sided remainder of the iteration left in it."""
    return (d1 * d1 <= _ACCEPT_NEWTON * (rho * rho)) & _em_small(d1, d1, rho) & _em_plausible(rho, A, V)


@kernel
def _em_w(r0, rho, gm, tau0, tlo):
    """GM / (Q + tau) at r1 = rho (tau = tau0 + tlo = h**2/2 GM): g_em = w (2 a - h v0)."""
    Q = r0 * rho * (r0 + rho)
    return gm / ((Q + tau0) + tlo)


@kernel
def _increments(ax, ay, az, vx, vy, vz, w, ua, uv, h):
    """g = w (ua a - uv v0), then dx = h v0 + h (h/2 w) u and dv = (h w) u with u = ua a - uv v0:
    the reference kernel's form dx = h (v0 + h/2 g), dv = h g (no rounded h**2/2: the two
    coefficients are rounded afresh from each step's w). ``u`` and ``dx`` take one fused
    multiply-add each (one rounding instead of two; part of the 1.3 ns per particle-step the
    fused multiply-adds of the em helpers saved, see :func:`_em_predict`)."""
    cx = h * ((0.5 * h) * w)
    cv = h * w
    ux = fma(ua, ax, -uv * vx)
    uy = fma(ua, ay, -uv * vy)
    uz = fma(ua, az, -uv * vz)
    return fma(cx, ux, h * vx), fma(cx, uy, h * vy), fma(cx, uz, h * vz), cv * ux, cv * uy, cv * uz


@kernel
def _em_big_t(w, gm, tau0):
    """Whether a step's t = tau / Q exceeds 1/128 (w = GM / (Q + tau))."""
    return tau0 * w > _BIG_T * gm


@kernel
def _em_finished(ax, ay, az, vx, vy, vz, w, r0, h, gm):
    """An em step with a large t: the increments from w, finished as the reference kernel
    finishes (:func:`~.pointmass.em_finish`)."""
    d0, d1, d2, w0, w1, w2 = _increments(ax, ay, az, vx, vy, vz, w, 2.0, h, h)
    d0, d1, d2, g0, g1, g2 = em_finish(ax, ay, az, r0, vx, vy, vz, d0, d1, d2, h, gm)
    return d0, d1, d2, h * g0, h * g1, h * g2


@kernel
def _mid_start(ax, ay, az, vx, vy, vz, h):
    """Midpoint: |a - h/2 v0|, the starting value of |m|."""
    hf = 0.5 * h
    mx = ax - hf * vx
    my = ay - hf * vy
    mz = az - hf * vz
    return math.sqrt(mx * mx + my * my + mz * mz)


@kernel
def _mid_newton(m0, mu, tau0):
    """A Newton update of mu = |m| on mu**3 - m0 mu**2 + tau0 / 2 = 0: (mu_new, delta)."""
    g = mu * mu * (mu - m0) + 0.5 * tau0
    d = mu * (3.0 * mu - 2.0 * m0)
    delta = g / d
    return mu - delta, delta


@kernel
def _mid_ok(delta, mu):
    return (delta * delta <= _ACCEPT2 * (mu * mu)) & (mu > 0.0) & (mu < math.inf)


@kernel
def _mid_w(mu, gm, tau0, tlo):
    """GM / (mu**3 + tau / 2) at |m| = mu: g = w (a - h/2 v0)."""
    return gm / ((mu * mu * mu + 0.5 * tau0) + 0.5 * tlo)


@kernel
def _resolve_plausible(method, rho, A, V):
    """em: :func:`_em_plausible`; midpoint (``A`` = |a - h/2 v0|): finite and positive."""
    if method == METHOD_MIDPOINT:
        return rho > 0.0 and rho < math.inf
    return _em_plausible(rho, A, V)


@_inline
def _resolve_point(method, A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter):
    """Finish a point whose packed solve was not accepted: more Newton updates of the
    scalar unknown; if that misbehaves (leaves the range of :func:`_resolve_plausible`,
    stops shrinking, runs out of iterations), the reference kernel's Newton on 3-vectors.
    ``A`` is |a - h/2 v0| for the midpoint. em (roundoff="brouwer") takes certified
    updates (:func:`_em_newton_certified`) until one is certified, or, once an update left
    no remainder (``prev`` below 2**-32.5 r1) but its rounding was not certified, one
    update on the accurate F, accepted as :func:`_em_ok_newton` says; after the reference
    kernel's Newton it takes one more update on the accurate F, so that no remainder of the
    iteration is left. Returns (r0, unknown, extra iterations, status)."""
    packed = _packed_iters(method)
    it = packed
    while it < max_iter and _resolve_plausible(method, rho, A, V):
        if method == METHOD_EM:
            if prev * prev <= _ACCEPT_NEWTON * (rho * rho):
                # the last update left no remainder, only its rounding was not certified:
                # the accurate update decides it
                rho, delta = _em_newton_accurate(A, P, V, r0, rho, tau0, tlo)
                it += 1
                if _em_ok_newton(delta, rho, A, V):
                    return r0, rho, it - packed, STATUS_OK
            else:
                rho, delta, cert = _em_newton_certified(A, P, V, r0, rho, tau0, tlo)
                it += 1
                if cert & _em_plausible(rho, A, V):
                    return r0, rho, it - packed, STATUS_OK
        else:
            if method == METHOD_EM_PLAIN:
                rho, delta, qg = _em_newton(A, P, V, r0, rho, tau0, tlo)
            else:
                rho, delta = _mid_newton(A, rho, tau0)
            it += 1
            if _mid_ok(delta, rho) and _resolve_plausible(method, rho, A, V):
                return r0, rho, it - packed, STATUS_OK
        if not abs(delta) < prev:
            break
        prev = abs(delta)
    extra = it - packed
    # the reference kernel's Newton on 3-vectors, from its own predictor
    if method != METHOD_MIDPOINT:  # only its r1 is used: the caller finishes the step
        d0, d1, d2, w0, w1, w2, its, status = em_step(px, py, pz, vx, vy, vz, h, gm, c0, c1, c2, max_iter, False)
    else:
        d0, d1, d2, w0, w1, w2, its, status = midpoint_step(px, py, pz, vx, vy, vz, h, gm, c0, c1, c2, max_iter)
    extra += its
    ax = c0 - px
    ay = c1 - py
    az = c2 - pz
    if method != METHOD_MIDPOINT:
        bx = ax - d0
        by = ay - d1
        bz = az - d2
        r0 = math.sqrt(ax * ax + ay * ay + az * az)
        rho = math.sqrt(bx * bx + by * by + bz * bz)
        if method == METHOD_EM and status == STATUS_OK and _em_plausible(rho, A, V):
            rho, delta = _em_newton_accurate(A, P, V, r0, rho, tau0, tlo)
            extra += 1
    else:
        mx = ax - 0.5 * d0
        my = ay - 0.5 * d1
        mz = az - 0.5 * d2
        rho = math.sqrt(mx * mx + my * my + mz * mz)
    if status == STATUS_OK and not _resolve_plausible(method, rho, A, V):
        status = STATUS_SINGULAR
    return r0, rho, extra, status


# the scalar path calls these (rarely taken) instead of inlining them with the rest of its
# step, which keeps its compile time down; one per method, so a run compiles only its own


@kernel
def _resolve_point_em(A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter):
    return _resolve_point(
        METHOD_EM, A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter
    )


@kernel
def _resolve_point_em_plain(A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter):
    return _resolve_point(
        METHOD_EM_PLAIN, A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter
    )


@kernel
def _resolve_point_mid(A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter):
    return _resolve_point(
        METHOD_MIDPOINT, A, P, V, r0, rho, prev, h, gm, tau0, tlo, px, py, pz, vx, vy, vz, c0, c1, c2, max_iter
    )


@_inline
def _implicit_point_impl(
    method, x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter
):
    """One em or midpoint sub-step of one point, through the same helpers as the packed
    passes. Returns the 12 new state values, extra iterations and status."""
    ax = c0 - x0
    ay = c1 - x1
    az = c2 - x2
    if method != METHOD_MIDPOINT:
        A, P, V, r0 = _em_dots(ax, ay, az, y0, y1, y2, h)
        if method == METHOD_EM:
            rho = _em_predict(A, P, V, r0, h, gm)
            rho, delta, cert = _em_newton_certified(A, P, V, r0, rho, tau0, tlo)
            ok = cert & _em_plausible(rho, A, V)
        else:
            rho = _em_predict_taylor(A, P, V, r0, h, gm)
            rho, d1, qg = _em_newton(A, P, V, r0, rho, tau0, tlo)
            rho, delta = _em_chord(A, P, V, r0, rho, tau0, tlo, qg)
            ok = _em_ok(d1, delta, rho, A, V)
    else:
        A = _mid_start(ax, ay, az, y0, y1, y2, h)
        P = 0.0
        V = 0.0
        r0 = 0.0
        rho, delta = _mid_newton(A, A, tau0)
        rho, delta = _mid_newton(A, rho, tau0)
        ok = _mid_ok(delta, rho)
    extra = 0
    status = STATUS_OK
    if not ok and method == METHOD_EM:
        r0, rho, extra, status = _resolve_point_em(
            A, P, V, r0, rho, abs(delta), h, gm, tau0, tlo, x0, x1, x2, y0, y1, y2, c0, c1, c2, max_iter
        )
    elif not ok and method == METHOD_EM_PLAIN:
        r0, rho, extra, status = _resolve_point_em_plain(
            A, P, V, r0, rho, abs(delta), h, gm, tau0, tlo, x0, x1, x2, y0, y1, y2, c0, c1, c2, max_iter
        )
    elif not ok:
        r0, rho, extra, status = _resolve_point_mid(
            A, P, V, r0, rho, abs(delta), h, gm, tau0, tlo, x0, x1, x2, y0, y1, y2, c0, c1, c2, max_iter
        )
    if method != METHOD_MIDPOINT:
        w = _em_w(r0, rho, gm, tau0, tlo)
        if method == METHOD_EM and _em_big_t(w, gm, tau0):
            d0, d1, d2, w0, w1, w2 = _em_finished(ax, ay, az, y0, y1, y2, w, r0, h, gm)
        else:
            d0, d1, d2, w0, w1, w2 = _increments(ax, ay, az, y0, y1, y2, w, 2.0, h, h)
    else:
        w = _mid_w(rho, gm, tau0, tlo)
        d0, d1, d2, w0, w1, w2 = _increments(ax, ay, az, y0, y1, y2, w, 1.0, 0.5 * h, h)
    t0, t1, t2, e0, e1, e2 = _kahan3(x0, x1, x2, p0, p1, p2, d0, d1, d2)
    u0, u1, u2, f0, f1, f2 = _kahan3(y0, y1, y2, q0, q1, q2, w0, w1, w2)
    if status == STATUS_OK and not _finite6(t0, t1, t2, u0, u1, u2):
        status = STATUS_SINGULAR
    return t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status


@_inline
def _implicit_point_em(x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter):
    """The default em step of one point, inlined into the point-by-point path: as a call it
    took 139-153 ns per step of the paper's orbit at T/100, inlined 125-128 ns (development
    machine, one thread, fastest of five runs of 1e6 steps; the call passes 20 values and
    returns 14 through memory). The other methods' steps stay calls: inlined, each would
    be processed (and then dropped) in every method's kernel, adding about 2-3 s to each
    one's first compile."""
    return _implicit_point_impl(
        METHOD_EM, x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter
    )


@kernel
def _implicit_point_em_plain(x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter):
    return _implicit_point_impl(
        METHOD_EM_PLAIN, x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter
    )


@kernel
def _implicit_point_mid(x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter):
    return _implicit_point_impl(
        METHOD_MIDPOINT, x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, h, gm, tau0, tlo, c0, c1, c2, max_iter
    )


@kernel
def _leapfrog_point(x0, x1, x2, y0, y1, y2, p0, p1, p2, q0, q1, q2, b0, b1, b2, h, gm, c0, c1, c2):
    """One kick-drift-kick sub-step of one point, with the same operations as
    pointmass.leapfrog_chunk (so the same bits). Returns 15 values and whether finite."""
    hf = 0.5 * h
    t0, t1, t2, e0, e1, e2 = _kahan3(x0, x1, x2, p0, p1, p2, h * (y0 + hf * b0), h * (y1 + hf * b1), h * (y2 + hf * b2))
    n0, n1, n2, rr = accel(c0 - t0, c1 - t1, c2 - t2, gm)
    u0, u1, u2, f0, f1, f2 = _kahan3(
        y0, y1, y2, q0, q1, q2, 0.5 * h * (b0 + n0), 0.5 * h * (b1 + n1), 0.5 * h * (b2 + n2)
    )
    # a centre hit makes the acceleration nan, so "finite" covers the reference's test of r
    good = _finite6(t0, t1, t2, u0, u1, u2) & _finite3(n0, n1, n2)
    return t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, good


# ----------------------------------------------------------------------------------------
# packed loops over one block of m points; S, D: offsets of the state buffers read and written


@_inline
def _loop_em_dots(W, m, h, c0, c1, c2, S):
    for i in range(m):
        ax = c0 - W[S + _OX0 + i]
        ay = c1 - W[S + _OX1 + i]
        az = c2 - W[S + _OX2 + i]
        vx = W[S + _OV0 + i]
        vy = W[S + _OV1 + i]
        vz = W[S + _OV2 + i]
        A, P, V, r0 = _em_dots(ax, ay, az, vx, vy, vz, h)
        W[_AA + i] = A
        W[_PP + i] = P
        W[_VV + i] = V
        W[_R0 + i] = r0


@_inline
def _pass_em_solve_impl(W, m, h, gm, tau0, tlo, c0, c1, c2, cur, method):
    """Dot products, predictor, the updates of r1 (em: one Newton update on the accurate F;
    fast: Newton and chord on the plain F), and w, for every point, as short loops. Returns
    the count of points not accepted (flagged in _PEND)."""
    if cur == 0:
        _loop_em_dots(W, m, h, c0, c1, c2, _BUF0)
    else:
        _loop_em_dots(W, m, h, c0, c1, c2, _BUF1)
    if method == METHOD_EM:
        for i in range(m):
            W[_RHO + i] = _em_predict(W[_AA + i], W[_PP + i], W[_VV + i], W[_R0 + i], h, gm)
    else:
        for i in range(m):
            W[_RHO + i] = _em_predict_taylor(W[_AA + i], W[_PP + i], W[_VV + i], W[_R0 + i], h, gm)
        for i in range(m):
            rho, d1, qg = _em_newton(W[_AA + i], W[_PP + i], W[_VV + i], W[_R0 + i], W[_RHO + i], tau0, tlo)
            W[_RHO + i] = rho
            W[_DEL + i] = d1
            W[_QG + i] = qg
    npend = 0
    for i in range(m):
        r0 = W[_R0 + i]
        A = W[_AA + i]
        P = W[_PP + i]
        V = W[_VV + i]
        if method == METHOD_EM:
            rho, delta, cert = _em_newton_certified(A, P, V, r0, W[_RHO + i], tau0, tlo)
            # never with A or V not finite (a state the update made so, see _run_packed):
            # then A/2 <= p <= 2 A fails, or D, delta or E is inf or nan and the
            # certificate's two roundings differ (tests/test_ensemble.py, the overflow test)
            ok = cert & _em_plausible(rho, A, V)
        else:
            rho, delta = _em_chord(A, P, V, r0, W[_RHO + i], tau0, tlo, W[_QG + i])
            ok = _em_ok(W[_DEL + i], delta, rho, A, V)
        W[_WG + i] = _em_w(r0, rho, gm, tau0, tlo)
        W[_PEND + i] = 0.0 if ok else 1.0
        W[_RHO + i] = rho
        W[_DEL + i] = delta
        npend += 0 if ok else 1
    return npend


@kernel
def _pass_em_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
    return _pass_em_solve_impl(W, m, h, gm, tau0, tlo, c0, c1, c2, cur, METHOD_EM)


@kernel
def _pass_em_plain_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
    return _pass_em_solve_impl(W, m, h, gm, tau0, tlo, c0, c1, c2, cur, METHOD_EM_PLAIN)


@_inline
def _loop_mid_start(W, m, h, c0, c1, c2, S):
    for i in range(m):
        W[_AA + i] = _mid_start(
            c0 - W[S + _OX0 + i],
            c1 - W[S + _OX1 + i],
            c2 - W[S + _OX2 + i],
            W[S + _OV0 + i],
            W[S + _OV1 + i],
            W[S + _OV2 + i],
            h,
        )


@kernel
def _pass_mid_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
    """|a - h/2 v0|, two Newton updates of |m| and w for every point. Returns the count of
    points not accepted (flagged in _PEND)."""
    if cur == 0:
        _loop_mid_start(W, m, h, c0, c1, c2, _BUF0)
    else:
        _loop_mid_start(W, m, h, c0, c1, c2, _BUF1)
    npend = 0
    for i in range(m):
        m0 = W[_AA + i]
        mu, delta = _mid_newton(m0, m0, tau0)
        mu, delta = _mid_newton(m0, mu, tau0)
        ok = _mid_ok(delta, mu)
        W[_PEND + i] = 0.0 if ok else 1.0
        W[_RHO + i] = mu
        W[_DEL + i] = delta
        W[_WG + i] = _mid_w(mu, gm, tau0, tlo)
        npend += 0 if ok else 1
    return npend


@_inline
def _loop_update(W, m, ua, uv, h, c0, c1, c2, S, D, gm, tau0, count_big, count_bad):
    """Increments from w and the compensated update of the state in S, into D; returns
    (``count_bad``, a constant) the count of points whose new state is not finite and
    (``count_big``, a constant: em) the count of steps with a large t (:func:`_em_big_t`),
    for :func:`_pass_finish_big_t`. (Counted here, where w is loaded anyway, instead of in a
    loop of its own: 0.66 ns per particle-step less on the benchmark ensemble, one thread.
    em leaves out the finite count where it can, see :func:`_run_packed`: it cost 0.3-0.9 ns
    per particle-step here or in a loop of its own.)"""
    nbad = 0
    nbig = 0
    for i in range(m):
        x0 = W[S + _OX0 + i]
        x1 = W[S + _OX1 + i]
        x2 = W[S + _OX2 + i]
        y0 = W[S + _OV0 + i]
        y1 = W[S + _OV1 + i]
        y2 = W[S + _OV2 + i]
        wg = W[_WG + i]
        d0, d1, d2, w0, w1, w2 = _increments(c0 - x0, c1 - x1, c2 - x2, y0, y1, y2, wg, ua, uv, h)
        t0, t1, t2, e0, e1, e2 = _kahan3(x0, x1, x2, W[S + _OCX0 + i], W[S + _OCX1 + i], W[S + _OCX2 + i], d0, d1, d2)
        u0, u1, u2, f0, f1, f2 = _kahan3(y0, y1, y2, W[S + _OCV0 + i], W[S + _OCV1 + i], W[S + _OCV2 + i], w0, w1, w2)
        _store_state(W, D, i, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2)
        if count_bad:
            nbad += 0 if _finite6(t0, t1, t2, u0, u1, u2) else 1
        if count_big:
            nbig += 1 if _em_big_t(wg, gm, tau0) else 0
    return nbad, nbig


@_inline
def _loop_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, S, D):
    """em: redo the steps with a large t (see _em_big_t) with the reference kernel's finish,
    from the state in S into D. Returns the count of points whose new state is not finite.
    (Its loads and compensated update are written out as in _loop_update: a helper shared by
    both stopped LLVM from vectorising _loop_update, measured 8.8 -> 15.5 ns per
    particle-step.)"""
    nbad = 0
    for i in range(m):
        if not _em_big_t(W[_WG + i], gm, tau0):
            continue
        x0 = W[S + _OX0 + i]
        x1 = W[S + _OX1 + i]
        x2 = W[S + _OX2 + i]
        y0 = W[S + _OV0 + i]
        y1 = W[S + _OV1 + i]
        y2 = W[S + _OV2 + i]
        d0, d1, d2, w0, w1, w2 = _em_finished(c0 - x0, c1 - x1, c2 - x2, y0, y1, y2, W[_WG + i], W[_R0 + i], h, gm)
        t0, t1, t2, e0, e1, e2 = _kahan3(x0, x1, x2, W[S + _OCX0 + i], W[S + _OCX1 + i], W[S + _OCX2 + i], d0, d1, d2)
        u0, u1, u2, f0, f1, f2 = _kahan3(y0, y1, y2, W[S + _OCV0 + i], W[S + _OCV1 + i], W[S + _OCV2 + i], w0, w1, w2)
        _store_state(W, D, i, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2)
        nbad += 0 if _finite6(t0, t1, t2, u0, u1, u2) else 1
    return nbad


@kernel
def _pass_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, cur):
    """em: after the update pass, the steps with a large t finished on the accurate g_em
    (a scalar pass, run only when :func:`_pass_update_em` counted such a step). Returns the
    count of points whose new state is not finite."""
    if cur == 0:
        return _loop_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, _BUF0, _BUF1)
    return _loop_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, _BUF1, _BUF0)


@kernel
def _pass_update(W, m, ua, uv, h, c0, c1, c2, cur):
    """Increments from w (g = w (ua a - uv v0)) and the compensated update into the other
    buffer. Returns the count of points whose new state is not finite."""
    if cur == 0:
        return _loop_update(W, m, ua, uv, h, c0, c1, c2, _BUF0, _BUF1, 0.0, 0.0, False, True)[0]
    return _loop_update(W, m, ua, uv, h, c0, c1, c2, _BUF1, _BUF0, 0.0, 0.0, False, True)[0]


@kernel
def _pass_update_em(W, m, h, gm, tau0, c0, c1, c2, cur, check):
    """em: :func:`_pass_update` (g = w (2 a - h v0)); returns the count of points whose new
    state is not finite (``check``; else 0) and the count of steps with a large t."""
    if check:
        if cur == 0:
            return _loop_update(W, m, 2.0, h, h, c0, c1, c2, _BUF0, _BUF1, gm, tau0, True, True)
        return _loop_update(W, m, 2.0, h, h, c0, c1, c2, _BUF1, _BUF0, gm, tau0, True, True)
    if cur == 0:
        return _loop_update(W, m, 2.0, h, h, c0, c1, c2, _BUF0, _BUF1, gm, tau0, True, False)
    return _loop_update(W, m, 2.0, h, h, c0, c1, c2, _BUF1, _BUF0, gm, tau0, True, False)


@_inline
def _loop_leapfrog(W, m, h, gm, c0, c1, c2, S, D):
    nbad = 0
    for i in range(m):
        (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, good) = _leapfrog_point(
            W[S + _OX0 + i],
            W[S + _OX1 + i],
            W[S + _OX2 + i],
            W[S + _OV0 + i],
            W[S + _OV1 + i],
            W[S + _OV2 + i],
            W[S + _OCX0 + i],
            W[S + _OCX1 + i],
            W[S + _OCX2 + i],
            W[S + _OCV0 + i],
            W[S + _OCV1 + i],
            W[S + _OCV2 + i],
            W[S + _OG0 + i],
            W[S + _OG1 + i],
            W[S + _OG2 + i],
            h,
            gm,
            c0,
            c1,
            c2,
        )
        _store_state(W, D, i, t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2)
        W[D + _OG0 + i] = n0
        W[D + _OG1 + i] = n1
        W[D + _OG2 + i] = n2
        nbad += 0 if good else 1
    return nbad


@kernel
def _pass_leapfrog(W, m, h, gm, c0, c1, c2, cur):
    """One kick-drift-kick sub-step into the other buffer; returns the count of points
    whose new state or acceleration is not finite."""
    if cur == 0:
        return _loop_leapfrog(W, m, h, gm, c0, c1, c2, _BUF0, _BUF1)
    return _loop_leapfrog(W, m, h, gm, c0, c1, c2, _BUF1, _BUF0)


# ----------------------------------------------------------------------------------------
# scalar passes over a block: the points whose packed solve was not accepted, and failures


@_inline
def _resolve_impl(W, method, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, check_input):
    """Finish the points flagged pending (see _resolve_point) and set their w; returns the
    count that failed and (em, ``check_input``) the count whose state came in not finite
    (the sub-step before made it so: flagged 2 in _PEND, failed as STATUS_SINGULAR, see
    :func:`_run_packed`)."""
    nfail = 0
    nin = 0
    for i in range(m):
        if W[_PEND + i] == 0.0 or W[_ST + i] != 0.0 or W[_ALIVE + i] != 1.0:
            continue
        if (
            method == METHOD_EM
            and check_input
            and not _finite6(
                W[S + _OX0 + i], W[S + _OX1 + i], W[S + _OX2 + i], W[S + _OV0 + i], W[S + _OV1 + i], W[S + _OV2 + i]
            )
        ):
            W[_PEND + i] = 2.0
            W[_ST + i] = float(STATUS_SINGULAR)
            nin += 1
            continue
        r0, rho, extra, status = _resolve_point(
            method,
            W[_AA + i],
            W[_PP + i],
            W[_VV + i],
            W[_R0 + i],
            W[_RHO + i],
            abs(W[_DEL + i]),
            h,
            gm,
            tau0,
            tlo,
            W[S + _OX0 + i],
            W[S + _OX1 + i],
            W[S + _OX2 + i],
            W[S + _OV0 + i],
            W[S + _OV1 + i],
            W[S + _OV2 + i],
            c0,
            c1,
            c2,
            max_iter,
        )
        W[_EXTRA + i] += extra
        if status == STATUS_OK:
            W[_R0 + i] = r0
            W[_RHO + i] = rho
            W[_WG + i] = _mid_w(rho, gm, tau0, tlo) if method == METHOD_MIDPOINT else _em_w(r0, rho, gm, tau0, tlo)
        else:
            W[_ST + i] = float(status)
            nfail += 1
    return nfail, nin


@kernel
def _resolve_em(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, check_input):
    return _resolve_impl(W, METHOD_EM, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, check_input)


@kernel
def _resolve_em_plain(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S):
    return _resolve_impl(W, METHOD_EM_PLAIN, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, False)[0]


@kernel
def _resolve_mid(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S):
    return _resolve_impl(W, METHOD_MIDPOINT, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, False)[0]


@kernel
def _fail_before(W, m, S, P, fail, lo, step, check):
    """em, one sub-step per step: the step ``step`` gave points a state that is not finite,
    found afterwards (flagged 2 in _PEND by the scalar pass of the next step, or, ``check``,
    any live point whose state in buffer S is not finite: at the end of a record). They
    fail at that step as STATUS_SINGULAR with the state from before it, still in the other
    buffer P. Returns the count."""
    n = 0
    for i in range(m):
        if W[_ALIVE + i] != 1.0:
            continue
        if check:
            bad = not _finite6(
                W[S + _OX0 + i], W[S + _OX1 + i], W[S + _OX2 + i], W[S + _OV0 + i], W[S + _OV1 + i], W[S + _OV2 + i]
            )
        else:
            bad = W[_PEND + i] == 2.0
        if bad:
            for j in range(_NS):
                W[S + j * LD + i] = W[P + j * LD + i]
            W[_ALIVE + i] = 0.0
            W[_ST + i] = 0.0
            W[_WG + i] = 0.0
            fail[lo + i, 0] = step
            fail[lo + i, 1] = STATUS_SINGULAR
            n += 1
    return n


@kernel
def _fixup(W, m, S, D):
    """After a sub-step in which a point failed (or with dead points): give such points
    their old state back (buffer S into D) and record a non-finite state in _ST."""
    for i in range(m):
        fin = _finite6(
            W[D + _OX0 + i], W[D + _OX1 + i], W[D + _OX2 + i], W[D + _OV0 + i], W[D + _OV1 + i], W[D + _OV2 + i]
        )
        fin = fin & _finite3(W[D + _OG0 + i], W[D + _OG1 + i], W[D + _OG2 + i])
        if not fin and W[_ST + i] == 0.0:
            W[_ST + i] = float(STATUS_SINGULAR)
        if W[_ST + i] != 0.0 or W[_ALIVE + i] != 1.0:
            for j in range(_NS):
                W[D + j * LD + i] = W[S + j * LD + i]


# ----------------------------------------------------------------------------------------
# one block: every step of the chunk


@kernel
def _work_array():
    """A block's work array ``W`` (:data:`_NROWS` rows of :data:`LD`), its rows on 64-byte
    boundaries (``LD * 8`` is a multiple of 64). Not cleared: :func:`_run_packed` sets what
    it reads before writing. One per range of blocks, not per block: allocating and clearing
    33 KB for every block of 64 points cost about 6 ns per point and call (measured on the
    development machine, 1e5 points, one thread)."""
    buf = np.empty(_NROWS * LD + 8)
    off = (8 - (buf.ctypes.data // 8) % 8) % 8
    return buf[off : off + _NROWS * LD]


@_inline
def _run_packed(
    method, W, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    """Every step of the chunk for the block of points lo..hi (at most :data:`BLOCK`) in
    the work array ``W`` (:func:`_work_array`, any content)."""
    m = hi - lo
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    for d in range(3):
        for i in range(m):
            W[d * LD + i] = x[d, lo + i]
            W[(3 + d) * LD + i] = v[d, lo + i]
            W[(6 + d) * LD + i] = cx[d, lo + i]
            W[(9 + d) * LD + i] = cv[d, lo + i]
            # the gravity rows of both buffers: leapfrog's state, and checked by _fixup
            W[_BUF0 + _OG0 + d * LD + i] = 0.0
            W[_BUF1 + _OG0 + d * LD + i] = 0.0
    for i in range(m):
        W[_ALIVE + i] = 1.0
        W[_ST + i] = 0.0
    ndead = 0
    packed = _packed_iters(method)
    if method == METHOD_LEAPFROG:
        for i in range(m):
            a0, a1, a2, rr = accel(c0 - W[_OX0 + i], c1 - W[_OX1 + i], c2 - W[_OX2 + i], gm)
            W[_OG0 + i] = a0
            W[_OG1 + i] = a1
            W[_OG2 + i] = a2
            if not (rr > 0.0 and rr < math.inf):
                W[_ALIVE + i] = 0.0
                ndead += 1
                fail[lo + i, 0] = 0
                fail[lo + i, 1] = STATUS_SINGULAR
    ns = gammas.shape[0]
    cur = 0  # the buffer that holds the state
    for r in range(nrec):
        for i in range(m):
            W[_EXTRA + i] = 0.0
        for s in range(every):
            if ns > 1:  # a failing sub-step discards the whole composed step
                base = _BUF0 if cur == 0 else _BUF1
                for j in range(_NS):
                    for i in range(m):
                        W[_BK + j * LD + i] = W[base + j * LD + i]
            failed = False
            for k in range(ns):
                h = dt * gammas[k]
                tau0, tlo = _tau(h, gm)
                S = _BUF0 if cur == 0 else _BUF1
                nbad = 0
                if method == METHOD_LEAPFROG:
                    nbad = _pass_leapfrog(W, m, h, gm, c0, c1, c2, cur)
                elif method == METHOD_EM:
                    first = r == 0 and s == 0 and k == 0  # the caller's state: as the reference
                    if _pass_em_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
                        nf, nin = _resolve_em(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S, not first)
                        nbad += nf
                        if nin and ns == 1:  # the step before made them so
                            ndead += _fail_before(
                                W, m, S, _BUF1 if cur == 0 else _BUF0, fail, lo, r * every + s - 1, False
                            )
                        else:  # an earlier sub-step of this step
                            nbad += nin
                    nb, nbig = _pass_update_em(W, m, h, gm, tau0, c0, c1, c2, cur, k == ns - 1 > 0)
                    nbad += nb
                    if nbig:
                        nbad += _pass_finish_big_t(W, m, h, gm, tau0, c0, c1, c2, cur)
                elif method == METHOD_EM_PLAIN:
                    if _pass_em_plain_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
                        nbad += _resolve_em_plain(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S)
                    nbad += _pass_update(W, m, 2.0, h, h, c0, c1, c2, cur)
                else:
                    if _pass_mid_solve(W, m, h, gm, tau0, tlo, c0, c1, c2, cur):
                        nbad += _resolve_mid(W, m, h, gm, tau0, tlo, c0, c1, c2, max_iter, S)
                    nbad += _pass_update(W, m, 1.0, 0.5 * h, h, c0, c1, c2, cur)
                cur = 1 - cur
                if nbad or failed or ndead:
                    failed = failed or nbad > 0
                    _fixup(W, m, S, _BUF0 if cur == 0 else _BUF1)
            if failed:
                step = r * every + s
                base = _BUF0 if cur == 0 else _BUF1
                for i in range(m):
                    if W[_ALIVE + i] == 1.0 and W[_ST + i] != 0.0:
                        W[_ALIVE + i] = 0.0
                        ndead += 1
                        fail[lo + i, 0] = step
                        fail[lo + i, 1] = int(W[_ST + i])
                        if ns > 1:
                            for j in range(_NS):
                                W[base + j * LD + i] = W[_BK + j * LD + i]
                    W[_ST + i] = 0.0
        base = _BUF0 if cur == 0 else _BUF1
        if method == METHOD_EM and ns == 1:  # the last step's state: not checked by its update
            ndead += _fail_before(W, m, base, _BUF1 if cur == 0 else _BUF0, fail, lo, r * every + every - 1, True)
        for d in range(3):
            for i in range(m):
                rec_x[r, d, lo + i] = W[base + d * LD + i]
                rec_v[r, d, lo + i] = W[base + (3 + d) * LD + i]
        for i in range(m):
            rec_iters[r, lo + i] = every * ns * packed + int(W[_EXTRA + i])
    base = _BUF0 if cur == 0 else _BUF1
    for d in range(3):
        for i in range(m):
            x[d, lo + i] = W[base + d * LD + i]
            v[d, lo + i] = W[base + (3 + d) * LD + i]
            cx[d, lo + i] = W[base + (6 + d) * LD + i]
            cv[d, lo + i] = W[base + (9 + d) * LD + i]


@_inline
def _run_point(method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, i):
    """Every step of the chunk for point ``i`` alone (blocks too small to pack)."""
    c0 = center[0]
    c1 = center[1]
    c2 = center[2]
    x0, x1, x2 = x[0, i], x[1, i], x[2, i]
    y0, y1, y2 = v[0, i], v[1, i], v[2, i]
    p0, p1, p2 = cx[0, i], cx[1, i], cx[2, i]
    q0, q1, q2 = cv[0, i], cv[1, i], cv[2, i]
    ns = gammas.shape[0]
    packed = _packed_iters(method)
    b0 = b1 = b2 = 0.0
    if method == METHOD_LEAPFROG:
        b0, b1, b2, rr = accel(c0 - x0, c1 - x1, c2 - x2, gm)
        if not (rr > 0.0 and rr < math.inf):
            fail[i, 0] = 0
            fail[i, 1] = STATUS_SINGULAR
            return
    for r in range(nrec):
        its = 0
        for s in range(every):
            # sub-steps go into trial copies: a failing step leaves the state untouched
            t0, t1, t2, u0, u1, u2 = x0, x1, x2, y0, y1, y2
            e0, e1, e2, f0, f1, f2 = p0, p1, p2, q0, q1, q2
            n0, n1, n2 = b0, b1, b2
            status = STATUS_OK
            for k in range(ns):
                h = dt * gammas[k]
                if method == METHOD_LEAPFROG:
                    (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, good) = _leapfrog_point(
                        t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, n0, n1, n2, h, gm, c0, c1, c2
                    )
                    if not good:
                        status = STATUS_SINGULAR
                elif method == METHOD_EM:
                    tau0, tlo = _tau(h, gm)
                    (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_em(
                        t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
                    )
                elif method == METHOD_EM_PLAIN:
                    tau0, tlo = _tau(h, gm)
                    (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_em_plain(
                        t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
                    )
                else:
                    tau0, tlo = _tau(h, gm)
                    (t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, extra, status) = _implicit_point_mid(
                        t0, t1, t2, u0, u1, u2, e0, e1, e2, f0, f1, f2, h, gm, tau0, tlo, c0, c1, c2, max_iter
                    )
                if method != METHOD_LEAPFROG:
                    its += packed + extra
                if status != STATUS_OK:
                    fail[i, 0] = r * every + s
                    fail[i, 1] = status
                    break
            if status != STATUS_OK:
                break
            x0, x1, x2, y0, y1, y2 = t0, t1, t2, u0, u1, u2
            p0, p1, p2, q0, q1, q2 = e0, e1, e2, f0, f1, f2
            b0, b1, b2 = n0, n1, n2
        if fail[i, 0] >= 0:
            break
        rec_x[r, 0, i] = x0
        rec_x[r, 1, i] = x1
        rec_x[r, 2, i] = x2
        rec_v[r, 0, i] = y0
        rec_v[r, 1, i] = y1
        rec_v[r, 2, i] = y2
        rec_iters[r, i] = its
    x[0, i], x[1, i], x[2, i] = x0, x1, x2
    v[0, i], v[1, i], v[2, i] = y0, y1, y2
    cx[0, i], cx[1, i], cx[2, i] = p0, p1, p2
    cv[0, i], cv[1, i], cv[2, i] = q0, q1, q2


# ----------------------------------------------------------------------------------------
# entry points: kernels per method. The method is a constant in each, so Numba prunes the
# other methods' code before compiling: a run compiles only what it uses. (The bodies above
# are inlined at the Numba level once per method; deeper nesting of such inlining made
# compiling several times slower.)


@_inline
def _run_points(
    method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    """Every step of the chunk for points lo..hi one by one (blocks too small to pack)."""
    for i in range(lo, hi):
        _run_point(
            method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, i
        )


@kernel
def _points_em(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_points(
        METHOD_EM, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
    )


@kernel
def _points_em_plain(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    _run_points(
        METHOD_EM_PLAIN,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@kernel
def _points_midpoint(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    _run_points(
        METHOD_MIDPOINT,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@kernel
def _points_leapfrog(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    _run_points(
        METHOD_LEAPFROG,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@_inline
def _run_range(
    method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
):
    """Every step of the chunk for points lo..hi, block by block (packed, or point by point
    where a block is too small)."""
    W = _work_array()
    for b in range(lo, hi, BLOCK):
        e = min(b + BLOCK, hi)
        if e - b >= _PACKED_MIN:
            _run_packed(
                method,
                W,
                x,
                v,
                cx,
                cv,
                gm,
                center,
                dt,
                gammas,
                every,
                nrec,
                max_iter,
                rec_x,
                rec_v,
                rec_iters,
                fail,
                b,
                e,
            )
        elif method == METHOD_EM:  # a call, not inlined: the one-orbit path's own kernel
            _points_em(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, b, e)
        elif method == METHOD_EM_PLAIN:
            _points_em_plain(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, b, e
            )
        elif method == METHOD_MIDPOINT:
            _points_midpoint(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, b, e
            )
        else:
            _points_leapfrog(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, b, e
            )


@kernel
def _range_em(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_range(
        METHOD_EM, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
    )


@kernel
def _range_em_plain(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_range(
        METHOD_EM_PLAIN,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@kernel
def _range_midpoint(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_range(
        METHOD_MIDPOINT,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@kernel
def _range_leapfrog(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi):
    _run_range(
        METHOD_LEAPFROG,
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        lo,
        hi,
    )


@_inline
def _claim_blocks(n, threads):
    """The blocks of a parallel run of n points on ``threads`` threads, and how many of them
    a thread claims at a time from the shared counter: up to :data:`_GRAIN`, and at least
    four claims per thread (the last claims even out the threads' ends)."""
    nb = (n + BLOCK - 1) // BLOCK
    return nb, max(1, min(_GRAIN, nb // (4 * threads)))


@_inline
def _run_claims(
    method, counter, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads
):
    """One thread's part of a parallel run: claim blocks from ``counter`` and run them with
    the method's range kernel until none are left."""
    n = x.shape[1]
    nb, grain = _claim_blocks(n, threads)
    b = fetch_add(counter, 0, grain)
    while b < nb:
        lo, hi = b * BLOCK, min((b + grain) * BLOCK, n)
        if method == METHOD_EM:
            _range_em(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
            )
        elif method == METHOD_EM_PLAIN:
            _range_em_plain(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
            )
        elif method == METHOD_MIDPOINT:
            _range_midpoint(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
            )
        else:
            _range_leapfrog(
                x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, lo, hi
            )
        b = fetch_add(counter, 0, grain)


@kernel(parallel=True)
def _parallel_em(x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads):
    counter = np.zeros(1, np.int64)
    for _ in prange(threads):
        _run_claims(
            METHOD_EM,
            counter,
            x,
            v,
            cx,
            cv,
            gm,
            center,
            dt,
            gammas,
            every,
            nrec,
            max_iter,
            rec_x,
            rec_v,
            rec_iters,
            fail,
            threads,
        )


@kernel(parallel=True)
def _parallel_em_plain(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads
):
    counter = np.zeros(1, np.int64)
    for _ in prange(threads):
        _run_claims(
            METHOD_EM_PLAIN,
            counter,
            x,
            v,
            cx,
            cv,
            gm,
            center,
            dt,
            gammas,
            every,
            nrec,
            max_iter,
            rec_x,
            rec_v,
            rec_iters,
            fail,
            threads,
        )


@kernel(parallel=True)
def _parallel_midpoint(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads
):
    counter = np.zeros(1, np.int64)
    for _ in prange(threads):
        _run_claims(
            METHOD_MIDPOINT,
            counter,
            x,
            v,
            cx,
            cv,
            gm,
            center,
            dt,
            gammas,
            every,
            nrec,
            max_iter,
            rec_x,
            rec_v,
            rec_iters,
            fail,
            threads,
        )


@kernel(parallel=True)
def _parallel_leapfrog(
    x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, threads
):
    counter = np.zeros(1, np.int64)
    for _ in prange(threads):
        _run_claims(
            METHOD_LEAPFROG,
            counter,
            x,
            v,
            cx,
            cv,
            gm,
            center,
            dt,
            gammas,
            every,
            nrec,
            max_iter,
            rec_x,
            rec_v,
            rec_iters,
            fail,
            threads,
        )


_RANGE = {
    METHOD_EM: _range_em,
    METHOD_EM_PLAIN: _range_em_plain,
    METHOD_MIDPOINT: _range_midpoint,
    METHOD_LEAPFROG: _range_leapfrog,
}
_POINTS = {
    METHOD_EM: _points_em,
    METHOD_EM_PLAIN: _points_em_plain,
    METHOD_MIDPOINT: _points_midpoint,
    METHOD_LEAPFROG: _points_leapfrog,
}
_PARALLEL = {
    METHOD_EM: _parallel_em,
    METHOD_EM_PLAIN: _parallel_em_plain,
    METHOD_MIDPOINT: _parallel_midpoint,
    METHOD_LEAPFROG: _parallel_leapfrog,
}


def ensemble_chunk(method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail):
    """Advance every point ``nrec * every`` composed steps on one thread.

    method     METHOD_EM, METHOD_EM_PLAIN (roundoff="fast"), METHOD_MIDPOINT or METHOD_LEAPFROG;
               the other arguments as in
               :func:`~.pointmass.implicit_chunk` (``fail`` pre-filled with -1; leapfrog
               ignores ``max_iter`` and counts no iterations).
    """
    if x.shape[1] < _PACKED_MIN:  # a kernel of the point-by-point path alone: less to compile
        _POINTS[method](
            x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, 0, x.shape[1]
        )
    else:
        _RANGE[method](
            x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail, 0, x.shape[1]
        )


def ensemble_chunk_parallel(
    method, x, v, cx, cv, gm, center, dt, gammas, every, nrec, max_iter, rec_x, rec_v, rec_iters, fail
):
    """:func:`ensemble_chunk` on all of Numba's threads (blocks are independent, and each
    point's result is the same as on one thread). The threads claim blocks from a shared
    counter as they finish the previous ones (:mod:`.atomic`): a thread that runs slower,
    on a core shared with other work, takes fewer blocks instead of holding up the run."""
    _PARALLEL[method](
        x,
        v,
        cx,
        cv,
        gm,
        center,
        dt,
        gammas,
        every,
        nrec,
        max_iter,
        rec_x,
        rec_v,
        rec_iters,
        fail,
        numba.get_num_threads(),
    )
