"""How far the reversible step-size control lags behind the motion near periapsis, for em and
tfe with adaptive steps on an eccentric Kepler orbit.

    python scripts/control_lag.py [--e 0.99 0.9] [--eta 0.04 0.03 0.02 0.01] [--order 8]

The controller (:mod:`emorbit.kernels.adaptive`) integrates its control variable rho in the
fictive time tau with kicks around each sub-step; a step is ``h = eps / rho``, and on the exact
motion ``rho s(y) = 1`` (s the step the accuracy knob asks for,
:func:`emorbit.kernels.pointmass.adaptive.control`). em's kicks ``rho C(eps/4 g(y))`` are of
order 2 in tau, raised by its compositions' sub-steps; a tfe step is one sub-step, and its
kicks are the Hermite rule's (:func:`emorbit.kernels.adaptive.kick4`, order 4). Where rho must
grow fast (periapsis of an eccentric orbit), a control of too low an order falls behind, and
the steps there are longer than asked.

For each eccentricity, method and eta the script runs one orbit from apoapsis (a = 6, the
work-precision bench's orbits, :func:`emorbit.bench.common.aphelion_state`) in one landing
interval, logging each composed step (the controller's loop run as Python around the compiled
steps), and prints the least ``rho s(y)`` at a step's start, the longest step over the one
asked for, the worst local position error (the step against the Kepler solution from its own
start, over a) and the final position error over a.
"""

from __future__ import annotations

import argparse

import numpy as np

from emorbit.bench.common import GM, aphelion_state, period
from emorbit.integrators import coefficients
from emorbit.kernels import adaptive
from emorbit.kernels.codes import METHOD_EM, METHOD_TFE, STATUS_OK
from emorbit.kernels.pointmass import adaptive as points
from emorbit.kernels.pointmass import tfe
from emorbit.orbits import propagate

_A = 6.0


def _state(s) -> tuple:
    """Position and velocity of the controller's 17 values (the compensations taken off)."""
    x = np.array(s[0:3]) - np.array(s[6:9])
    v = np.array(s[3:6]) - np.array(s[9:12])
    return x, v


def one_orbit(e: float, method: str, order: int, eta: float) -> dict:
    """One orbit of adaptive steps from apoapsis: the control's lag and the errors (module notes)."""
    x0, v0 = aphelion_state(_A, e)
    T = period(x0, v0)
    if method == "tfe":
        code, gammas, tab = METHOD_TFE, np.array([1.0]), tfe.tables(order)
    else:
        code, gammas, tab = METHOD_EM, np.asarray(coefficients(order), float), tfe.tables(4)
    log = []

    def step(ctx, s, rho, eps, fixed, t):
        out = points._step(ctx, s, rho, eps, fixed, t)
        log.append((s, rho, fixed, out))
        return out

    s = tuple(float(a) for a in (*x0, *v0)) + (0.0,) * 9
    eh, el, _ = points._energy_dd(s, GM, 0.0, 0.0, 0.0)
    rho = points.control(*x0, 0.0, 0.0, 0.0, GM, eta)
    ctx = (code, GM, 0.0, 0.0, 0.0, eta, gammas, 50, points.tfe_scratch(tab))
    q, _, _, steps, status = adaptive.interval.py_func(
        step, points._control, points._accept, ctx, s + (eh, el), rho, T, 0.0
    )
    lag, longest, local = np.inf, 0.0, 0.0
    for s0, r, fixed, out in log:
        if out[5] != STATUS_OK or fixed > 0.0:
            continue
        x, v = _state(s0)
        asked = 1.0 / points.control(*x, 0.0, 0.0, 0.0, GM, eta)
        lag = min(lag, r / points.control(*x, 0.0, 0.0, 0.0, GM, eta))
        longest = max(longest, out[2] / asked)
        xe = np.asarray(propagate(x, v, GM, out[2])[0]).ravel()
        local = max(local, float(np.linalg.norm(_state(out[0])[0] - xe)) / _A)
    xe = np.asarray(propagate(x0, v0, GM, T)[0]).ravel()
    return {
        "steps": steps,
        "status": status,
        "lag": lag,
        "longest": longest,
        "local": local,
        "final": float(np.linalg.norm(_state(q)[0] - xe)) / _A,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--e", type=float, nargs="+", default=[0.99, 0.9], help="eccentricities, in [0, 1)")
    parser.add_argument("--eta", type=float, nargs="+", default=[0.04, 0.03, 0.02, 0.01], help="accuracy knobs, > 0")
    parser.add_argument("--order", type=int, default=8, choices=(4, 6, 8), help="the order of both methods")
    args = parser.parse_args(argv)
    for e in args.e:
        if not 0.0 <= e < 1.0:
            parser.error(f"--e: an eccentricity in [0, 1), not {e!r}")
    for eta in args.eta:
        if not 0.0 < eta <= 0.2:
            parser.error(f"--eta: an accuracy knob in (0, 0.2], not {eta!r}")
    head = ("e", "method", "eta", "steps", "least rho s(y)", "longest step / asked", "worst local error / a")
    head += ("final error / a",)
    print("| " + " | ".join(head) + " |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for e in args.e:
        for method in ("tfe", "em"):
            for eta in args.eta:
                r = one_orbit(e, method, args.order, eta)
                failed = "" if r["status"] == STATUS_OK else f" (failed: status {r['status']})"
                print(
                    f"| {e:g} | {method} {args.order} | {eta:g} | {r['steps']} | {r['lag']:.3f} | {r['longest']:.2f} "
                    f"| {r['local']:.1e} | {r['final']:.1e}{failed} |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
