"""The peers of the ``perturbed`` bench section (:mod:`.perturbed`) on one case's force model
(:class:`~emorbit.bench.perturbed_models.Model`): heyoka's Taylor integrator, REBOUND's IAS15
and scipy's DOP853. Each run returns its CPU time, the final position, its largest energy
balance ``|E - E0 - W| / |E0|`` over its records, its steps and, for heyoka, its compile time.

* heyoka (:func:`heyoka_run`): ``taylor_adaptive`` on (x, v, W) with the paths' Hermite rows
  as parameters, propagated interval by interval of the paths' samples (the union of their
  grids), the cylindrical shadow's parameter switched by a terminal event on the cylinder's
  surface; compiled with its caches of compiled code switched off
  (:func:`emorbit.bench.gravity_field._cold`). The balance at each interval's end.
* REBOUND IAS15 (:func:`ias15_run`): G = 1, the Earth a mass GM at the origin, the satellite a
  test particle; the perturbations through ``additional_forces`` (a Python callback,
  velocity-dependent where there is drag). The timed run integrates to the end; a second,
  untimed run without REBOUND's gravity (the callback gives all of it) carries a second test
  particle whose x'' is the power, so its vx is W, and stops on the record grid (at REBOUND's
  default epsilon only: :func:`ias15_run`).
* scipy DOP853 (:func:`dop853_run`): ``solve_ivp`` on (x, v, W), ``rtol`` the setting and
  ``atol`` rtol times a, the circular speed at a and |E0| for the three parts; the balance at
  the record grid from its dense output.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .perturbed_models import heyoka_system
from .timing import best_cpu

__all__ = ["boundaries", "HeyokaRunner", "heyoka_run", "ias15_run", "dop853_run"]


def boundaries(model, duration: float) -> np.ndarray:
    """The ends of the intervals over which the paths are one polynomial each, up to ``duration``."""
    ends = {duration}
    for tb in model.tables():
        ends.update(float(k) * tb.step for k in range(1, int(math.ceil(duration / tb.step))))
    return np.array(sorted(e for e in ends if 0.0 < e <= duration))


def _balance(model, t, states, e0) -> float:
    """max |E - E0 - W| / |E0| over states (n, 7) at times t."""
    out = 0.0
    for tk, y in zip(t, states):
        out = max(out, abs(model.energy(float(tk), list(y[0:3]), list(y[3:6])) - e0 - float(y[6])) / abs(e0))
    return out


class HeyokaRunner:
    """heyoka's integrator of a model, built per tolerance."""

    def __init__(self, model, state0, duration: float):
        import heyoka as hy

        self.hy, self.model, self.duration = hy, model, duration
        self.system, self.set_pars, self.event = heyoka_system(model, hy)
        self.state0 = np.concatenate([np.asarray(state0, float), [0.0]])
        self.ends = boundaries(model, duration)
        self.npar = 13 * len(model.tables()) + (1 if model.srp else 0)  # the shadow's nu last

    def _shadow_callback(self, fp_type):
        model, index = self.model, self.event[1] if self.event else None

        def cb(ta, d_sgn):
            x = [float(q) for q in ta.state[:3]]
            sun = model.srp[4].state(float(ta.time))[0]
            behind = x[0] * sun[0] + x[1] * sun[1] + x[2] * sun[2] < 0.0
            inside = int(d_sgn) < 0  # into the cylinder
            ta.pars[index] = fp_type(0.0 if behind and inside else 1.0)
            return True

        return cb

    def build(self, tol: float, fp_type=float):
        """The integrator and its construction's CPU and wall time (caches off); in compact mode
        in long double (fully unrolled, the reference's order-22 integrator took 59 s to compile,
        in compact mode 0.9 s)."""
        from .gravity_field import _cold

        hy = self.hy
        kw = {}
        if self.event is not None:
            kw["t_events"] = [hy.t_event(self.event[0], callback=self._shadow_callback(fp_type), fp_type=fp_type)]
        state0 = np.array(self.state0, dtype=fp_type)
        with _cold(hy):
            t = time.perf_counter(), time.process_time()
            ta = hy.taylor_adaptive(
                self.system,
                state0,
                tol=fp_type(tol),
                pars=np.zeros(self.npar, dtype=fp_type),
                fp_type=fp_type,
                compact_mode=fp_type is not float,
                **kw,
            )
            return ta, time.process_time() - t[1], time.perf_counter() - t[0]

    def reset(self, ta, fp_type=float):
        """Back to t = 0, the parameters of the first interval, the shadow's nu at the start."""
        ta.time = fp_type(0.0)
        ta.state[:] = np.array(self.state0, dtype=fp_type)
        pars = np.zeros(self.npar)
        self.set_pars(pars, 0.0)
        if self.model.srp:
            pars[-1] = self.model.shadow(list(self.state0[:3]), self.model.srp[4].state(0.0)[0])
        ta.pars[:] = pars.astype(fp_type)
        return ta

    def propagate(self, ta, fp_type=float, keep=False):
        """Interval by interval to the end: (steps, states at the ends or None, failure or None)."""
        hy = self.hy
        steps, out = 0, []
        pars = np.zeros(self.npar)
        for end in self.ends:
            res = ta.propagate_until(fp_type(end))
            steps += int(res[3])
            if res[0] != hy.taylor_outcome.time_limit:
                return steps, None, str(res[0])
            if keep:
                out.append(np.array(ta.state, dtype=float))
            if end < self.duration:
                if self.model.srp:
                    pars[-1] = float(ta.pars[-1])
                self.set_pars(pars, float(end))
                ta.pars[:] = pars.astype(fp_type)
        return steps, out, None

    def run(self, tol: float, fp_type=float) -> dict:
        """A run at ``tol``: compile and CPU time, the final position, the balance, the steps."""
        ta, compile_cpu, compile_wall = self.build(tol, fp_type)
        (steps, _, failed), cpu = best_cpu(lambda ta: self.propagate(ta, fp_type), lambda: self.reset(ta, fp_type))
        if failed:
            return {"status": f"failed: {failed}", "compile_s": compile_cpu}
        x_end = np.array(ta.state[:3], dtype=fp_type)
        _, states, _ = self.propagate(self.reset(ta, fp_type), fp_type, keep=True)
        e0 = self.model.energy(0.0, list(self.state0[:3]), list(self.state0[3:6]))
        return {
            "cpu_s": cpu,
            "x_end": x_end,
            "energy_balance": _balance(self.model, self.ends, np.array(states), e0),
            "steps": steps,
            "order": int(ta.order),
            "compile_s": compile_cpu,
            "compile_wall_s": compile_wall,
        }


