"""Events: zeros of a function of the state, found on every step and located to round-off in time.

An event is a zero crossing of a scalar function ``g`` of the run's state at time t. For a
body b, ``x`` and ``v`` are its position and velocity (a rigid or elastic body's centre of
mass), ``c`` the field's centre, R its radius:

=============  ==========================================  ======================
kind           g                                           direction by default
=============  ==========================================  ======================
``radius``     ``|x - c| - value``                         either
``altitude``   ``|x - c| - R - value``                     either
``periapsis``  ``(x - c) . v``                             rising (only)
``apoapsis``   ``(x - c) . v``                             falling (only)
``node``       ``(x - c)_z`` (the scene's z axis)          either (rising: ascending)
``time``       ``t - value``                               rising (only)
``distance``   ``|x - x_other| - value``                   either
``eclipse``    ``|d_perp| - R`` where ``d . s < 0``,       either (falling: entry)
               else ``R + d . s`` (``d = x - c``)
=============  ==========================================  ======================

``eclipse`` is by default the central body's cylindrical shadow: ``s`` is the unit vector to
the Sun, ``d_perp = d - (d . s) s``; g is continuous across the shadow's edge (it changes
sign only there). With ``shadow = "penumbra"`` or ``"umbra"`` it is an edge of the conical
shadow that radiation pressure's default shadow model has (the plane-disc model): seen from
the body, the Sun's disc of angular radius ``a = asin(R_sun / |S - d|)`` and the central
body's of ``b = asin(R / |d|)`` lie ``c`` apart (S the Sun's position), and ``g = c - (a +
b)`` (the penumbra's edge: the Sun starts to be covered) or ``g = c - (b - a)`` (the umbra's:
it is covered whole), both continuous. R_sun is astropy's IAU 2015 nominal solar radius. The
Sun's direction is ``sun`` (fixed, in the scene's axes, at 1 au for the conical edges) or, by
default, the Sun's geocentric position from :class:`emorbit.effects.ephemeris.EphemerisTable`
(astropy's builtin ephemeris, sampled hourly from the run's epoch, which it then needs).

``direction`` picks the crossings that count: ``rising`` (g from below zero to zero or
above), ``falling``, or ``either``.

Finding. The driver evaluates every event's g after every step (the states of the step's
records) and compares its sign with the value after the step before. A crossing in step n
(from t0 to t0 + dt) is located by re-running that step from its start as one step of
length tau, 0 < tau <= dt, an ordinary step of the run's method and order, and solving
g(tau) = 0 by the Illinois form of regula falsi (M. Dowell, P. Jarratt, BIT 11 (1971)
168-174) on the bracket [0, dt], until the bracket is 4 ulp of t wide or g is zero. The event
is the state after the step of length tau on the crossing's side: a state the method
reached, so an em run keeps its energy (or energy balance) there exactly. Two crossings of
one event within one step (g returning to its sign) are not seen: the step is the grid.
With adaptive steps the grid is the record grid's unit ``dt``: the adaptive kernel takes its
own steps over each unit, and a crossing's unit is re-run as one adaptive span of length
tau, landing there.

A stopping event (``stop``) ends the run at its state: the status is ``stopped``, with the
event named. An impulsive manoeuvre (``dv``, in the frame ``frame``) fires once: the step is
split at the event, the impulse added to the body's velocity (a rigid body's centre of mass),
and the rest of the step, ``dt - tau``, taken from there, so the run stays on its step grid.
Its work, ``m (|v + dv|^2 - |v|^2) / 2``, is logged with it and counted in the energy balance
``E - E0 - W`` as ``work_manoeuvres``. Frames, at the body's state (x - c, v): ``inertial``
(the scene's axes), ``rsw`` (radial, along-track in the orbit plane, orbit normal) and
``vnc`` (velocity, orbit normal, their cross product). ``after`` arms an event only once the
event of that label has happened (a Hohmann transfer's second burn at the apoapsis after
the first). An event that starts or ends a burn (``[[effect]] kind = "thrust"`` with
``start_event`` or ``end_event``) splits its step the same way, fires once, and the burn
switches there. An effect may add events that steps land on (:attr:`Event.lands`): each
crossing splits its step there, every time, so that the effect's force is smooth within
every step (radiation pressure's ``land``: its shadow's edges). Other events leave the run's
states as they are (the located step is taken from a copy) and are logged:
:attr:`EventSet.log`, the run file's ``events/`` group, ``Result.events``.

Data layout: :class:`Event` holds SI values; :meth:`EventSet.values` takes (m,) times and the
systems' datasets for m records and returns (m, events) float64.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .units import to_si, vector_to_si

__all__ = ["KINDS", "DIRECTIONS", "DIRECTION_NAMES", "SHADOWS", "MAX_EVENTS", "Event", "EventSet", "locate"]

#: kind -> (the unit kind of its value or None, the default direction, whether it names a body)
KINDS = {
    "radius": ("length", 0, True),
    "altitude": ("length", 0, True),
    "periapsis": (None, 1, True),
    "apoapsis": (None, -1, True),
    "node": (None, 0, True),
    "time": ("time", 1, False),
    "distance": ("length", 0, True),
    "eclipse": (None, 0, True),
}
#: direction names -> the sign of g's change that counts (0: either)
DIRECTIONS = {"rising": 1, "falling": -1, "either": 0}
#: the most events a run may have
MAX_EVENTS = 64
#: trials at most when locating a crossing (each re-runs one step)
MAX_LOCATE = 100
#: the frames an impulse may be given in
FRAMES = ("inertial", "rsw", "vnc")
#: the shadow edges an eclipse event may follow: the cylindrical shadow's, or the conical
#: shadow's penumbra or umbra
SHADOWS = ("cylindrical", "penumbra", "umbra")


@dataclass
class Event:
    """One event.

    Attributes
    ----------
    kind : str
        A key of :data:`KINDS`.
    body : str or None
        The body whose state g reads (None for ``time``).
    value : float
        The level, SI (m for lengths, s for time; 0 where the kind has none).
    direction : int
        1 rising, -1 falling, 0 either.
    stop : bool
        Whether the run ends at it.
    other : str or None
        The second body of ``distance``.
    label : str
        Its name in the log (default ``<kind>[<i>]``, or as given).
    key : str
        Its name in errors (``event[0]``).
    dv : ndarray or None
        An impulse (3,) m/s in ``frame``, or None.
    frame : str
        A name of :data:`FRAMES`.
    after : str or None
        The label of the event that arms this one.
    shadow : str
        An eclipse's edge, a name of :data:`SHADOWS`.
    lands : bool
        Whether steps land on it: each crossing splits its step there (as an impulse does),
        every time, and nothing acts (an effect's discontinuity: radiation pressure's shadow
        edges).
    added_by : str or None
        The key of the effect that added it (a scene's text leaves it out: the effect adds
        it again).
    sun_path, occulting, sun_radius
        An eclipse's Sun from an effect's own path (a callable of times giving (m, 3) m from
        the centre), and its occulting and solar radii (m; None: the field's and the IAU's).
    acts : bool
        Whether an effect acts at it (a burn starts or ends there): like an impulse, it
        splits its step and fires once.
    """

    kind: str
    body: str | None
    value: float
    direction: int
    stop: bool
    other: str | None
    label: str
    key: str
    dv: np.ndarray | None = None
    frame: str = "inertial"
    after: str | None = None
    sun: np.ndarray | None = None
    epoch: object = None
    _table: object = None
    #: whether an effect acts at it (a burn starts or ends): the step is split there, once
    acts: bool = False
    shadow: str = "cylindrical"
    lands: bool = False
    added_by: str | None = None
    sun_path: object = None
    occulting: float | None = None
    sun_radius: float | None = None

    @property
    def splits(self) -> bool:
        """Whether it splits its step where it is located: an impulse or an event an effect
        acts at (once), or one steps land on (every time)."""
        return self.dv is not None or self.acts or self.lands

    def sun_direction(self, times) -> np.ndarray:
        """Unit vectors to the Sun at ``times`` (s from the epoch): (m, 3)."""
        p = self.sun_position(times)
        return p / np.linalg.norm(p, axis=-1, keepdims=True)

    def sun_position(self, times) -> np.ndarray:
        """The Sun's position from the field's centre at ``times`` (s from the epoch): (m, 3)
        m (a fixed direction at 1 au)."""
        times = np.asarray(times, float)
        if self.sun_path is not None:
            return np.asarray(self.sun_path(times), float)
        if self.sun is not None:
            from astropy.constants import au

            return np.broadcast_to(self.sun * float(au.si.value), (times.size, 3))
        table = self._table
        if table is None or times.min() < table.start or times.max() > table.end:
            from astropy.time import TimeDelta

            from .effects.ephemeris import EphemerisTable

            lo, hi = float(times.min()) - 3600.0, float(times.max()) + 10 * 86400.0
            start, end = (self.epoch + TimeDelta(t, format="sec") for t in (lo, hi))
            table = self._table = EphemerisTable("sun", start, end, 3600.0, epoch=self.epoch, check=False)
        return table.position(times)

    def impulse(self, x, v, center) -> np.ndarray:
        """The impulse in the scene's axes at the body's position ``x`` and velocity ``v``."""
        if self.frame == "inertial":
            return np.array(self.dv, float)
        r, v = np.asarray(x, float) - center, np.asarray(v, float)
        h = np.cross(r, v)
        normal = h / np.linalg.norm(h)
        if self.frame == "rsw":
            radial = r / np.linalg.norm(r)
            axes = (radial, np.cross(normal, radial), normal)
        else:
            along = v / np.linalg.norm(v)
            axes = (along, normal, np.cross(along, normal))
        return self.dv[0] * axes[0] + self.dv[1] * axes[1] + self.dv[2] * axes[2]

    def g(self, times, data, center, radius) -> np.ndarray:
        """g at m records: ``times`` (m,) s, ``data`` {body: {"position", "velocity": (m, 3)}}."""
        if self.kind == "time":
            return np.asarray(times, float) - self.value
        d = np.asarray(data[self.body]["position"], float) - center
        if self.kind == "radius":
            return np.linalg.norm(d, axis=1) - self.value
        if self.kind == "altitude":
            return np.linalg.norm(d, axis=1) - radius - self.value
        if self.kind in ("periapsis", "apoapsis"):
            return np.einsum("ij,ij->i", d, np.asarray(data[self.body]["velocity"], float))
        if self.kind == "node":
            return d[:, 2].copy()
        if self.kind == "eclipse" and self.occulting is not None:
            radius = self.occulting
        if self.kind == "eclipse" and self.shadow != "cylindrical":
            return self._conical(times, d, radius)
        if self.kind == "eclipse":
            s = self.sun_direction(times)
            along = np.einsum("ij,ij->i", d, s)
            across = np.linalg.norm(d - along[:, None] * s, axis=1)
            return np.where(along < 0.0, across - radius, radius + along)
        other = np.asarray(data[self.other]["position"], float)
        return np.linalg.norm(np.asarray(data[self.body]["position"], float) - other, axis=1) - self.value

    def _conical(self, times, d, radius) -> np.ndarray:
        """g of an edge of the conical shadow at the body's positions d (m, 3) from the centre."""
        from astropy.constants import R_sun

        q = self.sun_position(times) - d  # to the Sun, from the body
        sun = float(R_sun.si.value) if self.sun_radius is None else self.sun_radius
        a = np.arcsin(np.minimum(sun / np.linalg.norm(q, axis=1), 1.0))
        b = np.arcsin(np.minimum(radius / np.linalg.norm(d, axis=1), 1.0))
        c = np.arctan2(np.linalg.norm(np.cross(-d, q), axis=1), np.einsum("ij,ij->i", -d, q))
        return c - (a + b) if self.shadow == "penumbra" else c - (b - a)

    def describe(self) -> str:
        """The event in words, for messages: ``altitude of sat below 120000 m``."""
        what = {1: "rising through", -1: "falling through", 0: "crossing"}[self.direction]
        if self.kind == "time":
            return f"{self.label}: t = {self.value!r} s"
        if self.kind in ("periapsis", "apoapsis"):
            return f"{self.label}: {self.kind} of {self.body}"
        if self.kind == "eclipse":
            which = {1: "exit from ", -1: "entry into ", 0: "edge of "}[self.direction]
            shadow = "the shadow" if self.shadow == "cylindrical" else f"the {self.shadow}"
            return f"{self.label}: {which}{shadow} of {self.body}"
        if self.kind == "node":
            which = {1: "ascending ", -1: "descending ", 0: ""}[self.direction]
            return f"{self.label}: {which}node of {self.body}"
        level = f"{self.value!r} m"
        of = f"{self.body} and {self.other}" if self.kind == "distance" else self.body
        return f"{self.label}: {self.kind} of {of} {what} {level}"


