"""Adaptive, time-symmetric steps for a coupled structure (elastic bodies, with the rigid
bodies and point masses attached to them): the reversible controller of
:mod:`emorbit.kernels.pointmass.adaptive` around the structure's energy-momentum step.

Method. The structure carries one control variable ``rho``; its step is ``h = eps / rho``.
On the exact motion ``rho = 1 / s(y)`` with

    s(y) = eta 2 pi / sqrt(W),    W = GM / r**3 + max_b |w_b|**2 + w_el**2,

``r`` the distance of the structure's centre of mass from the field's centre, ``w_b`` the
angular velocity of each rigid body in it (``1/2 sum_k d_k x dd_k``) and ``w_el`` the
highest elastic frequency the mesh resolves: the step follows the fastest of the orbit, the
rotation and the elastic modes. ``w_el**2`` is the largest eigenvalue of ``M^-1 K`` at the
scene's start state (``K`` the elastic stiffness, its products by central differences of
the element forces; :data:`POWER_ITERATIONS` steps of the power method, whose Rayleigh
quotient approaches it from below), fixed for the run. In the step variable tau,
``d ln rho / d tau = g(y) = pi eta W' W**(-3/2)`` with ``W'`` the orbit term's rate of
change, ``-3 GM (x - c).v / r**5`` (the other terms' is left out: it only moves how closely
``rho`` follows ``1 / s``, and ``rho`` is reset to ``1 / s`` at each landing). A step is the
symmetric splitting ``rho_1/2 = rho_0 C(eps/4 g(y_0))``, ``y_1 = Phi_h(y_0)`` with ``h = eps
/ rho_1/2``, ``rho_1 = rho_1/2 C(eps/4 g(y_1))``, ``C(a) = (1 + a) / (1 - a)``, composed for
orders 4-8; steps land on every multiple of the run's ``dt`` (each interval starting
afresh) and failed steps are retried with the control started afresh, then with half the
``eps``, as for point masses. Every
sub-step is an energy-momentum step, so energy and angular momentum stay exact. Stiff
structures make the step short: em is stable at any step, and fixed steps over the elastic
modes cost far less where only the orbit matters.

Newton's "reuse" mode keeps its sparse factors per step size; with steps that vary, sizes
within a factor 2**(1/:data:`SIZE_CLASSES`) share factors (the iteration converges to the same
solution with factors of a nearby size, a little slower).

Data layout: ``rho`` (1,), 1/s (0: set from the state at the next step), part of a checkpoint.

References: E. Hairer, G. Soederlind, SIAM J. Sci. Comput. 26 (2005) 1838-1851; B. M. Irons,
AIAA J. 7 (1969) on element and system eigenvalues.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels.codes import METHOD_MIDPOINT, STATUS_NO_CONVERGENCE, STATUS_OK
from ..kernels.pointmass.adaptive import KICK_MAX, MAX_HALVINGS, MAX_STEPS, PREDICT, U_MAX

__all__ = ["StructureAdaptive", "POWER_ITERATIONS", "SIZE_CLASSES"]

#: power-method steps for the highest elastic frequency
POWER_ITERATIONS = 60
#: step sizes per factor 2 that share kept factors in adaptive runs
SIZE_CLASSES = 8


class StructureAdaptive:
    """The adaptive half of :class:`~emorbit.bodies.coupled.Structure` (a base class)."""

    #: the accuracy knob eta of adaptive steps (None: fixed steps); set by the Simulation
    adaptive: float | None = None
    #: adaptive steps taken so far
    adaptive_steps: int = 0
    #: the highest elastic frequency squared, 1/s^2 (None: not yet estimated)
    elastic_rate2: float | None = None

    def build(self) -> None:
        """Build the structure (:meth:`~emorbit.bodies.coupled_layout.StructureLayout.build`)
        and, with adaptive steps, set up the control at its start state: the highest elastic
        frequency comes from the scene's start, so a resumed run uses the same."""
        first = not self._built
        super().build()
        if first and self.adaptive is not None:
            self.start_adaptive()

    def factor_key(self, h: float) -> float:
        """The step size under which Newton's kept factors for a step of size ``h`` are filed:
        ``h`` itself with fixed steps, ``h`` rounded to :data:`SIZE_CLASSES` per factor 2 with
        adaptive ones."""
        if self.adaptive is None or h == 0.0:
            return h
        return math.copysign(2.0 ** (round(math.log2(abs(h)) * SIZE_CLASSES) / SIZE_CLASSES), h)

    def highest_elastic_rate2(self) -> float:
        """``w_el**2``, 1/s^2: the power method on ``M^-1 K`` at the current state (0 without
        elements). Deterministic: the start vector is fixed."""
        if self.bar_node.shape[0] + self.tet_node.shape[0] == 0:
            return 0.0
        u = self.u - self.cu
        pos = self.slot_pos[:, None]
        size = float(np.max(np.ptp(u[self.slot_pos > 0], axis=0), initial=1.0)) or 1.0
        x = np.random.default_rng(12345).standard_normal(u.shape)
        lam = 0.0
        for _ in range(POWER_ITERATIONS):
            x /= np.max(np.abs(x))
            d = 1e-6 * np.where(pos > 0, size, 1.0) * x
            fp = self._element_forces(METHOD_MIDPOINT, u + d, u + d)
            fm = self._element_forces(METHOD_MIDPOINT, u - d, u - d)
            kx = -(fp - fm) / (2e-6 * np.where(pos > 0, size, 1.0))
            mx = self._Mmul @ x
            lam = max(lam, float(np.sum(x * kx) / np.sum(x * mx)))
            x = self._solve_mass(kx)
        return lam

    def control(self, u, v, gm: float, c) -> tuple[float, float]:
        """``(1 / s(y), g(y))`` of the state ``u, v`` (see the module docstring); (0, 0) where
        nothing moves."""
        W = self.elastic_rate2
        dW = 0.0
        if gm > 0.0:
            w = self._pos_weights
            a = w @ u - c
            vc = w @ v
            r2 = float(a @ a)
            wo = gm / (r2 * math.sqrt(r2))
            W += wo
            dW += -3.0 * wo * float(a @ vc) / r2
        wr = 0.0
        for s in self.rb_slots:
            om = 0.5 * np.cross(u[s[1:4]], v[s[1:4]]).sum(axis=0)
            wr = max(wr, float(om @ om))
        W += wr
        if not W > 0.0:
            return 0.0, 0.0
        return math.sqrt(W) / (self.adaptive * 2.0 * math.pi), math.pi * self.adaptive * dW / (W * math.sqrt(W))

    def start_adaptive(self) -> None:
        """Set up what the control needs once the structure is built: the centre-of-mass
        weights of the slots and the highest elastic frequency."""
        w = np.asarray(self.Ms @ self.slot_pos).ravel() * self.slot_pos
        self._pos_weights = w / w.sum() if w.sum() > 0 else w
        if self.elastic_rate2 is None:
            self._scratch()
            self.elastic_rate2 = self.highest_elastic_rate2()

    def _composed(self, code, state, rho, eps, fixed, gammas, gm, c, max_iter):
        """One composed step of ``state`` (updated in place): sub-steps ``gammas[k] eps`` in
        tau, or (``fixed`` > 0) of physical size ``gammas[k] fixed`` with ``rho`` then
        ``1 / s``. Returns (rho, duration, iterations, stalled sub-steps, status)."""
        u, v = state[0], state[1]
        its = stl = 0
        dur = 0.0
        g = 0.0
        if fixed <= 0.0:
            r0, g = self.control(u - state[2], v - state[3], gm, c)
            if not r0 > 0.0:
                return rho, dur, its, stl, STATUS_NO_CONVERGENCE
        for gk in gammas:
            ak = 0.25 * eps * gk
            if fixed > 0.0:
                h = fixed * gk
            else:
                a = ak * g
                if not abs(a) < KICK_MAX:
                    return rho, dur, its, stl, STATUS_NO_CONVERGENCE
                rho = rho * (1.0 + a) / (1.0 - a)
                h = (4.0 * ak) / rho
            status, it, st = self._substeps(code, h, state, max_iter, self.MAX_SPLIT)
            its += it
            stl += st
            if status != STATUS_OK:
                return rho, dur, its, stl, status
            if fixed <= 0.0:
                r1, g = self.control(u - state[2], v - state[3], gm, c)
                a = ak * g
                if not (r1 > 0.0 and abs(a) < KICK_MAX):
                    return rho, dur, its, stl, STATUS_NO_CONVERGENCE
                rho = rho * (1.0 + a) / (1.0 - a)
            dur += h
        r1, _ = self.control(u - state[2], v - state[3], gm, c)
        if fixed > 0.0:
            rho = r1
        elif not (r1 > 0.0 and 1.0 / U_MAX < rho / r1 < U_MAX):  # the control ran away from 1 / s
            return rho, dur, its, stl, STATUS_NO_CONVERGENCE
        return rho, dur, its, stl, STATUS_OK

    def _interval(self, code, rho, interval, gammas, gm, c, max_iter):
        """Composed steps that end exactly ``interval`` seconds later (the state updated in
        place). Returns (rho, iterations, stalled sub-steps, composed steps, status). It starts
        afresh (a trial first step), so it depends on the state alone."""
        its = stl = steps = 0
        elapsed = prev = 0.0
        last = False
        status = STATUS_OK
        while not last:
            rem = interval - elapsed
            ok = False
            eps = 1.0
            reset = False
            for _ in range(MAX_HALVINGS + 2):
                dur, status = rem, STATUS_OK
                if prev < rem or eps < 1.0 or reset:
                    # a trial step (none when the last one was longer than what is left, unless
                    # the landing step failed)
                    state = self._state_copy()
                    rq, dur, it, st, status = self._composed(code, state, rho, eps, 0.0, gammas, gm, c, max_iter)
                    its += it
                    stl += st
                if status == STATUS_OK and dur >= rem:  # it passes the landing: the remaining time
                    state = self._state_copy()
                    rq, dur, it, st, status = self._composed(code, state, rho, 1.0, rem, gammas, gm, c, max_iter)
                    its += it
                    stl += st
                    last = True
                if status == STATUS_OK:
                    ok = True
                    break
                last = False
                if not reset:  # first failure: start the control afresh from the state, try again
                    reset = True
                    rho = self.control(self.u - self.cu, self.v - self.cv, gm, c)[0]
                    continue
                eps *= 0.5
            steps += 1
            if not ok or steps > MAX_STEPS:
                return rho, its, stl, steps, status if status != STATUS_OK else STATUS_NO_CONVERGENCE
            self.u, self.v, self.cu, self.cv, self.lam, self.acc, self.work, self.cwork = state
            rho = rq
            if not last:
                elapsed += dur
                prev = PREDICT * dur
        return rho, its, stl, steps, STATUS_OK

    def advance_adaptive(self, code, gm, c, dt, every, gammas, nrec, max_iter, rec) -> None:
        """``nrec`` records of ``every`` intervals of ``dt`` seconds (steps land on each) with
        adaptive steps, into ``rec`` (a :class:`~emorbit.bodies.coupled_output.StructureRecords`;
        ``rec.solves`` gets the sub-steps per record). On a failure the state is that at the
        failing record's start and ``rec.fail`` holds (record index, status)."""
        self.start_adaptive()
        rho = float(self.rho[0])
        if not rho > 0.0:
            rho, _ = self.control(self.u - self.cu, self.v - self.cv, gm, c)
        for r in range(nrec):
            its = stl = steps = 0
            start = (self.snapshot(), rho)
            for _ in range(every):
                rho, it, st, ns, status = self._interval(code, rho, dt, gammas, gm, c, max_iter)
                its += it
                stl += st
                steps += ns
                if status != STATUS_OK:
                    self.restore(start[0])
                    self.rho[0] = start[1]
                    rec.fail[0] = (r, status)
                    return
            self.rho[0] = rho
            self.adaptive_steps += steps
            rec.u[r], rec.v[r] = self.u, self.v
            rec.iterations[r, 0] = its
            rec.stalled[r, 0] = stl
            rec.solves[r, 0] = steps * len(gammas)

    def reversible_steps(self, method: str, gm: float, c, gammas, nsteps: int, max_iter: int) -> float:
        """Take exactly ``nsteps`` composed steps of size 1 in tau (no landing on a time): the
        scheme alone, for its time symmetry. Reversing ``v`` and ``cv`` and calling it again
        runs the same steps back. Returns the physical time advanced, s.

        Raises
        ------
        RuntimeError
            A step failed (its status in the message).
        """
        from ..integrators.dispatch import method_code

        self.build()
        self._scratch()
        self.start_adaptive()
        code = method_code(method)
        rho = float(self.rho[0])
        if not rho > 0.0:
            rho, _ = self.control(self.u - self.cu, self.v - self.cv, gm, c)
        t = 0.0
        for _ in range(nsteps):
            state = self._state_copy()
            rho, dur, _, _, status = self._composed(code, state, rho, 1.0, 0.0, gammas, gm, c, max_iter)
            if status != STATUS_OK:
                raise RuntimeError(f"an adaptive step failed with status {status}")
            self.u, self.v, self.cu, self.cv, self.lam, self.acc, self.work, self.cwork = state
            t += dur
        self.rho[0] = rho
        return t

    def _state_copy(self) -> tuple:
        return tuple(a.copy() for a in (self.u, self.v, self.cu, self.cv, self.lam, self.acc, self.work, self.cwork))
