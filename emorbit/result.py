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
    newton_iterations  (n,) mean Newton iterations per body and sub-step during the interval
                       that ends at each record (0 for the first record and explicit methods)
    bodies             {name: {dataset: (n, width)}}: "position" (m), "velocity" (m/s) for
                       every body; rigid bodies add "attitude" (unit quaternion, scalar first,
                       body to space) and "angular_velocity" (rad/s, body frame)
    masses, kinds      {name: mass in kg}, {name: "point" | "rigid"}
    method, order, dt, gm, center: how the run was made
    """

    time: np.ndarray
    energy: np.ndarray
    momentum: np.ndarray
    angular_momentum: np.ndarray
    newton_iterations: np.ndarray
    bodies: dict[str, dict[str, np.ndarray]]
    masses: dict[str, float]
    kinds: dict[str, str]
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
        return list(self.bodies)

    def _dataset(self, name: str) -> dict[str, np.ndarray]:
        return {b: d[name] for b, d in self.bodies.items() if name in d}

    @property
    def positions(self) -> dict[str, np.ndarray]:
        """{body: (n, 3)} positions (centre of mass for extended bodies), m."""
        return self._dataset("position")

    @property
    def velocities(self) -> dict[str, np.ndarray]:
        """{body: (n, 3)} velocities, m/s."""
        return self._dataset("velocity")

    @property
    def attitudes(self) -> dict[str, np.ndarray]:
        """{rigid body: (n, 4)} unit quaternions, scalar first, rotating body into space axes."""
        return self._dataset("attitude")

    @property
    def angular_velocities(self) -> dict[str, np.ndarray]:
        """{rigid body: (n, 3)} angular velocity in the body frame, rad/s."""
        return self._dataset("angular_velocity")

    def relative_energy_error(self) -> np.ndarray:
        """(E - E0) / |E0| per record."""
        return (self.energy - self.energy[0]) / abs(self.energy[0])

    def relative_angular_momentum_error(self) -> np.ndarray:
        """|L - L0| / |L0| per record."""
        L0 = self.angular_momentum[0]
        return np.linalg.norm(self.angular_momentum - L0, axis=-1) / np.linalg.norm(L0)

    def mean_newton_iterations(self) -> float:
        """Mean Newton iterations per body and sub-step over the whole run (weights: records)."""
        if len(self.time) < 2:
            return 0.0
        return float(np.mean(self.newton_iterations[1:]))

    def elements(self, name: str) -> orbits.OrbitalElements:
        """Osculating elements of body ``name`` (its centre of mass) at every record."""
        return orbits.elements(self.positions[name], self.velocities[name], self.gm, self.center)