@dataclass
class EventSet:
    """The run's events and the sign state between steps.

    Attributes
    ----------
    events : list of Event
    previous : ndarray or None
        g of each event after the last step taken (None before the first).
    log : list of dict
        The events found so far in this process: ``label``, ``kind``, ``body``, ``time`` (s),
        ``step`` (the step it fell in, counted from the run's origin) and ``state`` ({body:
        {"position", "velocity"}} at it, SI).
    """

    events: list = field(default_factory=list)
    previous: np.ndarray | None = None
    log: list = field(default_factory=list)
    #: the labels of the events that have happened (they arm ``after``; an impulse fires once)
    fired: set = field(default_factory=set)

    def __len__(self) -> int:
        return len(self.events)

    def __bool__(self) -> bool:
        return bool(self.events)

    def add(self, kind, *, body=None, value=None, direction=None, stop=False, other=None, label=None,
            dv=None, frame=None, after=None, sun=None, epoch=None, key=None, strict=False,
            has_radius=True, shadow=None) -> Event:  # fmt: skip
        """Check and add an event; see :meth:`emorbit.Simulation.add_event` for the keys.

        Raises
        ------
        InputError
            An unknown kind or direction, a body missing or given where it is not read, a
            value missing, not a quantity of the kind's unit or not finite, ``altitude`` in a
            field without a radius, ``distance`` without ``other``, a label used twice, more
            than :data:`MAX_EVENTS`.
        """
        key = key or f"event[{len(self.events)}]"
        if len(self.events) >= MAX_EVENTS:
            raise InputError(key, f"at most {MAX_EVENTS} events per run")
        if kind not in KINDS:
            raise InputError(f"{key}.kind", f"unknown event {kind!r}; known: {', '.join(KINDS)}")
        unit, default, needs_body = KINDS[kind]
        needs_body = needs_body or dv is not None  # an impulse acts on a body
        if needs_body and (not isinstance(body, str) or not body):
            raise InputError(f"{key}.body", f"a {kind} event reads a body's state: name the body, got {body!r}")
        if not needs_body and body is not None:
            raise InputError(f"{key}.body", f"a {kind} event reads no body, got {body!r}")
        if kind == "distance":
            if not isinstance(other, str) or not other or other == body:
                raise InputError(
                    f"{key}.other", f"a distance event needs a second body other than {body!r}, got {other!r}"
                )
        elif other is not None:
            raise InputError(f"{key}.other", f"only a distance event has a second body, got {other!r}")
        if unit is None:
            if value is not None:
                raise InputError(f"{key}.value", f"a {kind} event has no value, got {value!r}")
            level = 0.0
        else:
            if value is None:
                raise InputError(f"{key}.value", f"a {kind} event needs a value (a {unit}), e.g. {_EXAMPLE[unit]!r}")
            level = to_si(value, unit, f"{key}.value", strict=strict)
            if not math.isfinite(level):
                raise InputError(f"{key}.value", f"a finite {unit} expected, got {value!r}")
        if kind == "eclipse":
            if sun is not None:
                sun = np.asarray(vector_to_si(sun, "dimensionless", f"{key}.sun"), float)
                if not (np.all(np.isfinite(sun)) and np.linalg.norm(sun) > 0):
                    raise InputError(f"{key}.sun", f"a direction other than 0 expected, got {sun!r}")
                sun = sun / np.linalg.norm(sun)
            elif epoch is None:
                raise InputError(
                    f"{key}.sun",
                    "an eclipse needs the Sun: give its direction (sun) or the run's epoch (the ephemeris)",
                )
        elif sun is not None:
            raise InputError(f"{key}.sun", f"only an eclipse event has a Sun direction, got {sun!r}")
        if shadow is not None and (kind != "eclipse" or shadow not in SHADOWS):
            raise InputError(f"{key}.shadow", f"one of {', '.join(SHADOWS)}, for an eclipse, expected, got {shadow!r}")
        if kind in ("altitude", "eclipse") and not has_radius:
            raise InputError(f"{key}.kind", f"an {kind} is measured with the field's radius: give the [field] a radius")
        if direction is None:
            sign = default
        else:
            if direction not in DIRECTIONS:
                raise InputError(f"{key}.direction", f"one of {', '.join(DIRECTIONS)} expected, got {direction!r}")
            sign = DIRECTIONS[direction]
            if kind in ("periapsis", "apoapsis", "time") and sign != default:
                raise InputError(
                    f"{key}.direction", f"a {kind} event is {DIRECTION_NAMES[default]} only, got {direction!r}"
                )
        if not isinstance(stop, bool):
            raise InputError(f"{key}.stop", f"true or false expected, got {stop!r}")
        label = f"{kind}[{len(self.events)}]" if label is None else label
        if not isinstance(label, str) or not label or "/" in label:
            raise InputError(f"{key}.label", f"a name without '/' expected, got {label!r}")
        if any(e.label == label for e in self.events):
            raise InputError(f"{key}.label", f"a second event labelled {label!r}")
        impulse = None
        if dv is not None:
            if stop:
                raise InputError(f"{key}.dv", "an event either stops the run or fires an impulse, not both")
            impulse = np.asarray(vector_to_si(dv, "speed", f"{key}.dv", strict=strict), float)
            if not np.all(np.isfinite(impulse)):
                raise InputError(f"{key}.dv", f"three finite velocities expected, got {dv!r}")
        if frame is not None and (dv is None or frame not in FRAMES):
            raise InputError(f"{key}.frame", f"one of {', '.join(FRAMES)}, with dv, expected, got {frame!r}")
        if after is not None and (not isinstance(after, str) or after not in {e.label for e in self.events}):
            known = ", ".join(e.label for e in self.events) or "none yet"
            raise InputError(f"{key}.after", f"the label of an event before this one expected ({known}), got {after!r}")
        event = Event(kind, body, float(level), sign, stop, other, label, key, impulse, frame or "inertial", after, sun,
                      None if sun is not None else epoch, shadow=shadow or "cylindrical")  # fmt: skip
        self.events.append(event)
        self.previous = None
        return event

    @property
    def splitting(self) -> bool:
        """Whether an event splits its step (an impulse, a burn's switch, one steps land on)."""
        return any(e.splits for e in self.events)

    @property
    def impulses(self) -> bool:
        """Whether an event fires an impulse (the run then records ``work_manoeuvres``)."""
        return any(e.dv is not None for e in self.events)

    @property
    def impulse_work(self) -> float:
        """The work of the impulses logged so far, J (an exact sum: the same on a resume)."""
        return math.fsum(e["work"] for e in self.log)

    def resume_from(self, log: list) -> None:
        """Continue after the events of a file's log: they are logged, and have happened."""
        self.log = list(log)
        self.fired = {e["label"] for e in self.log}

    def check_bodies(self, names) -> None:
        """Refuse events whose bodies the run does not have, naming the key."""
        for e in self.events:
            for which, name in (("body", e.body), ("other", e.other)):
                if name is not None and name not in names:
                    raise InputError(f"{e.key}.{which}", f"no body named {name!r}; the bodies: {', '.join(names)}")

    def values(self, times, data, center, radius) -> np.ndarray:
        """g of every event at m records: (m, events)."""
        return np.stack([e.g(times, data, center, radius) for e in self.events], axis=1)

    def crossings(self, g) -> list[tuple[int, int, float, float]]:
        """The crossings in rows of g (m, events), each row a step after the one before (the
        row before the first: :attr:`previous`), in the order of their rows: [(row, event, g
        before, g after)]. Updates :attr:`previous` to the last row."""
        g = np.asarray(g, float)
        if not g.shape[0]:  # no steps (a chunk whose first step failed)
            return []
        before = np.vstack([g[:1] if self.previous is None else self.previous[None], g[:-1]])
        sign = np.array([e.direction for e in self.events])
        with np.errstate(invalid="ignore"):
            rising = (before < 0.0) & (g >= 0.0) & (sign >= 0)
            falling = (before > 0.0) & (g <= 0.0) & (sign <= 0)
        found = []
        for r, j in zip(*np.nonzero(rising | falling)):  # row by row: an event armed in a row counts after it
            e = self.events[j]
            if (e.after is None or e.after in self.fired) and not (e.splits and not e.lands and e.label in self.fired):
                found.append((int(r), int(j), float(before[r, j]), float(g[r, j])))
                self.fired.add(e.label)
        self.previous = g[-1].copy()
        return found


