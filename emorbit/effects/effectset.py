"""A simulation's effects: :class:`EffectSet`, what every body system reads of them.

The set holds the central field's effect (where there is a field) and those a scene names,
checks them against each other and against the run (once or many times, an epoch, the
method), orders them (:data:`emorbit.effects.EFFECTS`' order, a kind named twice in the
order named), compiles them (:func:`emorbit.effects.program.compile_set`) and lays out
their parameters for the step kernels (:meth:`EffectSet.arrays`). Body systems ask it for
their points' coefficients (:meth:`EffectSet.coefficients`) and for the slots of the
effects whose work the step sums (:meth:`EffectSet.working`). Nothing here names an effect:
what differs between effects is each one's declaration.
"""

from __future__ import annotations

import sys

import numpy as np

from ..errors import InputError
from ..kernels.effects.signatures import SLICES
from .base import AT_POINTS, ON_SURFACES, Effect, check_left_out

#: the package, whose registry (``EFFECTS``) is complete by the time a set is asked for it
_PACKAGE = sys.modules[__name__.rpartition(".")[0]]

__all__ = ["EffectSet"]


class EffectSet:
    """The effects of one simulation.

    Parameters
    ----------
    field : CentralField or None
        The central field; its effect is the set's first.
    """

    def __init__(self, field):
        self.field = field
        self._named: list[Effect] = []  # the effects of add(), in the order named
        self._all = None  # (the registry's size, all), kept until the set changes
        self._memo: dict = {}  # what _of_all found, for the "all" it holds
        self._central = None
        if field is not None:
            from . import EFFECTS

            self._central = EFFECTS["central"].from_table({}, _Context(field))
            self._central.key = "field"

    # -- membership ----------------------------------------------------------------------
    def add(self, table: dict, key: str, bodies=None, strict: bool = False, folder: str = "") -> Effect:
        """Build an effect from its table and add it.

        Parameters
        ----------
        table : dict
            ``kind`` and its keys.
        key : str
            Its name in errors.
        bodies : list of str, optional
            The scene's body names (for effects that name bodies).
        strict : bool
            Require units.
        folder : str
            Where a relative ``file`` is found.

        Returns
        -------
        Effect

        Raises
        ------
        InputError
            What :func:`emorbit.effects.build` refuses; a second effect of a kind a scene may
            name once, or the same one twice (a third body named twice).
        """
        from . import build

        effect = build(table, self.field, key, bodies, strict, folder)
        same = [e for e in self._named if e.kind == effect.kind]
        if same and not type(effect).MULTIPLE:
            raise InputError(key, f"a scene names {effect.kind!r} once; this simulation has it already ({same[0].key})")
        for other in same:
            if effect.same_as(other):
                where = f"{key}.{type(effect).SAME_KEY}" if type(effect).SAME_KEY else key
                raise InputError(where, f"this simulation has the same {effect.kind!r} already ({other.key})")
        if same:
            effect.label = f"{effect.kind}_{len(same) + 1}"
        self._named.append(effect)
        self._all = None
        return effect

    def remove(self, effect: Effect) -> None:
        """Take an effect out again (one that a check refused after it was added)."""
        self._named = [e for e in self._named if e is not effect]
        self._all = None

    @property
    def named(self) -> tuple[Effect, ...]:
        """The effects beyond the central field, in the order named."""
        return tuple(self._named)

    @property
    def central(self) -> Effect | None:
        """The central field's effect (the first of :attr:`all`), or None in free space."""
        return self._central

    @property
    def all(self) -> tuple[Effect, ...]:
        """Every effect, the central field's first, in the order a step sums their forces."""
        registry = _PACKAGE.EFFECTS  # asked many times in every run: no import statement here
        key = len(registry)  # a user's registered effect ranks after the shipped ones
        if self._all is None or self._all[0] != key:
            rank = {k: i for i, k in enumerate(registry)}
            named = sorted(self._named, key=lambda e: rank.get(e.kind, len(rank)))
            self._all = (key, ((self._central,) if self._central is not None else ()) + tuple(named))
        return self._all[1]

    def __iter__(self):
        return iter(self.all)

    def __len__(self) -> int:
        return len(self.all)

    def __getitem__(self, i) -> Effect:
        return self.all[i]

    def kinds(self) -> tuple[str, ...]:
        """The kinds of :attr:`all`."""
        return tuple(e.kind for e in self.all)

    def beyond_field(self) -> bool:
        """Whether the set holds more than the central field (a scene named an effect)."""
        return bool(self._named)

    def acting_on(self, body_kind: str, how: str | None = None) -> list[Effect]:
        """The effects that act on a body kind (at its points or on its surfaces, or ``how``)."""
        return [e for e in self.all if e.acts_on(body_kind) and (how is None or e.acts_on(body_kind) == how)]

    def _of_all(self, name: str, fn):
        """``fn(all)`` kept until the set changes (a step's set-up and every record ask the
        same questions of it)."""
        effects = self.all
        memo = self._memo
        if memo.get("all") is not effects:
            memo.clear()
            memo["all"] = effects
        if name not in memo:
            memo[name] = fn(effects)
        return memo[name]

    def working(self) -> list[Effect]:
        """The effects whose work the step sums (their slots' order)."""
        return list(self._of_all("working", lambda effects: tuple(e for e in effects if type(e).does_work())))

    def ledger(self) -> bool:
        """Whether an effect of the set changes a body's mass (a burn): the work then has a
        ledger row after the working effects' (:mod:`emorbit.effects.program`), and the run
        records the mass ledger."""
        return self._of_all("ledger", lambda effects: any(type(e).changes_mass() for e in effects))

    def work_rows(self) -> int:
        """The rows of the step's work sums: one per working effect, and the ledger row."""
        return self._of_all("work_rows", lambda _: len(self.working()) + int(self.ledger()))

    def mass_lost(self, t) -> dict:
        """The mass the set's effects have taken from each body by times ``t`` (s):
        {body name: (len(t),) kg}."""
        lost: dict = {}
        for e in self.all:
            for name, kg in e.mass_lost(t).items():
                lost[name] = lost.get(name, 0.0) + kg
        return lost

    def with_potential(self) -> list[Effect]:
        """The effects with a potential energy (recorded as ``invariants/potential_<label>``)."""
        return [e for e in self.all if type(e).has_potential()]

    def spin(self):
        """The spin vector (rad/s, (3,) ndarray) of the central body whose turning field an
        effect names (its ``body_frame`` fact), or None: with it the records hold the Jacobi
        integral ``E - w . L`` (``invariants/jacobi``)."""
        for e in self.all:
            frame = e.facts().get("body_frame")
            if frame:
                return float(frame["rate"]) * np.asarray(frame["axes"], float)[:, 2]
        return None

    def pair_effects(self) -> list[Effect]:
        """The effects between pairs of points: they couple the bodies they reach."""
        return [e for e in self.all if type(e).pairs()]

    def conserves(self, what: str) -> bool:
        """Whether every effect of the set keeps ``what`` (e.g. ``"energy"``)."""
        return all(what in type(e).CONSERVES for e in self.all)

    def time_dependent(self) -> list[Effect]:
        """The effects that sample a path over a run's span before its steps."""
        return [e for e in self.all if e.time_dependent]

    def needs_epoch(self) -> list[Effect]:
        """The effects that need the run's epoch."""
        return [e for e in self.all if e.needs_epoch]

    # -- checks against the run ----------------------------------------------------------------
    def check_method(self, method: str, key: str = "method") -> None:
        """Refuse a method an effect cannot run with: one whose kernels step the central field
        alone (:attr:`~emorbit.integrators.Method.effects`), leapfrog kicks with forces
        that depend on the velocity (drag) or that act between pairs of bodies of other kinds,
        and tfe's stages with forces that act between pairs or change the mass (the body
        systems refuse what their stages do not take: :attr:`~emorbit.bodies.system.BodySystem.POINTS_ONLY`).

        Raises
        ------
        InputError
            Naming the method's key and the effect.
        """
        from ..integrators import get_method

        if self._named and not get_method(method).effects:
            e = self._named[0]
            raise InputError(
                key, f"method {method!r} steps the central field alone, and the run has {e.key} ({e.kind}); use em"
            )
        if method == "tfe":
            for e in self._named:
                cls = type(e)
                why = (
                    "acts between pairs of bodies" if cls.pairs()
                    else "changes the mass" if cls.changes_mass()
                    else ""
                )  # fmt: skip
                if why:
                    raise InputError(
                        key,
                        f"tfe evaluates forces at points of single bodies, and {e.key} ({e.kind}) {why}; use em",
                    )
        if method != "leapfrog":
            return
        for e in self._named:
            if not type(e).EXPLICIT:
                raise InputError(
                    key,
                    f"leapfrog kicks with forces at points, but {e.key} ({e.kind}) depends on the velocity; "
                    "use em or midpoint",
                )

    def check_bodies(self, names_by_kind: dict, masses: dict | None = None) -> None:
        """Refuse effects that name bodies that do not exist or act on body kinds they do not
        reach, and pair effects between fewer than two bodies; then let each effect read the
        bodies (:meth:`~emorbit.effects.base.Effect.bind`).

        Parameters
        ----------
        names_by_kind : dict
            {body kind: list of names} of the simulation's bodies.
        masses : dict, optional
            {name: kg} of the point masses and rigid bodies.

        Raises
        ------
        InputError
            Naming the effect's key.
        """
        every = [n for names in names_by_kind.values() for n in names]
        kind_of = {n: k for k, names in names_by_kind.items() for n in names}
        for e in self._named:
            for name in e.bodies or ():
                if name not in kind_of:
                    raise InputError(f"{e.key}.bodies", f"no body named {name!r}; bodies: {', '.join(every)}")
                if not e.acts_on(kind_of[name]):
                    raise InputError(f"{e.key}.bodies", f"{e.kind} does not act on {kind_of[name]} bodies ({name!r})")
            if type(e).pairs():
                reached = [n for n in every if e.reaches(n)]
                if len(reached) < 2:
                    raise InputError(
                        e.key, f"{e.kind} acts between bodies, and the scene has {len(reached)} it reaches: add another"
                    )
        for e in self._named:
            e.bind(kind_of, masses or {}, self.named)

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """Let every effect that follows a path sample it over ``t0`` to ``t1`` (s from the epoch)."""
        for e in self.time_dependent():
            e.prepare(t0, t1, epoch)

    def landing_times(self, t0: float, t1: float) -> np.ndarray:
        """The times in ``(t0, t1]`` that steps must end on, over every effect (sorted)."""
        times = [e.landing_times(t0, t1) for e in self.all]
        return np.unique(np.concatenate(times)) if times else np.zeros(0)

    def check_landings(self, t0: float, t1: float, grid: float, what: str) -> None:
        """Check that every time an effect's steps must land on (:meth:`landing_times`) in
        ``(t0, t1]`` is a step's end: ``t0`` plus a whole number of ``grid`` (within 1e-9 of a
        step, relative).

        Raises
        ------
        InputError
            A landing time between two steps' ends, naming the effect's key.
        """
        for e in self.all:
            for t in e.landing_times(t0, t1):
                k = (float(t) - t0) / grid
                if abs(k - round(k)) > 1e-9 * max(1.0, abs(k)):
                    raise InputError(
                        e.key,
                        f"steps must end at t = {float(t)!r} s, which lies between two steps' ends ({what}: "
                        f"multiples of {grid!r} s from {t0!r} s); choose a step that divides it",
                    )

    def attach_events(self, events) -> None:
        """Mark the events that effects act at (:meth:`~emorbit.effects.base.Effect.events_heard`),
        so that they split their steps.

        Raises
        ------
        InputError
            An effect names an event the run does not have, naming its key.
        """
        for effect in self.all:
            effect.attach(events)
        labels = {e.label: e for e in events.events}
        for effect in self.all:
            for key, label in effect.events_heard():
                if label not in labels:
                    known = ", ".join(labels) or "none"
                    raise InputError(key, f"the run has no event labelled {label!r}; its events: {known}")
                labels[label].acts = True

    def on_event(self, label: str, t: float, events) -> None:
        """An event happened at time ``t``: let the effects act."""
        for effect in self.all:
            effect.on_event(label, t, events)

    def replay_events(self, events) -> None:
        """A resumed run: let the effects act at the events of its log, in order."""
        self.attach_events(events)
        for entry in list(events.log):
            self.on_event(entry["label"], float(entry["time"]), events)

    # -- what the kernels take -------------------------------------------------------------------
    def program(self, announce=None):
        """The set compiled (:func:`emorbit.effects.program.compile_set`), kept until the set
        changes (every chunk of steps asks for it)."""
        from .program import compile_set

        return self._of_all("program", lambda effects: compile_set([type(e) for e in effects], announce))

    def coefficients(self, body_kind: str, name: str, values: dict) -> np.ndarray:
        """(k,) a body's points' coefficient for each effect of :attr:`all` (0: not at its
        points; surface effects act through its facets)."""
        return np.array([e.coefficient(body_kind, values) if e.reaches(name) else 0.0 for e in self.all], float)

    def surface_mask(self, body_kind: str, name: str) -> np.ndarray:
        """(k,) 1 where an effect acts on the surfaces of this body, else 0."""
        return np.array(
            [1.0 if e.acts_on(body_kind) == ON_SURFACES and e.reaches(name) else 0.0 for e in self.all], float
        )

    def needs_surface(self, body_kind: str, name: str) -> bool:
        """Whether an effect acts on this body's own surface (its shape's facets, its facet
        tables), beyond the facets effects bring (:meth:`own_facets`)."""
        return any(e.acts_on(body_kind) == ON_SURFACES and e.reaches(name) and not type(e).OWN_FACETS for e in self.all)

    def own_facets(self, body_kind: str, name: str) -> np.ndarray:
        """The facets that effects bring to this body (a burn's thruster), as
        :meth:`~emorbit.effects.base.Effect.own_facets` gives them: (k, 11) for a rigid body,
        (k, 5) for an elastic one."""
        rows = [e.own_facets(body_kind, name) for e in self.all if type(e).OWN_FACETS and e.reaches(name)]
        width = 11 if body_kind == "rigid" else 5
        return np.ascontiguousarray(np.vstack(rows)) if rows else np.zeros((0, width))

    def arrays(self, n_points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The set's parameters, slices, tables and scratch for ``n_points`` points.

        Returns
        -------
        P, I, T, S : ndarray
            As :mod:`emorbit.kernels.effects.signatures` lays them out (S zeroed).
        """
        effects = self.all
        sizes = tuple((e.p.size, e.tab.size, e.scratch_size(n_points)) for e in effects)
        kept = self._of_all("arrays", lambda _: {})  # the slices by sizes, the tables by identity
        if kept.get("sizes") != sizes:
            I = np.zeros((len(effects), SLICES), np.int64)
            p = t = s = 0
            for e, (np_, nt, ns) in enumerate(sizes):
                I[e] = [p, p + np_, t, t + nt, s, s + ns]
                p, t, s = I[e, 1], I[e, 3], I[e, 5]
            kept.update(sizes=sizes, I=I, scratch=max(int(s), 1))
        tabs = tuple(e.tab for e in effects)
        if "tabs" not in kept or len(kept["tabs"]) != len(tabs) or any(a is not b for a, b in zip(kept["tabs"], tabs)):
            T = np.concatenate(tabs) if effects else np.zeros(0)
            kept.update(tabs=tabs, T=np.ascontiguousarray(T if T.size else np.zeros(1), float))
        P = np.concatenate([e.p for e in effects]) if effects else np.zeros(0)  # read anew: effects set p in place
        return np.ascontiguousarray(P, float), kept["I"].copy(), kept["T"], np.zeros(kept["scratch"])

    def packed_points(self):
        """A packed point-mass kernel that an effect of the set declares for exactly this set
        (:meth:`~emorbit.effects.base.Effect.packed`): (chunk, parameter arrays), or None."""
        for cls in dict.fromkeys(type(e) for e in self.all):
            found = cls.packed(self.all)
            if found is not None:
                return found
        return None

    def sets_time_scale(self, body_kind: str) -> bool:
        """Whether an effect of the set that acts at the points of a body kind declares the
        rate that sets adaptive steps' time scale."""
        return any(
            e.acts_on(body_kind) == AT_POINTS and (type(e).PIECES.rate or type(e).PIECES.pair_rate) for e in self.all
        )

    def body_keys(self, body_kind: str) -> list:
        """The body keys (:class:`~emorbit.effects.base.BodyKey`) the set's effects require of
        bodies of a kind."""
        return [bk for e in self.all for bk in type(e).BODY_KEYS if body_kind in bk.kinds and bk.required]

    def jacobian_left_out(self, body_kind: str = "point") -> float:
        """The largest :meth:`~emorbit.effects.base.Effect.jacobian_left_out` of the set's
        effects that act at the points of a body kind (inf where one does not know its own).

        Raises
        ------
        InputError
            An effect's bound that is not a number >= 0, naming the effect.
        """
        return max(
            (
                check_left_out(e.jacobian_left_out(), f"{e.key or e.kind}.jacobian_left_out()")
                for e in self.all
                if e.acts_on(body_kind) == AT_POINTS
            ),
            default=0.0,
        )

    def acts_at_points(self, body_kind: str) -> bool:
        """Whether any effect of the set acts at the points of a body kind on its own (effects
        between pairs act at the mass points whatever the body's gravity model)."""
        return any(e.acts_on(body_kind) == AT_POINTS and not type(e).pairs() for e in self.all)


class _Context:
    """The build context of the central field's own effect."""

    def __init__(self, field):
        self.field, self.key, self.bodies, self.strict = field, "field", None, False
