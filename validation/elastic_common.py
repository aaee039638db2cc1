"""What the elastic cases share: frequencies measured from records, the midpoint rule's
frequency, the laid-out state of a simulation and the invariants' checks (the cases:
:mod:`.elastic_bodies`).

em linearised about a configuration is the implicit midpoint rule (the averaged-strain stress
S = C : (E0 + E1) / 2 of Simo & Tarnow is, to first order, linear in the displacements), which
turns an oscillator of frequency w by 2 atan(w h / 2) per step: its records oscillate at
w_h = (2 / h) atan(w h / 2) (:func:`midpoint_frequency`; :func:`spatial_frequency` inverts it
and so removes the step's error from a measured frequency). A measured frequency is a sinusoid
a sin(w t) + b cos(w t) + c fitted by least squares to a modal coordinate eta = phi^T M u of
the recorded displacements (:func:`fit_frequency`); the modes are M-orthogonal, so each
coordinate holds one mode.

``add_elastic`` starts every node in the reference configuration moving rigidly; the cases
write their initial deformations and velocities into the laid-out structure
(:func:`laid_out_state`: ``sim.structure.build()`` and ``Simulation.state_arrays``, then
``Simulation.set_state_arrays``, the checkpoint interface).

Every em run keeps energy, momentum and angular momentum at round-off: :func:`invariant_checks`
reads ``Result.invariant_drift`` (the drift relative to emorbit's round-off scale of each
invariant: T + W + the elements' stress scale, sqrt(2 M T), sqrt(2 T J)) in units of eps.

References: J. C. Simo, N. Tarnow, Z. angew. Math. Phys. 43 (1992) 757-792; T. J. R. Hughes,
*The Finite Element Method* (Prentice-Hall 1987), ch. 9 (the trapezoidal rule's period
elongation).
"""

from __future__ import annotations

import math

import numpy as np

from . import checks as C
from .body_case import BodyRun

__all__ = [
    "EPS",
    "midpoint_frequency",
    "spatial_frequency",
    "fit_frequency",
    "laid_out_state",
    "drift_eps",
    "invariant_checks",
]

#: the spacing of doubles at 1 (the invariants' drift is measured in it)
EPS = C.EPS


def midpoint_frequency(omega, dt):
    """The frequency at which the midpoint rule (and em, linearised) carries an oscillator.

    A linear oscillator of frequency w advanced by the implicit midpoint rule at step h turns by
    2 atan(w h / 2) per step, so its records oscillate at (2 / h) atan(w h / 2) (Hughes 1987,
    ch. 9: the trapezoidal rule's period elongation).

    Parameters
    ----------
    omega : float or ndarray
        The oscillator's frequency, rad/s.
    dt : float
        The step, s.

    Returns
    -------
    float or ndarray
        rad/s.
    """
    return 2.0 / dt * np.arctan(0.5 * np.asarray(omega, float) * dt)


def spatial_frequency(omega_h, dt):
    """The inverse of :func:`midpoint_frequency`: the oscillator's own frequency (rad/s),
    (2 / h) tan(w_h h / 2), of records that oscillate at ``omega_h`` (rad/s) under the step ``dt``
    (s)."""
    return 2.0 / dt * np.tan(0.5 * np.asarray(omega_h, float) * dt)


