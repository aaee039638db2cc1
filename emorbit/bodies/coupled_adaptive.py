"""Adaptive, time-symmetric steps for a coupled structure (elastic bodies, with the rigid
bodies and point masses attached to them): the reversible controller of
:mod:`emorbit.kernels.adaptive` around the structure's energy-momentum step.

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
``rho`` follows ``1 / s``, and ``rho`` is reset to ``1 / s`` at each landing). The splitting,
the compositions, the landing on every multiple of the run's ``dt`` and the retries are
those of :func:`emorbit.kernels.adaptive.interval`: the structure runs the same loop, as
Python (its step is Python). Every sub-step is an energy-momentum step, so energy and
angular momentum stay exact (under effects that do work, the energy balance). Stiff
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

from ..kernels.adaptive import KICK_MAX, U_MAX, interval
from ..kernels.codes import METHOD_MIDPOINT, STATUS_NO_CONVERGENCE, STATUS_OK
from ..kernels.eft import kahan_add

__all__ = ["StructureAdaptive", "POWER_ITERATIONS", "SIZE_CLASSES"]

#: power-method steps for the highest elastic frequency
POWER_ITERATIONS = 60
#: step sizes per factor 2 that share kept factors in adaptive runs
SIZE_CLASSES = 8


class StructureAdaptive:
    """The adaptive half of :class:`~emorbit.bodies.coupled.Structure` (a base class)."""

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
            mx = self.Mmul @ x
            lam = max(lam, float(np.sum(x * kx) / np.sum(x * mx)))
            x = self.solve_mass(kx)
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

    def _composed(self, code, state, rho, eps, fixed, gammas, gm, c, max_iter, t=0.0):
        """One composed step of ``state`` (updated in place) from time ``t``: sub-steps
        ``gammas[k] eps`` in tau, or (``fixed`` > 0) of physical size ``gammas[k] fixed`` with
        ``rho`` then ``1 / s``. Returns (rho, duration as a Kahan pair ``dur - dlo``,
        iterations, stalled sub-steps, status)."""
        u, v = state[0], state[1]
        its = stl = 0
        dur = dlo = 0.0
        g = 0.0
        if fixed <= 0.0:
            r0, g = self.control(u - state[2], v - state[3], gm, c)
            if not r0 > 0.0:
                return rho, dur, dlo, its, stl, STATUS_NO_CONVERGENCE
        for gk in gammas:
            ak = 0.25 * eps * gk
            if fixed > 0.0:
                h = fixed * gk
            else:
                a = ak * g
                if not abs(a) < KICK_MAX:
                    return rho, dur, dlo, its, stl, STATUS_NO_CONVERGENCE
                rho = rho * (1.0 + a) / (1.0 - a)
                h = (4.0 * ak) / rho
            status, it, st = self._substeps(code, h, state, max_iter, self.MAX_SPLIT, t + (dur - dlo))
            its += it
            stl += st
            if status != STATUS_OK:
                return rho, dur, dlo, its, stl, status
            if fixed <= 0.0:
                r1, g = self.control(u - state[2], v - state[3], gm, c)
                a = ak * g
                if not (r1 > 0.0 and abs(a) < KICK_MAX):
                    return rho, dur, dlo, its, stl, STATUS_NO_CONVERGENCE
                rho = rho * (1.0 + a) / (1.0 - a)
            dur, dlo = kahan_add(dur, dlo, h)
        r1, _ = self.control(u - state[2], v - state[3], gm, c)
        if fixed > 0.0:
            rho = r1
        elif not (r1 > 0.0 and 1.0 / U_MAX < rho / r1 < U_MAX):  # the control ran away from 1 / s
            return rho, dur, dlo, its, stl, STATUS_NO_CONVERGENCE
        return rho, dur, dlo, its, stl, STATUS_OK

    # the structure's three functions for the controller's loop (emorbit.kernels.adaptive.interval),
    # with ctx = (structure, method code, gammas, gm, c, max_iter)
    @staticmethod
    def _step(ctx, s, rho, eps, fixed, t):
        st, code, gammas, gm, c, max_iter = ctx
        q = tuple(a.copy() for a in s)
        rho, dur, dlo, its, stl, status = st._composed(code, q, rho, eps, fixed, gammas, gm, c, max_iter, t)
        st._stalled += stl
        return q, rho, dur, dlo, its, status

    @staticmethod
    def _control_of(ctx, s):
        st, code, gammas, gm, c, max_iter = ctx
        return st.control(s[0] - s[2], s[1] - s[3], gm, c)[0]

    @staticmethod
    def _accept(ctx, s, q):
        return q

    def _interval(self, code, rho, length, gammas, gm, c, max_iter, t0=0.0):
        """Composed steps that end exactly ``length`` seconds later (the state updated in
        place). Returns (rho, iterations, stalled sub-steps, composed steps, status). It starts
        afresh (a trial first step), so it depends on the state alone."""
        self._stalled = 0
        ctx = (self, code, gammas, gm, c, max_iter)
        s, rho, its, steps, status = interval.py_func(
            self._step, self._control_of, self._accept, ctx, self._state_copy(), rho, length, t0
        )
        self.u, self.v, self.cu, self.cv, self.lam, self.acc, self.work, self.cwork = s
        return rho, its, self._stalled, steps, status

    def advance_adaptive(self, code, gm, c, dt, every, gammas, nrec, max_iter, rec, clock=(0.0, 0)) -> None:
        """``nrec`` records of ``every`` intervals of ``dt`` seconds (steps land on each) with
        adaptive steps, into ``rec`` (a :class:`~emorbit.bodies.coupled_output.StructureRecords`;
        ``rec.solves`` gets the sub-steps per record). Interval j of the chunk starts at
        ``clock[0] + (clock[1] + j) dt``. On a failure the state is that at the failing record's
        start and ``rec.fail`` holds (record index, status)."""
        self.start_adaptive()
        rho = float(self.rho[0])
        if not rho > 0.0:
            rho, _ = self.control(self.u - self.cu, self.v - self.cv, gm, c)
        for r in range(nrec):
            its = stl = steps = 0
            start = (self.snapshot(), rho)
            for j in range(every):
                t0 = float(clock[0]) + (float(clock[1]) + r * every + j) * dt
                rho, it, st, ns, status = self._interval(code, rho, dt, gammas, gm, c, max_iter, t0)
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
            if rec.work is not None:
                rec.work[r] = self.work
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
        self.build()
        self._scratch()
        self.start_adaptive()
        code, gammas = self.method_setup(method, gm, c, gammas)
        rho = float(self.rho[0])
        if not rho > 0.0:
            rho, _ = self.control(self.u - self.cu, self.v - self.cv, gm, c)
        t = 0.0
        for _ in range(nsteps):
            state = self._state_copy()
            rho, dur, dlo, _, _, status = self._composed(code, state, rho, 1.0, 0.0, gammas, gm, c, max_iter, t)
            if status != STATUS_OK:
                raise RuntimeError(f"an adaptive step failed with status {status}")
            self.u, self.v, self.cu, self.cv, self.lam, self.acc, self.work, self.cwork = state
            t += dur - dlo
        self.rho[0] = rho
        return t

    def _state_copy(self) -> tuple:
        return tuple(a.copy() for a in (self.u, self.v, self.cu, self.cv, self.lam, self.acc, self.work, self.cwork))