def heyoka_run(runner: HeyokaRunner, tol: float, fp_type=float) -> dict:
    """:meth:`HeyokaRunner.run`, a failure kept as a point."""
    try:
        return runner.run(tol, fp_type)
    except Exception as exc:  # noqa: BLE001 - a peer never stops the bench
        return {"status": f"failed: {type(exc).__name__}: {exc}"}


def _rebound(model, state0, epsilon: float, energy: bool):
    import rebound

    sim = rebound.Simulation()
    sim.G = 1.0
    sim.integrator = "ias15"
    sim.integrator.epsilon = epsilon
    x, v = [float(q) for q in state0[:3]], [float(q) for q in state0[3:6]]
    if energy:
        sim.gravity = "none"
        sim.add(m=0.0, x=x[0], y=x[1], z=x[2], vx=v[0], vy=v[1], vz=v[2])
        sim.add(m=0.0)  # its vx integrates the power: W
    else:
        sim.add(m=model.gm)
        sim.add(m=0.0, x=x[0], y=x[1], z=x[2], vx=v[0], vy=v[1], vz=v[2])
        sim.N_active = 1
    sat = 0 if energy else 1
    sim.force_is_velocity_dependent = 1 if model.drag is not None else 0

    def forces(ptr):
        s = ptr.contents
        p = s.particles[sat]
        xs, vs, t = [p.x, p.y, p.z], [p.vx, p.vy, p.vz], s.t
        a = model.acceleration(t, xs, vs) if energy else model.perturbation(t, xs, vs)
        p.ax += a[0]
        p.ay += a[1]
        p.az += a[2]
        if energy:
            s.particles[1].ax += model.power(t, xs, vs)

    sim.additional_forces = forces
    return sim, forces  # the callback is kept alive by the caller


def ias15_run(model, state0, duration: float, epsilon: float, records: int, balance: bool = True) -> dict:
    """REBOUND's IAS15 at ``epsilon``: CPU time to the end, the final position and, where
    ``balance``, the energy balance over ``records`` records of an untimed run (see the
    module's docstring; its W particle's acceleration jumps at the shadow's edges, where IAS15's
    default step control, per particle, takes steps without end: that run uses its global
    control, ``adaptive_mode = 1``)."""
    try:
        keep = []

        def setup():
            sim, cb = _rebound(model, state0, epsilon, False)
            keep[:] = [cb]
            return sim

        def go(sim):
            sim.integrate(duration)
            return sim

        sim, cpu = best_cpu(go, setup)
        out = {"cpu_s": cpu, "x_end": np.array(sim.particles[1].xyz), "steps": int(sim.steps_done)}
        if balance:
            esim, cb = _rebound(model, state0, epsilon, True)
            esim.integrator.adaptive_mode = 1
            e0 = model.energy(0.0, list(state0[:3]), list(state0[3:6]))
            grid = np.linspace(0.0, duration, records + 1)[1:]
            states = []
            for t in grid:
                esim.integrate(t)
                p, w = esim.particles[0], esim.particles[1]
                states.append([*p.xyz, *p.vxyz, w.vx])
            out["energy_balance"] = _balance(model, grid, states, e0)
            del cb
    except Exception as exc:  # noqa: BLE001 - a peer never stops the bench
        return {"status": f"failed: {type(exc).__name__}: {exc}"}
    return out


def dop853_run(model, state0, duration: float, rtol: float, records: int, a: float) -> dict:
    """scipy's DOP853 at ``rtol`` on (x, v, W): CPU time, the final position, the balance over
    ``records`` records of its dense output."""
    from scipy.integrate import solve_ivp

    y0 = np.concatenate([np.asarray(state0, float), [0.0]])
    e0 = model.energy(0.0, list(y0[:3]), list(y0[3:6]))
    speed = math.sqrt(model.gm / a)
    atol = rtol * np.array([a] * 3 + [speed] * 3 + [abs(e0)])
    grid = np.linspace(0.0, duration, records + 1)[1:]
    try:
        sol, cpu = best_cpu(
            lambda: solve_ivp(model.rhs, (0.0, duration), y0, method="DOP853", rtol=rtol, atol=atol, dense_output=True)
        )
    except Exception as exc:  # noqa: BLE001 - a peer never stops the bench
        return {"status": f"failed: {type(exc).__name__}: {exc}"}
    if sol.status != 0:
        return {"status": f"failed: {sol.message}", "cpu_s": cpu}
    states = sol.sol(grid).T
    return {
        "cpu_s": cpu,
        "x_end": sol.y[:3, -1].copy(),
        "energy_balance": _balance(model, grid, states, e0),
        "steps": int(sol.t.size - 1),
    }
