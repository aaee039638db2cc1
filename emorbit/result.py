"""The recorded history of a run, in SI units, as returned by
:meth:`emorbit.Simulation.run` and :func:`emorbit.io.read`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import orbits

__all__ = ["Result"]


@dataclass
class Result:
    """Records of a run. Arrays have one row per record; all values SI.

    time               (n,) s
    energy             (n,) J, total over all bodies
    momentum           (n, 3) kg m/s (not conserved in a fixed field; recorded for completeness)
    angular_momentum   (n, 3) kg m^2/s, about the field's centre
    newton_iterations  (n,) mean Newton iterations per point and sub-step during the
                       interval that ends at each record (0 for the first record and for
                       explicit methods)
    positions, velocities  {body name: (n, 3)} in m and m/s
    masses             {body name: mass in kg}
    method, order, dt, gm, center: how the run was made
    """

    time: np.ndarray
    energy: np.ndarray
    momentum: np.ndarray
    angular_momentum: np.ndarray
    newton_iterations: np.ndarray
    positions: dict[str, np.ndarray]
    velocities: dict[str, np.ndarray]
    masses: dict[str, float]
    method: str
    order: int
    dt: float
    gm: float
    center: np.ndarray
    attrs: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.time)

    @property
    def names(self) -> list[str]:
        """Body names in the order they were added."""
        return list(self.positions)

    def relative_energy_error(self) -> np.ndarray:
        """(E - E0) / |E0| per record."""
        return (self.energy - self.energy[0]) / abs(self.energy[0])

    def relative_angular_momentum_error(self) -> np.ndarray:
        """|L - L0| / |L0| per record."""
        L0 = self.angular_momentum[0]
        return np.linalg.norm(self.angular_momentum - L0, axis=-1) / np.linalg.norm(L0)

    def mean_newton_iterations(self) -> float:
        """Mean Newton iterations per point and sub-step over the whole run (weights: records)."""
        if len(self.time) < 2:
            return 0.0
        return float(np.mean(self.newton_iterations[1:]))

    def elements(self, name: str) -> orbits.OrbitalElements:
        """Osculating elements of body ``name`` at every record."""
        return orbits.elements(self.positions[name], self.velocities[name], self.gm, self.center)
