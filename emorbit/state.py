"""What a simulation's bodies are now: a body's state, the total invariants and osculating
elements, measured on the current state of every system (a structure not yet built is
measured on a built copy). :class:`StateQueries` is a base class of
:class:`emorbit.Simulation`; it reads the simulation's ``systems``, ``names``, ``field``,
``gm`` and ``center``.
"""

from __future__ import annotations

import copy

import numpy as np

from .errors import InputError
from .orbits import OrbitalElements, elements

__all__ = ["StateQueries"]


class StateQueries:
    """The current state of a simulation's bodies: :meth:`state`, :meth:`energy`,
    :meth:`momentum`, :meth:`angular_momentum` and :meth:`elements`."""

    def _measured(self) -> list:
        """The systems now; a structure not yet built is measured on a built copy (it stays open)."""
        out = []
        for s in self.systems:
            if s is self.structure and not s._built:
                s = copy.deepcopy(s)
                s.build()
            out.append(s)
        return out

    def state(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """The current position and velocity of a body's centre of mass.

        Parameters
        ----------
        name : str
            The body.

        Returns
        -------
        position, velocity : ndarray
            (3,) arrays, m and m/s.

        Raises
        ------
        InputError
            No body of that name.
        """
        if name not in self.names:
            raise InputError("name", f"no body named {name!r}; bodies: {', '.join(self.names)}")
        s = next(s for s in self._measured() if name in s.names)
        d = s.datasets(s.current(), 1)[name]
        return d["position"][0].copy(), d["velocity"][0].copy()

    def _rigid_pose(self, name: str):
        """A rigid body's centre (m), attitude (body to space) and mass points now, in its own
        system or in a structure; None where ``name`` is no rigid body."""
        rigid, st = self.rigid, self.structure
        if rigid is not None and name in rigid.names:
            b = rigid.names.index(name)
            return rigid.q[b, :3], rigid.q[b, 3:].reshape(3, 3).T, rigid.points[b]
        if st is not None and name in st.names and st._body(name)["kind"] == "rigid":
            centre, *axes = (st._u[k] for k in st._body(name)["slots"])
            return centre, np.column_stack(axes), st._body(name)["points"]
        return None

    def _invariants_now(self):
        recs = [(s, s.current()) for s in self._measured()]
        if self.effects.time_dependent():  # potentials that follow the clock
            self._prepare_effects(1, self.plan.gammas)
            for _, rec in recs:
                rec.t = np.array([self.time])
        parts = [s.invariants(rec, 1, self.gm, self.center) for s, rec in recs]
        return [sum(p[j] for p in parts)[0] for j in range(3)]

    def energy(self) -> float:
        """Total energy of all bodies now.

        Returns
        -------
        float
            J.
        """
        return float(self._invariants_now()[0])

    def momentum(self) -> np.ndarray:
        """Total linear momentum now.

        Returns
        -------
        ndarray
            (3,) kg m/s.
        """
        return self._invariants_now()[1]

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the field's centre now.

        Returns
        -------
        ndarray
            (3,) kg m^2/s.
        """
        return self._invariants_now()[2]

    def elements(self, name: str, si: bool = False) -> OrbitalElements:
        """Osculating elements of a body's centre of mass now, as :meth:`Result.elements
        <emorbit.result.Result.elements>` gives them for every record.

        Parameters
        ----------
        name : str
            The body.
        si : bool
            Plain floats in m and rad instead of Quantities.

        Returns
        -------
        OrbitalElements
            Scalar Quantities (see :mod:`emorbit.orbits`): ``a`` in m (negative for a
            hyperbolic state), ``e`` dimensionless, ``i``, ``raan``, ``argp``, ``nu`` and ``M``
            in rad; with ``si`` plain floats.

        Raises
        ------
        InputError
            No field, or no body of that name.
        """
        if self.field is None:
            raise InputError("field", "orbital elements need a central field")
        x, v = self.state(name)
        el = OrbitalElements(*map(float, elements(x, v, self.field.gm, self.field.center)))
        return el if si else el.with_units()
