"""A finite burn: constant thrust and specific impulse over a window (``[[effect]] kind = "thrust"``).

A burn pushes one body with thrust T (N) from ``start`` to ``end`` (s from time 0 of the
run's clock). A point mass is pushed along a direction fixed in the scene's axes (``frame =
"inertial"``) or in the local frame of its motion (``"rsw"``: radial, along-track in the
orbit plane, orbit normal; ``"vnc"``: velocity, orbit normal, their cross product). A rigid
body is pushed through a thruster fixed in it (``frame = "body"``): at ``point`` (body
axes, from the centre of mass) along ``direction`` (body axes), hence with the torque ``r x
F``; it loses its mass evenly, its inertia in proportion. An elastic body is pushed at one
of its nodes (``node``), along a direction in the node's own inertial, RSW or VNC frame,
its mass held (no ``isp``). With a specific
impulse ``isp`` the body's mass falls at ``q = T / (isp g0)`` kg/s (g0 the standard gravity
of :data:`astropy.constants.g0`), and over each sub-step from ta to tb the velocity changes
by the rocket equation's ``dv = isp g0 ln(m(ta) / m(tb))`` exactly; without it the mass is
held and ``dv = T (tb - ta) / m`` (:mod:`emorbit.kernels.effects.thrust`). A scene may name
several burns; the burns of one body may not overlap in time, and each one starts from the
mass the earlier ones leave.

Steps land on each burn's start and end: fixed steps must divide them (adaptive steps: the
record interval must), or the run is refused naming the burn, so no step straddles the
switch. A burn may instead start at an event of the run (``start_event``, its label) and end
after a ``duration`` or at another event (``end_event``): such an event splits its step
where it is located, as an impulse does (:mod:`emorbit.event_run`), fires once, and the burn
switches there (:meth:`Thrust.on_event`); a duration's end is the time event
``<start_event>.end``, added when the burn starts. A resumed run replays its log, so its
burns start and end where they did. The mass enters the force alone: the bodies' masses in the run file, the energy and
the work are those of the body at its initial mass m0, and the step keeps the balance ``m0
(eps - eps0) - m0 sum dv e . (x1 - x0) / h = 0`` (``eps = v^2 / 2 + U`` per unit mass) to
round-off (``invariants/energy_balance``; ``invariants/work_thrust`` is the burn's term).
The body's true energy is ``m(t) eps``; :meth:`Thrust.mass` gives ``m(t)``, and the run
records the ledger (``invariants/ledger_*``, ``docs/methods.md``) that splits the change of
``m(t) eps`` into the work done on the body at its true mass and the energy the propellant
carries away, its balance at round-off. Other effects' coefficients per unit mass (drag's
``Cd A / m``, radiation's ``Cr A / m``) stay those of the initial mass.

References: H. D. Curtis, Orbital Mechanics for Engineering Students, 3rd ed. (2014),
section 6.11 (finite burns, the rocket equation); D. A. Vallado, Fundamentals of
Astrodynamics and Applications, 4th ed. (2013), section 3.3 (the RSW and NTW/VNC frames).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..keys import Key
from ..units import to_si, vector_to_si
from .base import AT_POINTS, ON_SURFACES, Effect, Pieces

__all__ = ["Thrust", "FRAMES", "MAX_THRUST"]

#: the frames a burn's direction may be given in (body: a rigid body's own axes)
FRAMES = ("inertial", "rsw", "vnc", "body")
#: the largest thrust, N (a Saturn V's first stage gives 3.5e7 N)
MAX_THRUST = 1e9
_KEYS = (
    Key("body", True, "string", "", "a point mass or a rigid body of the scene", "the body the burn pushes"),
    Key("thrust", True, "force (N)", "", f"> 0, at most {MAX_THRUST:g}", "the thrust T"),
    Key("start", False, "time (s)", "", "a time; give start or start_event",
        "when the burn starts, s from time 0 of the run's clock"),
    Key("start_event", False, "string", "", "the label of an event of the run; give start or start_event",
        "the burn starts when this event happens (the first time)"),
    Key("end", False, "time (s)", "", "after start (with start only); give end, duration or end_event",
        "when the burn ends"),
    Key("duration", False, "time (s)", "", "> 0; give end, duration or end_event", "how long the burn lasts"),
    Key("end_event", False, "string", "", "the label of an event of the run; give end, duration or end_event",
        "the burn ends when this event happens after its start"),
    Key("isp", False, "time (s)", "none: the mass is held", "> 0",
        "the specific impulse: the mass falls at T / (isp g0), and dv follows the rocket equation"),
    Key("frame", False, "string", '"vnc" (a point mass), "body" (a rigid body)',
        '"inertial", "rsw", "vnc" (point masses); "body" (rigid bodies)', "the frame of direction"),
    Key("direction", False, "3 numbers", "[1, 0, 0]", "a vector other than 0 (normalised)",
        "the thrust's direction in frame: [1, 0, 0] in vnc is along the velocity"),
    Key("point", False, "3 lengths (m)", "[0, 0, 0] m, the centre of mass", "rigid bodies only",
        "where the thrust acts, in the body's axes from its centre of mass"),
    Key("node", False, "integer", "", "a node of the elastic body (0 first); elastic bodies only, required there",
        "the node the thrust acts on"),
)  # fmt: skip


class Thrust(Effect):
    """A finite burn as an effect: ``p`` as :mod:`emorbit.kernels.effects.thrust` (its mass
    terms filled by :meth:`bind`).

    Attributes
    ----------
    body : str
        The body it pushes.
    start, end : float
        Its window, s.
    thrust : float
        N.
    isp : float or None
        s (None: no mass flow).
    mass_start, mass_end : float
        The body's mass at the start and the end of the burn, kg (after :meth:`bind`).
    """

    NAME = "thrust"
    SUMMARY = "a finite burn: constant thrust and specific impulse over a window, the mass falling"
    KEYS = _KEYS
    ACTS = {"point": AT_POINTS, "rigid": ON_SURFACES, "elastic": ON_SURFACES}
    CONSERVES: tuple[str, ...] = ()
    MULTIPLE = True
    SAME_KEY = "start"
    EXPLICIT = False
    OWN_FACETS = True
    PIECES = Pieces(
        "emorbit.kernels.effects.thrust",
        force="thrust_piece",
        prepare="thrust_prepare",
        facet="thrust_facet",
        mass="thrust_mass",
    )
    POTENTIAL = "none: a burn does work W = sum m0 dv e . (x1 - x0) / h, recorded as invariants/work_thrust"
    DISCRETE_FORCE = "F = (dv / h) e, dv = isp g0 ln(m(ta) / m(tb)) (or T (tb - ta) / m), e in its frame at x_m"
    JACOBIAN = "left out (a local frame's turn with x1, of order |F| / (|v| h))"

    mass_start = mass_end = float("nan")
    duration = None
    #: the labels of its start_event and end_event, where given
    triggers: dict = {}
    _named: tuple = ()

    def scratch_size(self, n_points: int) -> int:
        return 2  # the sub-step's dv and mean mass change

    def same_as(self, other) -> bool:
        return False  # another burn; one that overlaps this one in time is refused by bind()

    def landing_times(self, t0: float, t1: float) -> np.ndarray:
        """The burn's start and end where they lie in ``(t0, t1]`` and are times of the
        scene (an event's time is a step's end already: its step is split there)."""
        times = [self.start] if "start_event" not in self.triggers else []
        if not self.triggers:
            times.append(self.end)
        return np.array([t for t in times if t0 < t <= t1], float)

    @property
    def mass_flow(self) -> float:
        """kg/s (0 without isp)."""
        from astropy.constants import g0

        return 0.0 if self.isp is None else self.thrust / (self.isp * float(g0.si.value))

    def bind(self, kinds: dict, masses: dict, named) -> None:
        """Take the body's mass at the burn's start: its initial mass less what its earlier
        burns expel.

        Raises
        ------
        InputError
            Another burn of the body overlaps this one in time, or the burn would expel more
            mass than the body has, naming its window.
        """
        self._check_overlap(named)
        kind = kinds.get(self.body)
        if kind != "elastic" and self.node is not None:
            raise InputError(f"{self.key}.node", f"{self.body!r} is not an elastic body: node is for elastic bodies")
        if kind == "elastic":
            for name, bad in (("isp", self.isp is not None), ("point", self.point is not None),
                              ("frame", self.frame == "body"), ("node", self.node is None)):  # fmt: skip
                if bad:
                    raise InputError(
                        f"{self.key}.{name}",
                        f"{self.body!r} is an elastic body: a burn pushes one of its nodes (give node), in the "
                        '"inertial", "rsw" or "vnc" frame, its mass held (no isp, no point)',
                    )
            self.p[6] = float(FRAMES.index(self.frame or "vnc"))
        elif kind == "rigid":
            if self.frame not in (None, "body"):
                raise InputError(
                    f"{self.key}.frame", f'a rigid body\'s thruster is fixed in it: frame = "body", not {self.frame!r}'
                )
            self.p[6] = float(FRAMES.index("body"))
        else:
            if self.frame == "body" or self.point is not None:
                raise InputError(
                    f"{self.key}.{'point' if self.point is not None else 'frame'}",
                    f'{self.body!r} is a point mass: it has no body axes (frame "inertial", "rsw" or "vnc")',
                )
            self.p[6] = float(FRAMES.index(self.frame or "vnc"))
        burns = [e for e in named if isinstance(e, Thrust)]
        self.p[14] = -1.0 - burns.index(self)
        self.p[13] = float(masses.get(self.body, 1.0))  # an elastic body's burn holds its mass: 1
        self._named = tuple(named)
        self._chain()

    def _check_overlap(self, named) -> None:
        for e in named:
            if isinstance(e, Thrust) and e is not self and e.body == self.body:
                if e.start < self.end and self.start < e.end:
                    raise InputError(
                        f"{self.key}.{'start_event' if 'start_event' in self.triggers else 'start'}",
                        f"the burn ({self.start!r} s to {self.end!r} s) overlaps {e.key}'s ({e.start!r} s to "
                        f"{e.end!r} s) on {self.body!r}: the burns of one body follow one another",
                    )

    def _chain(self) -> None:
        """Set the mass terms of this body's burns whose start is known, in time order: each
        starts from what the earlier ones leave (an open end leaves the rest unknown)."""
        burns = sorted((e for e in self._named if isinstance(e, Thrust) and e.body == self.body), key=lambda e: e.start)
        m0 = self.p[13]
        mass = m0
        for e in burns:
            if not math.isfinite(e.start):
                break
            e.mass_start = mass
            e.mass_end = mass - e.mass_flow * (e.end - e.start) if math.isfinite(e.end) else math.nan
            if not e.mass_end > 0.0 and math.isfinite(e.end):
                raise InputError(
                    f"{e.key}.{'end' if 'end' in e.table else 'duration'}",
                    f"the burn expels {e.mass_flow * (e.end - e.start)!r} kg, and {e.body!r} has {mass!r} kg "
                    "left: shorten it or raise isp",
                )
            e.p[0], e.p[1] = e.start, e.end
            e.p[2] = mass / m0
            e.p[3] = e.mass_flow / m0
            e.p[5] = e.thrust / mass
            e.p[13] = m0
            mass = e.mass_end

    def events_heard(self) -> tuple[tuple[str, str], ...]:
        """Its start_event and end_event."""
        return tuple((f"{self.key}.{k}", label) for k, label in self.triggers.items())

    def on_event(self, label: str, t: float, events) -> None:
        """Start at its start_event (the first time; with a duration, add the time event of
        its end, labelled ``<start_event>.end``), end at its end_event after its start."""
        if label == self.triggers.get("start_event") and not math.isfinite(self.start):
            self.start = t
            if self.duration is not None:
                self.end = t + self.duration
                _switch_at(events, self.end, f"{label}.end", f"{self.key}.duration")
            self._check_overlap(self._named)
            self._chain()
            self.attach(events)
        elif label == f"{self.label}.empty":
            raise InputError(
                f"{self.key}.end_event",
                f"the burn has expelled 99.9 % of {self.body!r}'s {float(self.mass_start)!r} kg at t = {t!r} s, before "
                f"{self.triggers['end_event']!r} happens: give it a duration, or raise isp",
            )
        elif label == self.triggers.get("end_event") and math.isfinite(self.start) and not math.isfinite(self.end):
            self.end = t
            self._chain()
        elif label == f"{self.triggers.get('start_event')}.end" and self.duration is not None:
            self.end = t  # the located end: the step is split there
            self._chain()

    def attach(self, events) -> None:
        """A burn that ends at an event and expels mass: add the time event at which its body
        would have 0.1 % of its mass left (``<label>.empty``), where the run stops naming
        end_event."""
        if not (math.isfinite(self.start) and "end_event" in self.triggers and self.mass_flow > 0.0):
            return
        empty = self.start + 0.999 * self.mass_start / self.mass_flow
        _switch_at(events, empty, f"{self.label}.empty", f"{self.key}.end_event")

    def own_facets(self, body_kind: str, name: str) -> np.ndarray:
        """A rigid body's thruster: a facet of area 0 at ``point`` with the direction as its
        normal, marked (k3) as this burn's; an elastic body's: its node and the marked
        coefficients."""
        if name != self.body or body_kind not in ("rigid", "elastic"):
            return np.zeros((0, 11 if body_kind == "rigid" else 5))
        if body_kind == "elastic":
            return np.array([[float(self.node), 0.0, 0.0, 0.0, self.p[14]]])
        point = np.zeros(3) if self.point is None else self.point
        return np.array([[*point, *self.p[7:10], 0.0, 0.0, 0.0, 0.0, self.p[14]]])

    def mass(self, t) -> np.ndarray:
        """The body's mass at times ``t`` (s) as this burn leaves it (kg; the mass at its start
        before it), after :meth:`bind`."""
        tau = np.clip(np.asarray(t, float) - self.start, 0.0, self.end - self.start)
        return self.mass_start - self.mass_flow * tau

    def mass_lost(self, t) -> dict:
        """The mass this burn has expelled from its body by times ``t``: {body: (len(t),) kg}
        (0 before it starts; {} without isp)."""
        t = np.atleast_1d(np.asarray(t, float))
        if self.mass_flow == 0.0:
            return {}
        if not math.isfinite(self.start):
            return {self.body: np.zeros(t.shape)}
        return {self.body: self.mass_flow * np.clip(t - self.start, 0.0, self.end - self.start)}

    def facts(self) -> dict:
        return {
            "body": self.body, "start": self.start, "end": self.end, "thrust": self.thrust,
            "isp": self.isp, "mass_start": self.mass_start, "mass_end": self.mass_end,
        }  # fmt: skip

    @classmethod
    def from_table(cls, table, context) -> Thrust:
        """A burn from ``body``, ``thrust``, ``start``, ``end`` or ``duration``, ``isp``,
        ``frame`` and ``direction``.

        Raises
        ------
        InputError
            A body that is not a string or not in the scene, a thrust not in (0, 1e9] N, a
            window that ends before it starts, both or neither of end and duration, an isp
            not > 0, an unknown frame or a zero direction.
        """
        key, strict = context.key, context.strict
        body = table.get("body")
        if not isinstance(body, str) or not body.strip():
            raise InputError(f"{key}.body", f"the name of a point mass expected, got {body!r}")
        if context.bodies is not None and body not in context.bodies:
            raise InputError(f"{key}.body", f"no body named {body!r}; bodies: {', '.join(context.bodies)}")
        thrust = to_si(table.get("thrust"), "force", f"{key}.thrust", strict=strict, positive=True)
        if thrust > MAX_THRUST:
            raise InputError(f"{key}.thrust", f"at most {MAX_THRUST:g} N expected, got {thrust!r} N")
        if ("start" in table) == ("start_event" in table):
            raise InputError(key, "give the burn's start or its start_event (one of them)")
        if sum(k in table for k in ("end", "duration", "end_event")) != 1:
            raise InputError(key, "give the burn's end, its duration or its end_event (one of them)")
        triggers = {k: _label(table, k, key) for k in ("start_event", "end_event") if k in table}
        start = to_si(table["start"], "time", f"{key}.start", strict=strict) if "start" in table else math.inf
        duration = None
        if "duration" in table:
            duration = to_si(table["duration"], "time", f"{key}.duration", strict=strict, positive=True)
        end = start + duration if duration is not None else math.inf
        if "end" in table:
            if "start_event" in table:
                raise InputError(
                    f"{key}.end", "a burn that starts at an event ends after a duration or at an end_event"
                )
            end = to_si(table["end"], "time", f"{key}.end", strict=strict)
            if not end > start:
                raise InputError(f"{key}.end", f"the burn ends at {end!r} s, not after its start at {start!r} s")
        isp = None
        if "isp" in table:
            isp = to_si(table["isp"], "time", f"{key}.isp", strict=strict, positive=True)
        frame = table.get("frame")
        if frame is not None and frame not in FRAMES:
            raise InputError(f"{key}.frame", f"one of {', '.join(map(repr, FRAMES))} expected, got {frame!r}")
        direction = vector_to_si(table.get("direction", [1.0, 0.0, 0.0]), "dimensionless", f"{key}.direction")
        norm = float(np.linalg.norm(direction))
        if not norm > 0.0:
            raise InputError(f"{key}.direction", f"a vector other than 0 expected, got {direction.tolist()!r}")
        center = context.field.center if context.field is not None else (0.0, 0.0, 0.0)
        from astropy.constants import g0

        ve = 0.0 if isp is None else isp * float(g0.si.value)
        point = None
        if "point" in table:
            point = vector_to_si(table["point"], "length", f"{key}.point", strict=strict)
        p = [start, end, 1.0, 0.0, ve, 0.0, 0.0, *(direction / norm), *center, 0.0, 0.0]
        effect = cls(table, p, bodies=[body])
        effect.duration, effect.triggers = duration, triggers
        node = table.get("node")
        if node is not None and (isinstance(node, bool) or not isinstance(node, (int, np.integer)) or node < 0):
            raise InputError(f"{key}.node", f"a node's index (an integer >= 0) expected, got {node!r}")
        effect.frame, effect.point, effect.node = frame, point, node
        effect.body, effect.start, effect.end, effect.thrust, effect.isp = body, start, end, thrust, isp
        return effect


def _switch_at(events, t: float, label: str, key: str) -> None:
    """Add the time event ``label`` at t (s) that splits its step for a burn, unless the run has
    it already (a resumed run replays the event that added it)."""
    if all(e.label != label for e in events.events):
        event = events.add("time", value=t, label=label, key=key)
        event.acts, event.added_by = True, key


def _label(table: dict, name: str, key: str) -> str:
    """An event's label from a burn's table."""
    label = table[name]
    if not isinstance(label, str) or not label:
        raise InputError(f"{key}.{name}", f"the label of an event of the run expected, got {label!r}")
    return label