def fit_frequency(t, y) -> dict:
    """The frequency of a sampled sinusoid y = a sin(w t) + b cos(w t) + c, by least squares.

    A first guess is the peak of the zero-padded, Hann-windowed spectrum; the frequency that
    minimises the residual of the linear least squares in (a, b, c) is then searched on a grid
    of +-20 % around it (over a period or more of samples the grid's best point lies in the
    global minimum's basin) and refined by ``scipy.optimize.least_squares`` in all four
    parameters.

    Parameters
    ----------
    t : ndarray
        (m,) equally spaced times, s, spanning a period or more.
    y : ndarray
        (m,) the samples.

    Returns
    -------
    dict
        ``omega`` (rad/s), ``amplitude`` (sqrt(a^2 + b^2)), ``offset`` c and ``residual``
        (the largest |residual| relative to the amplitude).

    Raises
    ------
    ValueError
        Fewer than 8 samples, or samples that are all equal.
    """
    from scipy.optimize import least_squares

    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if t.size < 8 or t.shape != y.shape:
        raise ValueError(f"fit_frequency: at least 8 samples of equal shape expected, got {t.shape} and {y.shape}")
    scale = float(np.abs(y - y.mean()).max())
    if not scale > 0:
        raise ValueError("fit_frequency: the samples are all equal")
    tt = t - t[0]
    yy = (y - y.mean()) / scale
    h = tt[1] - tt[0]
    pad = 1 << int(math.ceil(math.log2(64 * t.size)))
    spec = np.abs(np.fft.rfft(yy * np.hanning(t.size), pad))
    k = int(np.argmax(spec[1:])) + 1
    if 1 <= k < spec.size - 1:
        a, b, c = np.log(spec[k - 1 : k + 2] + 1e-300)
        k = k + 0.5 * (a - c) / (a - 2 * b + c)
    guess = 2 * math.pi * k / (pad * h)

    def linear(w):
        A = np.column_stack([np.sin(w * tt), np.cos(w * tt), np.ones_like(tt)])
        coef, *_ = np.linalg.lstsq(A, yy, rcond=None)
        return coef, A @ coef - yy

    grid = guess * np.linspace(0.8, 1.2, 401)
    w0 = grid[int(np.argmin([np.sum(linear(w)[1] ** 2) for w in grid]))]
    coef, _ = linear(w0)

    def resid(p):
        return p[0] * np.sin(p[3] * tt) + p[1] * np.cos(p[3] * tt) + p[2] - yy

    sol = least_squares(
        resid, [*coef, w0], x_scale=[1.0, 1.0, 1.0, w0], xtol=1e-15, ftol=1e-15, gtol=1e-15, method="lm"
    )
    a, b, c, w = sol.x
    amp = math.hypot(a, b)
    return {
        "omega": float(w),
        "amplitude": amp * scale,
        "offset": c * scale + float(y.mean()),
        "residual": float(np.abs(sol.fun).max() / amp),
    }


def laid_out_state(sim) -> dict:
    """Lay out the simulation's structure and return its state arrays (``Simulation.state_arrays``):
    write into them and pass them to ``Simulation.set_state_arrays(arrays, 0)``."""
    sim.structure.build()
    return sim.state_arrays()


def drift_eps(res) -> np.ndarray:
    """The largest drift of energy, momentum and angular momentum over a run, in units of eps
    times emorbit's round-off scale of each (``Result.invariant_drift``)."""
    d = np.asarray(res.invariant_drift, float)
    return np.maximum(d, 0.0).max(axis=0) / EPS


def invariant_checks(r: BodyRun, tolerance: dict) -> None:
    """The checks ``energy``, ``momentum`` and ``angular-momentum`` of a case's em runs.

    Parameters
    ----------
    r : BodyRun
        The case's run; every run whose ``info`` has ``drift_eps`` (:func:`drift_eps`) counts.
    tolerance : dict
        ``energy``, ``momentum``, ``angular-momentum`` (eps), ``measured`` (the three worst
        measured, eps) and optionally ``note`` (why the energy's tolerance has its size).
    """
    drifts = {label: np.asarray(tr.info["drift_eps"]) for label, tr in r.runs.items() if "drift_eps" in tr.info}
    names = ("energy", "momentum", "angular-momentum")
    scales = (
        "T + W + sum EA L |E| + sum V |S| (kinetic and strain energy and the elements' stress scale: what a rounding "
        "of the strain moves W by, over eps)",
        "sqrt(2 M T)",
        "sqrt(2 T J), J = sum m |x|^2",
    )
    for k, (name, sc) in enumerate(zip(names, scales)):
        vals = {label: float(d[k]) for label, d in drifts.items()}
        worst = max(vals.values())
        r.check(
            name,
            f"|{('E', 'P', 'L')[k]} - its start| over every record of every em run, relative to {sc}, in eps",
            "the initial value (exact for em: the averaged-strain stress does work equal to the strain energy's "
            "change, and the internal forces have no resultant and no moment)",
            worst,
            tolerance[name],
            "eps",
            f"round-off of {max(tr.info['steps'] for tr in r.runs.values() if 'steps' in tr.info)} steps at most; "
            f"the tolerance is about 10 times the worst measured ({tolerance['measured'][k]:.2g} eps)"
            + (f"; {tolerance['note']}" if k == 0 and "note" in tolerance else ""),
            "; ".join(f"{label}: {v:.2g}" for label, v in vals.items()),
        )
