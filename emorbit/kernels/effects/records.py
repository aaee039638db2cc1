"""An effect set's potential energies at recorded states (:mod:`.signatures`'s ``potential``).

For each record r at time ``t[r]``: the set's ``prepare`` at ``(t, t, t)`` (a path's position
at that time), then ``potential`` at the record's points, summed over the points per effect
with error-free transformations (two_sum, the errors summed apart): a plain running sum over
the hundreds of gravity points of an elastic body leaves ~20 ulp of noise in the recorded
energy, which then looks like an energy error the step did not make.
Data layout: ``x`` (rows, 3, n) positions, m; ``t`` (rows,) s from the epoch; ``m`` (n,)
kg; ``body`` (n,) int64; ``coef`` (k, n); ``P, I, T, S`` the set's arrays; ``out`` (rows, k)
J, overwritten.
"""

from __future__ import annotations

import numpy as np

from ..eft import two_sum
from ..jit import kernel

__all__ = ["record_potentials"]


@kernel
def record_potentials(prepare, potential, x, t, m, body, coef, P, I, T, S, out):
    """Each effect's potential energy summed over the points, at every record (into ``out``)."""
    rows = x.shape[0]
    n = x.shape[2]
    k = coef.shape[0]
    each = np.empty((k, n))
    xr = np.empty((3, n))
    for r in range(rows):
        prepare(t[r], t[r], t[r], P, I, T, S)
        for c in range(3):
            for i in range(n):
                xr[c, i] = x[r, c, i]
        potential(xr, m, body, coef, P, I, T, S, each)
        for e in range(k):
            s = 0.0
            err = 0.0
            for i in range(n):
                s, d = two_sum(s, each[e, i])
                err += d
            out[r, e] = s + err