_EXAMPLE = {"length": "120 km", "time": "1 h"}
#: direction signs -> names
DIRECTION_NAMES = {sign: name for name, sign in DIRECTIONS.items()}


def locate(g_of_tau, dt: float, g0: float, g1: float, t0: float) -> float:
    """The step length tau in (0, dt] at which g crosses zero, to round-off in time.

    A bracket ``[lo, hi]`` keeps g0's sign at ``lo`` and g1's at ``hi``. Each trial is the
    inverse quadratic interpolant's root through the last three values of g (the secant's
    through the last two while there are fewer, or where the quadratic's root leaves the
    bracket), so the error shrinks with order about 1.8, not the 1.4 of the Illinois method;
    once the root is known within half the final width of an end, the trial goes just past
    that end (one ulp of dt, doubling while trials stay on its side, at most the half width),
    so the bracket closes from both sides at a state within round-off of the crossing (it
    stops when it is 4 ulp of t wide and its last trial moved ``hi``, or 4 ulp of dt); where
    two other trials in a row do not halve the least |g| so far, the next bisects the bracket.

    Parameters
    ----------
    g_of_tau : callable
        g after one step of length tau from the step's start (the run's method).
    dt : float
        The whole step, s.
    g0, g1 : float
        g at the step's start and after the whole step (signs differ, or g1 is zero).
    t0 : float
        The step's start time, s (the bracket stops at 4 ulp of t0 + dt).

    Returns
    -------
    float
        tau on the crossing's side: g(tau) is zero or has g1's sign, and the bracket's other
        end, with g0's sign, lies within the width below it.
    """
    lo, hi, glo, ghi = 0.0, float(dt), float(g0), float(g1)
    if ghi == 0.0:
        return hi
    width = 4.0 * math.ulp(abs(t0) + abs(dt)) + math.ulp(dt)
    near = 0.5 * width
    points = [(lo, glo), (hi, ghi)]  # the latest trials, the last one last
    best = min(abs(glo), abs(ghi))  # the least |g| so far
    slow = 0  # trials in a row that did not halve it
    past = math.ulp(dt)  # how far past an end the next trial near it goes
    fresh = False  # whether the last trial moved hi
    for _ in range(MAX_LOCATE):
        if hi - lo <= width and (fresh or hi - lo <= 4.0 * math.ulp(dt)):
            break
        tau = _trial(points, lo, hi, glo, ghi) if slow < 2 else 0.5 * (lo + hi)
        close = not lo + near <= tau <= hi - near
        if tau < lo + near:  # the root is known within the width: the trial just past lo
            tau = min(max(tau, lo + past), lo + near)
        elif tau > hi - near:
            tau = max(min(tau, hi - past), hi - near)
        past = 2.0 * past if close else math.ulp(dt)
        g = float(g_of_tau(tau))
        if g == 0.0:
            return tau
        if not g == g:  # the step failed (g is nan): on g0's side, and the next trial bisects
            lo, slow, fresh = tau, 2, False
            continue
        fresh = (g > 0.0) == (ghi > 0.0)
        if fresh:
            hi, ghi = tau, g
        else:
            lo, glo = tau, g
        points = [*points[-2:], (tau, g)]
        slow = 0 if close or abs(g) <= 0.5 * best else slow + 1
        best = min(best, abs(g))
    return hi


def _trial(points, lo: float, hi: float, glo: float, ghi: float) -> float:
    """The next trial of :func:`locate`: the root of the inverse quadratic interpolant
    through the last three trials ``points`` [(tau, g)], or of the secant through the last
    two, where it lies inside (lo, hi); else the secant's through the bracket's ends."""
    tau = math.nan
    if len(points) >= 3:
        (a, ga), (b, gb), (c, gc) = points[-3:]
        if ga != gb and gb != gc and ga != gc:
            tau = (
                a * gb * gc / ((ga - gb) * (ga - gc))
                + b * ga * gc / ((gb - ga) * (gb - gc))
                + c * ga * gb / ((gc - ga) * (gc - gb))
            )
    if not lo < tau < hi:
        (b, gb), (c, gc) = points[-2:]
        if gb != gc:
            tau = c - gc * (c - b) / (gc - gb)
    if not lo < tau < hi:
        tau = hi - ghi * (hi - lo) / (ghi - glo)
    return tau
