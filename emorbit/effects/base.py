"""The effect contract: :class:`Effect`, the one declaration of a force a scene may name.

An effect is one module (``emorbit/effects/<name>.py``, or a user's own file) with one
subclass of :class:`Effect` and one kernel module of plain Numba functions, its *pieces*
(:mod:`emorbit.kernels.effects.signatures` gives their arguments). The class declares
everything about the effect; nothing else in emorbit names it:

- its scene keys (:attr:`Effect.KEYS`) and the keys it attaches to bodies
  (:attr:`Effect.BODY_KEYS`: drag's ``ballistic_coefficient`` on point masses);
- the body kinds it acts on and how (:attr:`Effect.ACTS`: at a body's points, on its
  surfaces, or not), whether a scene may name it more than once, what an em step with it
  conserves, whether it does work, whether it needs a central field, an epoch, or changes
  in time, and whether its force is explicit (a function of position and time alone, so
  leapfrog's kicks and the time finite element's stages may use it);
- its pieces (:class:`Pieces`): the force on a point over a step with its Jacobian, its
  potential, what it prepares per sub-step, the work of its change in time, its force on a
  facet, or its pair forces;
- any times that steps must land on (:meth:`Effect.landing_times`).

An instance is one effect of one simulation: its parameters in SI, packed as float64 arrays
in the order its pieces read them (``p``, the flat tables ``tab``, and the scratch size),
built from its scene table by :meth:`Effect.from_table`. The body kinds' step kernels take a
set of effects compiled into seven functions (:mod:`emorbit.effects.program`), so an effect
reaches point masses, rigid bodies' mass points and facets and elastic bodies' gravity points
and surfaces, with every method and with adaptive steps, from this one declaration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..errors import InputError
from ..keys import Key

__all__ = ["Effect", "Pieces", "BodyKey", "AT_POINTS", "ON_SURFACES", "BODY_KINDS", "epoch_needed", "check_left_out"]

#: the body kinds an effect may act on
BODY_KINDS = ("point", "rigid", "elastic")
#: an effect acts on a body kind at its points (a point mass; a rigid body's mass points; an
#: elastic body's gravity points)
AT_POINTS = "points"
#: an effect acts on a body kind through its surfaces (a rigid body's facets, an elastic
#: body's surface triangles)
ON_SURFACES = "surfaces"


@dataclass(frozen=True)
class Pieces:
    """Where an effect's kernel functions are and what they are called.

    Attributes
    ----------
    module : str
        The importable module that defines them (``"emorbit.kernels.effects.zonal"``), or
        the path of a Python file (a user's effect).
    force, potential, prepare, time_work, facet, pairs, pair_potential, pair_block, rate, pair_rate, mass : str
        The names of the pieces in ``module`` ("" where the effect has none; every effect
        that acts at points has a ``force``).

    Notes
    -----
    The pieces are Numba-compilable plain functions (``@kernel`` of
    :mod:`emorbit.kernels.jit`); forces and potentials are per unit mass of a point. ``p`` is
    the effect's parameter vector, ``tab`` its tables (flat; the piece reshapes them from
    sizes in ``p``), ``s`` its scratch (what ``prepare`` fills, and a pair effect's working
    rows)::

        force(x0, y0, z0, x1, y1, z1, h, c, p, tab, s, J, jac) -> (fx, fy, fz)
            the effect's force over a step x0 -> x1 of length h (the discrete force of an em
            step: its work equals the drop of the effect's potential), and, where ``jac``, its
            derivative with respect to the end point added into J (3, 3): ``J[a, b] += dF_a /
            dx1_b``. With x0 = x1 = x it is the force at x. c is the point's coefficient for
            the effect (a body key such as drag's ``Cd A / m``; 1 where the effect has none).
            The set evaluates it at every point of a block, so that its loop has no branches
            (:mod:`emorbit.effects.program`), and keeps the force and J only where c is not 0:
            at c = 0 it may return anything, but must return.
        potential(x, y, z, c, p, tab, s) -> V
            the potential energy per unit mass (conservative effects).
        prepare(ta, tm, tb, p, tab, s)
            fills the scratch s with what every point's force reads over a sub-step from ta to
            tb (its middle tm): a body's position on its path, the Sun's.
        time_work(x0, y0, z0, x1, y1, z1, c, p, tab, s) -> W
            the work per unit mass of the potential's change in time over the sub-step (an
            effect that depends on time), at the positions x0 and x1.
        facet(ax, ay, az, bx, by, bz, nx, ny, nz, area, k0, k1, k2, k3, h, p, tab, s) -> (fx, fy, fz)
            a surface effect's force (N) on a flat facet of ``area`` (m^2) whose centre moves
            a -> b over the step, with unit normal n at the step's middle and the facet
            coefficients k (drag coefficient Cd, specular and diffuse reflectivity, two-sided
            flag).
        pairs(x0, x1, m, body, c, h, p, s, F, W, R, jac, first, weighted)
            an effect between pairs of points (mutual gravity): adds its forces per unit mass
            (``weighted``: the forces, N) into F (3, n), the diagonal blocks of their Jacobian
            into W (9, n) where ``jac``, and each point's coupling bound ``sum_j |dF_i / dx1_j|``
            (1/s^2) into R (n,), between points of different ``body`` where ``c`` is not 0;
            ``first`` is the first evaluation of a sub-step (the piece may keep what it formed in
            s). Weighted, the two forces of a pair are bitwise opposite, so that a system that
            steps masses (a structure) keeps momentum and angular momentum to round-off.

        rate(x, y, z, vx, vy, vz, c, p) -> (W, dW)
            the squared rate that sets adaptive steps' time scale at a point (1/s^2: a Kepler rate
            GM / r**3), and its rate of change along the motion (1/s^3).
        pair_rate(d0, d1, d2, u0, u1, u2, ma, mb, p) -> (W, dW)
            the same for a pair of points from their separation and relative velocity.
        pair_block(a0, a1, a2, b0, b1, b2, ma, mb, p, J)
            a pair effect's block between two points: ``J = -d F_a / d x1_b`` (N/m; F_a the force
            on point a, N) from their separation ``x_a - x_b`` at the step's start (a) and end (b)
            and their masses.

    ``pair_potential(x, m, body, c, p, out)`` adds each point's half of its pairs'
    potential energy (J) into ``out`` (n,).

    ``mass(c, facet, p, s) -> dmu`` (an effect that changes a body's mass: a burn) gives the
    effect's part of the body's mean mass over its initial mass, less 1, over the sub-step
    that ``prepare`` set up: at a point whose coefficient is c (not 0), or at a facet whose last
    coefficient is c (``facet``; 0 at facets not its own). A set with such an effect sums the
    work done on each body at its true mass in one more work row (its *ledger row*).
    """

    module: str
    force: str = ""
    potential: str = ""
    prepare: str = ""
    time_work: str = ""
    facet: str = ""
    pairs: str = ""
    pair_potential: str = ""
    pair_block: str = ""
    rate: str = ""
    pair_rate: str = ""
    mass: str = ""


@dataclass(frozen=True)
class BodyKey:
    """A key an effect attaches to the bodies it acts on, e.g. drag's ``ballistic_coefficient``.

    Attributes
    ----------
    key : Key
        The key as the scene tables of the body kinds below document it.
    kinds : tuple of str
        The body kinds that take it.
    quantity : str
        Its kind of quantity for :func:`emorbit.units.to_si` (e.g. ``"area_per_mass"``).
    unit : str
        Its SI unit as scenes write it (``"m2 / kg"``).
    required : bool
        Whether a body the effect acts on must give it (where the simulation has the effect).
    """

    key: Key
    kinds: tuple[str, ...]
    quantity: str
    unit: str
    required: bool = True

    @property
    def name(self) -> str:
        """The key's name."""
        return self.key.name

    def value(self, raw, key: str, strict: bool) -> float:
        """The key's value in SI: a float >= 0 (raises InputError naming ``key``)."""
        from ..units import to_si

        return to_si(raw, self.quantity, key, strict=strict, nonnegative=True)


def epoch_needed(why: str) -> InputError:
    """The error of an effect that needs the run's epoch and has none: ``why`` (the effect's key
    and what it needs the date for), then how to give one."""
    return InputError("integrator.epoch", f'{why}: the run needs an epoch (e.g. epoch = "2000-01-01T12:00:00 TDB")')


def check_left_out(value, key: str) -> float:
    """A Jacobian bound (:attr:`Effect.JACOBIAN_LEFT_OUT`) as a float: a number >= 0, inf
    where the effect does not know it.

    Raises
    ------
    InputError
        Not a real number, NaN or negative, naming ``key`` and the value.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) or not value >= 0.0:
        raise InputError(key, f"a number >= 0 expected (inf where the effect does not know it), got {value!r}")
    return float(value)


class Effect:
    """One force a scene may name: the declaration (class attributes) and, as an instance,
    one effect of one simulation.

    Subclasses set the class attributes below, write :meth:`from_table`, and register with
    :func:`emorbit.effects.register` (the shipped ones are registered by
    :mod:`emorbit.effects`).

    Attributes
    ----------
    kind : str
        Its ``NAME``.
    label : str
        Its name in the run file's datasets (``invariants/potential_<label>``,
        ``work_<label>``): the kind, numbered where a scene names a kind twice.
    key : str
        Its name in errors (``effect[0]``).
    table : dict
        The scene table that made it (plain TOML values), written back into scenes.
    bodies : list of str or None
        The bodies it acts on (None: every body of a kind it acts on).
    p : ndarray
        Its parameters (float64), in the order its pieces read them.
    tab : ndarray
        Its tables, flat (float64). An effect replaces them, never writes into them: the set
        keeps their concatenation while every effect's ``tab`` is the same array.
    """

    #: its ``kind`` in scenes
    NAME: ClassVar[str] = ""
    #: one line on what it is
    SUMMARY: ClassVar[str] = ""
    #: its scene keys (beyond ``kind``)
    KEYS: ClassVar[tuple[Key, ...]] = ()
    #: the keys it attaches to bodies
    BODY_KEYS: ClassVar[tuple[BodyKey, ...]] = ()
    #: how it acts on each body kind: AT_POINTS or ON_SURFACES (absent: not at all)
    ACTS: ClassVar[dict] = {"point": AT_POINTS, "rigid": AT_POINTS, "elastic": AT_POINTS}
    #: what an em step with it keeps exactly ("energy", "momentum", "angular momentum ...")
    CONSERVES: ClassVar[tuple[str, ...]] = ("energy",)
    #: whether a scene may name it more than once (each then adds its force)
    MULTIPLE: ClassVar[bool] = False
    #: the key that tells two of them apart where a scene may name it more than once
    #: (:meth:`same_as`), named in the error for a second one that is the same
    SAME_KEY: ClassVar[str] = ""
    #: whether it belongs to a central field (a scene in free space may not name it)
    NEEDS_FIELD: ClassVar[bool] = False
    #: its keys that name files: a relative path is found in the scene's folder where a file
    #: of that name is there
    PATH_KEYS: ClassVar[tuple[str, ...]] = ()
    #: whether its force is a function of position (and time) alone: leapfrog may kick with it,
    #: and tfe's stages take it on point masses
    EXPLICIT: ClassVar[bool] = True
    #: whether its facet force acts on facets of its own that it adds to a body
    #: (:meth:`own_facets`: a burn's thruster) rather than on the body's surface
    OWN_FACETS: ClassVar[bool] = False
    #: a bound of the part of its force's derivative that its ``force`` piece leaves out of J,
    #: relative to the central field's (0: J is the exact derivative; inf: unknown, or no J).
    #: Where every effect of a point mass's set gives a finite bound, em's Newton iteration on
    #: point masses may stop after one update (:mod:`emorbit.kernels.pointmass.effect_step`)
    JACOBIAN_LEFT_OUT: ClassVar[float] = math.inf
    #: its pieces
    PIECES: ClassVar[Pieces | None] = None
    #: the equations, for the docs (effects.md is generated from them)
    POTENTIAL: ClassVar[str] = ""
    DISCRETE_FORCE: ClassVar[str] = ""
    JACOBIAN: ClassVar[str] = ""

    def __init__(self, table: dict, p=(), tab=(), bodies: list | None = None):
        self.kind = self.NAME
        self.label = self.NAME
        self.key = ""
        self.table = dict(table)
        self.bodies = bodies
        self.p = np.ascontiguousarray(p, dtype=float).ravel()
        self.tab = np.ascontiguousarray(tab, dtype=float).ravel()

    # -- what the declaration implies --------------------------------------------------------
    def jacobian_left_out(self) -> float:
        """This effect's :attr:`JACOBIAN_LEFT_OUT` (an effect whose pieces depend on its keys
        may give a bound of its own)."""
        return type(self).JACOBIAN_LEFT_OUT

    @classmethod
    def does_work(cls) -> bool:
        """Whether its force does work that the step sums: it keeps no energy (drag,
        radiation pressure), or its potential changes in time (a third body on its path)."""
        return "energy" not in cls.CONSERVES or bool(cls.PIECES and cls.PIECES.time_work)

    @classmethod
    def changes_mass(cls) -> bool:
        """Whether it changes its body's mass over the run (a burn with a specific impulse):
        the run then records the mass ledger (:meth:`mass_lost`)."""
        return bool(cls.PIECES and cls.PIECES.mass)

    def mass_lost(self, t) -> dict:
        """The mass it has taken from each body by times ``t`` (s): {body name: (len(t),) kg}
        ({} for an effect that changes no mass)."""
        return {}

    @classmethod
    def has_potential(cls) -> bool:
        """Whether it has a potential energy, recorded as ``invariants/potential_<label>``."""
        return bool(cls.PIECES and (cls.PIECES.potential or cls.PIECES.pair_potential))

    @classmethod
    def pairs(cls) -> bool:
        """Whether it acts between pairs of points (it then couples the bodies it reaches)."""
        return bool(cls.PIECES and cls.PIECES.pairs)

    @classmethod
    def acts_on(cls, body_kind: str) -> str:
        """How it acts on a body kind: AT_POINTS, ON_SURFACES or "" (not at all)."""
        return cls.ACTS.get(body_kind, "")

    @property
    def time_dependent(self) -> bool:
        """Whether :meth:`prepare` must sample something over a run's span before its steps."""
        return False

    @property
    def needs_epoch(self) -> bool:
        """Whether it needs the run's epoch (an ephemeris, a dated atmosphere)."""
        return False

    # -- an instance ---------------------------------------------------------------------------
    def facts(self) -> dict:
        """What the run file records about it beside its kind and label (the ``effects``
        attribute, JSON): plain numbers and lists, e.g. a turning field's ``body_frame``
        (``axes``: the 3 x 3 columns e1, e2, e3 in the scene's axes; ``angle``, rad, at time 0;
        ``rate``, rad/s), from which plots draw longitudes and ground tracks. None by default."""
        return {}

    @classmethod
    def from_table(cls, table: dict, context: BuildContext) -> Effect:
        """The effect from its scene table (or :meth:`emorbit.Simulation.add_effect`'s keywords).

        Parameters
        ----------
        table : dict
            Its keys (``kind`` already checked; unknown keys already refused).
        context : BuildContext
            The central field, the body names, where errors point, strict units.

        Returns
        -------
        Effect

        Raises
        ------
        InputError
            A value it refuses, naming the key.
        """
        raise NotImplementedError

    @staticmethod
    def packed(effects):
        """A packed point-mass kernel of the effect's own for exactly the set ``effects`` (em,
        fixed steps), with its parameter arrays, or None (the step kernels of every set run)."""
        return None

    def scratch_size(self, n_points: int) -> int:
        """The length of its scratch for a set of ``n_points`` points (what ``prepare`` fills)."""
        return 0

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """Make the tables cover the times ``t0`` to ``t1`` (s from the epoch): an effect that
        follows a path in time samples it (nothing to do for the others).

        Parameters
        ----------
        t0, t1 : float
            The span the steps reach, s.
        epoch : astropy.time.Time or None
            The run's epoch.
        """

    def landing_times(self, t0: float, t1: float) -> np.ndarray:
        """The times in ``(t0, t1]`` that steps must end on (an effect switching on or off).

        Returns
        -------
        ndarray
            Sorted times, s (none by default).
        """
        return np.zeros(0)

    def bind(self, kinds: dict, masses: dict, named) -> None:
        """Read what it needs of the bodies it acts on, once they are known (a burn: its body's
        mass); nothing by default.

        Parameters
        ----------
        kinds : dict
            {name: body kind} of the simulation's bodies.
        masses : dict
            {name: kg} of its point masses and rigid bodies.
        named : tuple of Effect
            The simulation's named effects (a burn reads the earlier burns of its body).

        Raises
        ------
        InputError
            What it refuses of them, naming its key.
        """

    def own_facets(self, body_kind: str, name: str) -> np.ndarray:
        """The facets it adds to a body it acts on through facets (:attr:`OWN_FACETS`): a rigid
        body's packed as :meth:`emorbit.bodies.facets.Facets.packed` rows (k, 11), body frame;
        an elastic body's as rows (k, 5), a node's index in the body and the coefficients k0 to
        k3 of a facet at that node alone (no area, no normal). None by default."""
        return np.zeros((0, 11 if body_kind == "rigid" else 5))

    def events_heard(self) -> tuple[tuple[str, str], ...]:
        """The events it acts at: (its key naming the event, the event's label) pairs (a burn
        that starts or ends at an event); none by default."""
        return ()

    def attach(self, events) -> None:
        """Add the events it needs to the run's ``events`` before the run starts (a burn that
        ends at an event: the time its body's mass would run out); nothing by default."""

    def on_event(self, label: str, t: float, events) -> None:
        """An event of the run happened at time ``t`` (s): an effect that acts at it changes
        (a burn starts or ends) and may add events to ``events`` (a burn's end after its
        duration); nothing by default.

        Raises
        ------
        InputError
            What it cannot do there, naming its key.
        """

    def same_as(self, other: Effect) -> bool:
        """Whether ``other`` (of the same kind) is the same effect named twice (a second third
        body must be another body)."""
        return True

    def coefficient(self, body_kind: str, values: dict) -> float:
        """The coefficient of a body's points for this effect (0: it does not act on them).

        Parameters
        ----------
        body_kind : str
            ``"point"``, ``"rigid"`` or ``"elastic"``.
        values : dict
            The body's effect keys (:attr:`BODY_KEYS` values given for it, SI).

        Returns
        -------
        float
            The value of its body key (the first that applies), 1 where it has none, 0 where
            it does not act at the body's points.
        """
        if self.acts_on(body_kind) != AT_POINTS:
            return 0.0
        for bk in self.BODY_KEYS:
            if body_kind in bk.kinds:
                return float(values.get(bk.name, 0.0))
        return 1.0

    def potential_energy(self, x, masses, t=None) -> np.ndarray:
        """This effect's potential energy of points at recorded states, through its own pieces
        (the compiled set of this effect alone).

        Parameters
        ----------
        x : array_like
            (rows, 3, n) positions, m.
        masses : array_like
            (n,) kg.
        t : array_like, optional
            (rows,) the records' times, s from the epoch (an effect that follows a path:
            :meth:`prepare` must have covered them).

        Returns
        -------
        ndarray
            (rows,) J (zeros for an effect without a potential).
        """
        from ..kernels.effects.records import record_potentials
        from ..kernels.effects.signatures import SLICES
        from .program import compile_set

        x = np.ascontiguousarray(x, dtype=float)
        rows, n = x.shape[0], x.shape[2]
        prog = compile_set([type(self)])
        I = np.array([[0, self.p.size, 0, self.tab.size, 0, self.scratch_size(n)]], np.int64).reshape(1, SLICES)
        out = np.zeros((rows, 1))
        record_potentials(
            prog.prepare, prog.potential, x, np.zeros(rows) if t is None else np.ascontiguousarray(t, float),
            np.ascontiguousarray(masses, float), np.arange(n, dtype=np.int64), np.ones((1, n)), self.p, I,
            self.tab if self.tab.size else np.zeros(1), np.zeros(max(self.scratch_size(n), 1)), out,
        )  # fmt: skip
        return out[:, 0]

    def reaches(self, name: str) -> bool:
        """Whether it acts on the body ``name`` (its ``bodies`` list, or every body)."""
        return self.bodies is None or name in self.bodies

    def __repr__(self) -> str:
        return f"<effect {self.label} ({self.key or 'no key'})>"


@dataclass
class BuildContext:
    """What an effect's :meth:`Effect.from_table` may read.

    Attributes
    ----------
    field : CentralField or None
        The scene's central field.
    key : str
        The table's name in errors (``effect[0]``).
    bodies : list of str or None
        The scene's body names, where known (None: checked when the simulation runs).
    strict : bool
        Require units on every dimensional value (scenes do).
    """

    field: object
    key: str
    bodies: list | None = None
    strict: bool = False
    extra: dict = field(default_factory=dict)

    def error(self, name: str, message: str) -> InputError:
        """An InputError naming ``<key>.<name>`` (or the table, with ``name`` empty)."""
        return InputError(f"{self.key}.{name}" if name else self.key, message)
