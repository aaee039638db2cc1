"""The records of a run, as :meth:`emorbit.Simulation.run` returns them and :func:`emorbit.read`
reads them from a file.

:class:`Result` speaks units: its times, invariants, states, field and elements are astropy
Quantities in SI units: ``result.energy[-1]`` is a Quantity in J, and
``result.positions[name].to(u.km)`` converts. Plain SI numbers are one call away: ``.value``
on any Quantity, or ``result.si`` (a :class:`ResultSI`), which has the same names holding
plain SI arrays and floats. Ratios, counts and text (relative errors, Newton iterations,
drift measures, method, kinds) are plain numbers on both.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import astropy.units as u
import numpy as np

from . import orbits

__all__ = ["Result", "ResultSI", "DATASET_UNITS"]

#: the unit of each recorded body dataset that has one (:mod:`emorbit.io.hdf5`); the others
#: (``attitude``: unit quaternions; ``mesh/tetrahedra``, ``mesh/bars``: node indices) are
#: plain arrays
DATASET_UNITS = {
    "position": u.m,
    "velocity": u.m / u.s,
    "angular_velocity": u.rad / u.s,
    "nodes/position": u.m,
    "nodes/time": u.s,
    "mass_points/position": u.m,
    "mass_points/mass": u.kg,
    "mesh/reference_nodes": u.m,
}

_MOMENTUM = u.kg * u.m / u.s
_ANGULAR_MOMENTUM = u.kg * u.m**2 / u.s
_GM = u.m**3 / u.s**2


@dataclass
class ResultSI:
    """The records of a run as plain SI numbers: one row per record.

    ``result.si`` of a :class:`Result`; it has the names of :class:`Result`, each holding the
    plain ndarray or float (SI units) that :class:`Result` gives as a Quantity.

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
    energy_range : ndarray
        (n, 2) the least and the greatest total energy over the steps of the record interval
        that ends at each record, J; both columns equal :attr:`energy` where the run did
        not record them.
    work : dict
        {effect label: (n,) J}: the work each effect that does work (drag) has done on the
        bodies since the run's start; empty for conservative scenes.
    energy_balance : ndarray or None
        (n,) ``E - E0 - sum W``, J, under effects that do work (an em step keeps it at
        round-off); None for conservative scenes.
    ledger : dict
        Under burns that expel mass, the mass ledger (``docs/methods.md``, "Finite burns"),
        each (n,) J: ``energy`` the bodies' energy at their true masses, ``work`` the work
        done on them there, ``expelled`` the energy the propellant has carried away, and
        ``balance`` = energy - energy[0] - work + expelled (round-off); empty otherwise.
    events : list of dict
        The events found (:mod:`emorbit.events`), in time order: ``label``, ``kind``,
        ``body``, ``time`` (s), ``step``, ``position`` (3,) m and ``velocity`` (3,) m/s of the
        body at the event (NaN for a time event).
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
    energy_range: np.ndarray | None = None
    work: dict = field(default_factory=dict)
    energy_balance: np.ndarray | None = None
    ledger: dict = field(default_factory=dict)
    events: list = field(default_factory=list)

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
        energy = np.asarray(self.energy, float)
        if self.energy_range is None:
            self.energy_range = np.stack([energy, energy], axis=-1)
        else:
            self.energy_range = np.asarray(self.energy_range, float)
            if self.energy_range.shape != (len(energy), 2):
                raise ValueError(
                    f"energy_range must have shape ({len(energy)}, 2) (least and greatest energy per record), "
                    f"got {self.energy_range.shape}"
                )

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

    def relative_energy_error_range(self) -> np.ndarray:
        """The least and the greatest relative energy error over each record interval.

        The envelope of :meth:`relative_energy_error` between records: a run that records
        every k-th step can dip or peak between two records, and this says how far.

        Returns
        -------
        ndarray
            (n, 2): (E_min - E0) / |E0| and (E_max - E0) / |E0| over the steps of the
            interval that ends at each record (:attr:`energy_range`).
        """
        return (self.energy_range - self.energy[0]) / abs(self.energy[0])

    def relative_energy_balance(self) -> np.ndarray | None:
        """The energy balance of every record relative to the first energy.

        Returns
        -------
        ndarray or None
            (E - E0 - sum W) / |E0|, shape (n,), under effects that do work; None otherwise.
        """
        if self.energy_balance is None:
            return None
        return np.asarray(self.energy_balance, float) / abs(self.energy[0])

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
            Plain arrays of shape (n,), m and rad (see :mod:`emorbit.orbits`).
        """
        return orbits.elements(self.positions[name], self.velocities[name], self.gm, self.center)


def _with_unit(value, unit):
    """``value`` as a Quantity in ``unit`` that shares its memory, or unchanged without a unit."""
    return value if unit is None else np.asarray(value) << unit


class Result:
    """The records of a run: one row per record, values with units.

    The constructor takes plain SI arrays (as the recorder and the file reader have them);
    the attributes give them back as astropy Quantities in SI units that share the arrays'
    memory. ``result.si`` (:class:`ResultSI`) holds the same records as plain SI numbers,
    and ``.value`` of any Quantity is its SI array.

    Parameters
    ----------
    time, energy, momentum, angular_momentum, newton_iterations : ndarray
        The records in SI units (see the properties of the same names).
    bodies : dict
        {name: {dataset: SI array}} (see :attr:`bodies`).
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
    attrs : dict, optional
        The file's root attributes.
    split_steps, stalled_solves, drift_bound : ndarray, optional
        (n,) diagnostics per record (default 0, 0 and -1).
    invariant_drift : ndarray, optional
        (n, 3) invariant drift per record (default -1).
    energy_range : ndarray, optional
        (n, 2) the least and the greatest total energy over the steps of the record interval
        that ends at each record, J (default: both columns equal ``energy``).

    Raises
    ------
    ValueError
        ``energy_range`` has a shape other than (n, 2).

    Examples
    --------
    >>> import astropy.units as u
    >>> import emorbit
    >>> res = emorbit.load_scene("paper-ellipse").build().run(t_end="10 s")
    >>> res.elements("satellite").a[-1].to(u.cm)  # doctest: +SKIP
    <Quantity 600.00135351 cm>
    >>> res.energy[-1], res.si.energy[-1]  # doctest: +SKIP
    (<Quantity -0.32898259 J>, -0.32898259119999995)
    """

    def __init__(
        self,
        time,
        energy,
        momentum,
        angular_momentum,
        newton_iterations,
        bodies,
        masses,
        kinds,
        method,
        order,
        dt,
        gm,
        center,
        attrs=None,
        split_steps=None,
        stalled_solves=None,
        invariant_drift=None,
        drift_bound=None,
        energy_range=None,
        work=None,
        energy_balance=None,
        events=None,
        ledger=None,
    ) -> None:
        self._si = ResultSI(
            time=time,
            energy=energy,
            momentum=momentum,
            angular_momentum=angular_momentum,
            newton_iterations=newton_iterations,
            bodies=bodies,
            masses=masses,
            kinds=kinds,
            method=method,
            order=order,
            dt=dt,
            gm=gm,
            center=center,
            attrs={} if attrs is None else attrs,
            split_steps=split_steps,
            stalled_solves=stalled_solves,
            invariant_drift=invariant_drift,
            drift_bound=drift_bound,
            energy_range=energy_range,
            work={} if work is None else dict(work),
            energy_balance=energy_balance,
            ledger={} if ledger is None else dict(ledger),
            events=[] if events is None else list(events),
        )

    def __repr__(self) -> str:
        si = self._si
        return f"Result(method={si.method!r}, order={si.order}, records={len(si)}, bodies={si.names})"

    def __len__(self) -> int:
        return len(self._si)

    @property
    def si(self) -> ResultSI:
        """The same records as plain SI arrays and floats, under the same names."""
        return self._si

    # -- Quantities ----------------------------------------------------------------------------
    @property
    def time(self) -> u.Quantity:
        """(n,) record times, s."""
        return _with_unit(self._si.time, u.s)

    @property
    def energy(self) -> u.Quantity:
        """(n,) total energy of all bodies, J."""
        return _with_unit(self._si.energy, u.J)

    @property
    def energy_range(self) -> u.Quantity:
        """(n, 2) the least and the greatest total energy over each record interval, J."""
        return _with_unit(self._si.energy_range, u.J)

    @property
    def momentum(self) -> u.Quantity:
        """(n, 3) total linear momentum, kg m / s."""
        return _with_unit(self._si.momentum, _MOMENTUM)

    @property
    def angular_momentum(self) -> u.Quantity:
        """(n, 3) total angular momentum about the field's centre, kg m2 / s."""
        return _with_unit(self._si.angular_momentum, _ANGULAR_MOMENTUM)

    @property
    def dt(self) -> u.Quantity:
        """The step, s."""
        return u.Quantity(self._si.dt, u.s)

    @property
    def gm(self) -> u.Quantity:
        """GM of the field, m3 / s2 (0 in free space)."""
        return u.Quantity(self._si.gm, _GM)

    @property
    def center(self) -> u.Quantity:
        """The field's centre (3,), m."""
        return _with_unit(self._si.center, u.m)

    @property
    def masses(self) -> dict[str, u.Quantity]:
        """{body: mass}, kg."""
        return {name: u.Quantity(m, u.kg) for name, m in self._si.masses.items()}

    @property
    def bodies(self) -> dict[str, dict]:
        """{body: {dataset: Quantity or ndarray}}: every recorded dataset of every body.

        ``"position"`` (n, 3) in m (the centre of mass of an extended body) and
        ``"velocity"`` (n, 3) in m / s for every body; rigid bodies add ``"attitude"``
        (n, 4, a plain ndarray of unit quaternions, scalar first, body to space) and
        ``"angular_velocity"`` (n, 3, rad / s, body frame); elastic bodies add
        ``"nodes/position"`` (m) and ``"nodes/time"`` (s), and bodies read from a file their
        constants (:mod:`emorbit.io.hdf5`). The units are those of :data:`DATASET_UNITS`;
        datasets without one (quaternions, mesh node indices) are plain ndarrays.
        """
        return {
            name: {q: _with_unit(a, DATASET_UNITS.get(q)) for q, a in sets.items()}
            for name, sets in self._si.bodies.items()
        }

    def _dataset(self, name: str) -> dict:
        unit = DATASET_UNITS.get(name)
        return {b: _with_unit(d[name], unit) for b, d in self._si.bodies.items() if name in d}

    @property
    def positions(self) -> dict[str, u.Quantity]:
        """{body: (n, 3)} positions (centre of mass for extended bodies), m."""
        return self._dataset("position")

    @property
    def velocities(self) -> dict[str, u.Quantity]:
        """{body: (n, 3)} velocities, m / s."""
        return self._dataset("velocity")

    @property
    def attitudes(self) -> dict[str, np.ndarray]:
        """{rigid body: (n, 4)} unit quaternions, scalar first, rotating body into space axes:
        plain ndarrays (a quaternion has no unit)."""
        return self._dataset("attitude")

    @property
    def angular_velocities(self) -> dict[str, u.Quantity]:
        """{rigid body: (n, 3)} angular velocity in the body frame, rad / s."""
        return self._dataset("angular_velocity")

    def elements(self, name: str, si: bool = False) -> orbits.OrbitalElements:
        """Osculating elements of a body's centre of mass at every record.

        Parameters
        ----------
        name : str
            The body.
        si : bool
            Plain arrays in m and rad (as ``result.si.elements(name)``) instead of Quantities.

        Returns
        -------
        OrbitalElements
            Quantities of shape (n,) (see :mod:`emorbit.orbits`): ``a`` in m (negative for
            a hyperbolic state), ``e`` dimensionless, ``i``, ``raan``, ``argp``, ``nu`` and
            ``M`` in rad; with ``si`` plain arrays.
        """
        el = self._si.elements(name)
        return el if si else el.with_units()

    # -- plain numbers ---------------------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        """Body names in the order they were added."""
        return self._si.names

    @property
    def kinds(self) -> dict[str, str]:
        """{body: ``"point"``, ``"rigid"`` or ``"elastic"``}."""
        return self._si.kinds

    @property
    def method(self) -> str:
        """The method's name."""
        return self._si.method

    @property
    def order(self) -> int:
        """The composition's order."""
        return self._si.order

    @property
    def attrs(self) -> dict:
        """The file's root attributes, for a Result read from a file (empty otherwise)."""
        return self._si.attrs

    @property
    def newton_iterations(self) -> np.ndarray:
        """(n,) mean Newton iterations per body and sub-step in the interval that ends at each
        record (0 for the first record and for explicit methods)."""
        return self._si.newton_iterations

    @property
    def split_steps(self) -> np.ndarray:
        """(n,) steps of each record interval redone in sub-steps because Newton failed."""
        return self._si.split_steps

    @property
    def stalled_solves(self) -> np.ndarray:
        """(n,) implicit sub-steps of each record interval accepted at a Newton stall."""
        return self._si.stalled_solves

    @property
    def invariant_drift(self) -> np.ndarray:
        """(n, 3) drift of energy, momentum and angular momentum relative to round-off."""
        return self._si.invariant_drift

    @property
    def drift_bound(self) -> np.ndarray:
        """(n,) the drift that round-off explains at each record."""
        return self._si.drift_bound

    @property
    def work(self) -> dict[str, u.Quantity]:
        """{effect label: (n,) J} the work of each effect that does work (drag) since the run's
        start; empty for conservative scenes."""
        return {k: _with_unit(w, u.J) for k, w in self._si.work.items()}

    @property
    def ledger(self) -> dict[str, u.Quantity]:
        """The mass ledger of burns that expel mass, {name: (n,) J}: ``energy`` (the bodies'
        energy at their true masses), ``work`` (done on them there), ``expelled`` (the energy
        the propellant has carried away) and ``balance`` (``energy - energy[0] - work +
        expelled``, at round-off); empty without such burns."""
        return {k: _with_unit(w, u.J) for k, w in self._si.ledger.items()}

    @property
    def events(self):
        """The events found, one row each in time order: an astropy QTable with ``label``,
        ``kind``, ``body``, ``time`` (s), ``step``, the body's ``position`` (m) and
        ``velocity`` (m/s) at the event (NaN for a time event), and an impulse's ``dv`` (m/s)
        and ``work`` (J); empty when there were none."""
        from astropy.table import QTable

        rows = self._si.events
        return QTable(
            {
                "label": [e["label"] for e in rows],
                "kind": [e["kind"] for e in rows],
                "body": [e["body"] for e in rows],
                "time": np.array([e["time"] for e in rows], float) * u.s,
                "step": np.array([e["step"] for e in rows], np.int64),
                "position": np.array([e["position"] for e in rows], float).reshape(-1, 3) * u.m,
                "velocity": np.array([e["velocity"] for e in rows], float).reshape(-1, 3) * (u.m / u.s),
                "dv": np.array([e.get("dv", np.zeros(3)) for e in rows], float).reshape(-1, 3) * (u.m / u.s),
                "work": np.array([e.get("work", 0.0) for e in rows], float) * u.J,
            }
        )

    @property
    def energy_balance(self) -> u.Quantity | None:
        """(n,) ``E - E0 - sum W``, J, under effects that do work; None otherwise."""
        b = self._si.energy_balance
        return None if b is None else _with_unit(b, u.J)

    def relative_energy_balance(self) -> np.ndarray | None:
        """(E - E0 - sum W) / |E0| of every record (plain array), or None for conservative scenes."""
        return self._si.relative_energy_balance()

    def relative_energy_error(self) -> np.ndarray:
        """The relative energy error of every record.

        Returns
        -------
        ndarray
            (E - E0) / |E0|, shape (n,), a plain array.
        """
        return self._si.relative_energy_error()

    def relative_energy_error_range(self) -> np.ndarray:
        """The least and the greatest relative energy error over each record interval.

        Returns
        -------
        ndarray
            (n, 2) plain array: (E_min - E0) / |E0| and (E_max - E0) / |E0| over the steps
            of the interval that ends at each record (:attr:`energy_range`); it brackets
            :meth:`relative_energy_error`.
        """
        return self._si.relative_energy_error_range()

    def relative_angular_momentum_error(self) -> np.ndarray:
        """The relative angular-momentum error of every record.

        Returns
        -------
        ndarray
            |L - L0| / |L0|, shape (n,), a plain array.
        """
        return self._si.relative_angular_momentum_error()

    def mean_newton_iterations(self) -> float:
        """Mean Newton iterations per body and sub-step over the run.

        Returns
        -------
        float
            The mean of :attr:`newton_iterations` over the record intervals; 0 with fewer
            than two records.
        """
        return self._si.mean_newton_iterations()
