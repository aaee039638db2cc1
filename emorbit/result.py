"""The records of a run, in SI units, as :meth:`emorbit.Simulation.run` returns them and
:func:`emorbit.read` reads them from a file."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import orbits

__all__ = ["Result"]


@dataclass
class Result:
    """The records of a run: one row per record, all values in SI units.

    Attributes
    ----------
    time : ndarray
        (n,) record times, s.
    energy : ndarray
        (n,) total energy of all bodies, J.
    momentum : ndarray
        (n, 3) total linear momentum, kg m/s (not conserved in a fixed field; recorded for
        completeness).
    angular_momentum : ndarray
        (n, 3) total angular momentum about the field's centre, kg m^2/s.
    newton_iterations : ndarray
        (n,) mean Newton iterations per body and sub-step in the interval that ends at each
        record (0 for the first record and for explicit methods).
    bodies : dict
        {name: {dataset: array}}: ``"position"`` (n, 3) in m (the centre of mass of an
        extended body) and ``"velocity"`` (n, 3) in m/s for every body; rigid bodies add
        ``"attitude"`` (n, 4, unit quaternion, scalar first, body to space) and
        ``"angular_velocity"`` (n, 3, rad/s, body frame); elastic bodies add
        ``"nodes/position"`` and ``"nodes/time"`` (see :mod:`emorbit.io.hdf5`).
    masses : dict
        {name: mass in kg}.
    kinds : dict
        {name: ``"point"``, ``"rigid"`` or ``"elastic"``}.
    method : str
        The method's name.
    order : int
        The composition's order.
    dt : float
        The step, s.
    gm : float
        GM of the field, m^3/s^2 (0 in free space).
    center : ndarray
        The field's centre (3,), m.
    attrs : dict
        The file's root attributes, for a Result read from a file (empty otherwise).
    split_steps : ndarray
        (n,) steps of the interval that ends at each record that were redone in sub-steps
        because Newton failed on the whole step (0 for the first record).
    stalled_solves : ndarray
        (n,) implicit sub-steps of the interval that ends at each record whose Newton
        iteration was accepted at a stall, above round-off (structures and rigid bodies).
    invariant_drift : ndarray
        (n, 3) drift of energy, linear momentum and angular momentum from the first record,
        relative to their round-off scales; -1 for an invariant the method does not
        conserve (:mod:`emorbit.io.drift`).
    drift_bound : ndarray
        (n,) the drift that round-off explains at each record, C eps sqrt(n), same units.
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
    split_steps: np.ndarray | None = None
    stalled_solves: np.ndarray | None = None
    invariant_drift: np.ndarray | None = None
    drift_bound: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.time)
        for name, shape, fill in (
            ("split_steps", (n,), 0.0),
            ("stalled_solves", (n,), 0.0),
            ("invariant_drift", (n, 3), -1.0),
            ("drift_bound", (n,), -1.0),
        ):
            if getattr(self, name) is None:
                setattr(self, name, np.full(shape, fill))

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
        """The relative energy error of every record.

        Returns
        -------
        ndarray
            (E - E0) / |E0|, shape (n,).
        """
        return (self.energy - self.energy[0]) / abs(self.energy[0])

    def relative_angular_momentum_error(self) -> np.ndarray:
        """The relative angular-momentum error of every record.

        Returns
        -------
        ndarray
            |L - L0| / |L0|, shape (n,).
        """
        L0 = self.angular_momentum[0]
        return np.linalg.norm(self.angular_momentum - L0, axis=-1) / np.linalg.norm(L0)

    def mean_newton_iterations(self) -> float:
        """Mean Newton iterations per body and sub-step over the run.

        Returns
        -------
        float
            The mean of :attr:`newton_iterations` over the record intervals (each interval
            weighs the same); 0 with fewer than two records.
        """
        if len(self.time) < 2:
            return 0.0
        return float(np.mean(self.newton_iterations[1:]))

    def elements(self, name: str) -> orbits.OrbitalElements:
        """Osculating elements of a body's centre of mass at every record.

        Parameters
        ----------
        name : str
            The body.

        Returns
        -------
        OrbitalElements
            Arrays of shape (n,), m and rad (see :mod:`emorbit.orbits`).
        """
        return orbits.elements(self.positions[name], self.velocities[name], self.gm, self.center)
