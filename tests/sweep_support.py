"""A check shared by the tests of em's one-update stop (:mod:`emorbit.kernels.pointmass.effect_step`)."""

from __future__ import annotations

import numpy as np


def assert_one_sweep_matches_two(one, two, radius: float) -> None:
    """``one`` and ``two``: (final positions, result) of the same run with an effect set whose
    Jacobian is declared exact and declared unknown. The first takes one Newton sweep per
    sub-step after its first two steps, the second two or more after its first; their positions
    agree to 1e-14 of ``radius``, and both keep the energy balance within 2e-15 of |E0|."""
    (pos, res), (pos2, res2) = one, two
    assert np.all(np.asarray(res.newton_iterations)[2:] == 1.0)
    assert np.all(np.asarray(res2.newton_iterations)[1:] >= 2.0)
    assert np.abs(pos - pos2).max() <= 1e-14 * radius
    for r in (res, res2):
        assert np.abs(r.relative_energy_balance()).max() <= 2e-15
