"""Third bodies on prescribed paths (``[[effect]] kind = "third_body"``): the Sun, the Moon, or
a point mass on a Kepler orbit, attracting the scene's bodies.

Path. The Sun and the Moon come from an ephemeris (:mod:`emorbit.effects.ephemeris`:
astropy's builtin series offline, or a JPL kernel through jplephem), geocentric, at the
run's epoch plus the clock's seconds (TDB); a ``body`` of any other name moves on the
Kepler orbit its ``orbit`` table gives about the central body at time 0
(:class:`~emorbit.effects.ephemeris.KeplerThirdBody`, GM of the relative orbit = the field's
plus its own). Either path is sampled every ``table_step`` on a grid anchored at the epoch
and interpolated by cubic Hermite polynomials in the step
(:func:`emorbit.kernels.effects.third_body.table_position`): the Moon at 1 h samples to
1.5 cm of the builtin series, the Sun at 6 h to 0.4 m (:class:`EphemerisTable`'s measured
figures), a Kepler body at a thousandth of its period to 3.5e-12 of its orbit's size
(measured on a 120 000 km orbit, ``tests/test_third_body.py``).

Force and energy. In the frame of the central body (``indirect``, the default) the potential
per unit mass is the tidal one, ``U = -gm (1 / |s - d| - 1 / |s| - d . s / |s|^3)``, with the
central body's own acceleration towards the third body as the indirect term; without it
(``indirect = false``: a central body held fixed, an inertial frame) ``U = -gm / |s - d|``.
Over a step the force is the conserving discrete gradient of U at the step's middle time
t_m (:mod:`emorbit.kernels.effects.third_body`): the point-mass force of the central field's
form towards s(t_m), minus ``gm s / |s|^3``. U changes with time, so an em step changes the
energy ``E = T + V + U`` by the discrete work of that change,
``W = m ([U(x1, t1) - U(x1, t_m)] + [U(x0, t_m) - U(x0, t0)])``, which the step sums per
body (``invariants/work_<label>``); ``E - E0 - W`` stays at round-off. Rigid bodies feel the
third body at their mass points (its tidal torque included), elastic bodies at their gravity
points.

Data layout of the parameters: ``p = [gm, indirect, c0, c1, c2, step, k0, rows]``, ``tab``
the table (rows, 6): x, y, z, vx, vy, vz at the times ``(k0 + j) step``
(:mod:`emorbit.kernels.effects.third_body`). References: O. Montenbruck, E. Gill, Satellite Orbits (Springer, 2000),
section 3.3; D. A. Vallado, Fundamentals of Astrodynamics and Applications, 4th ed. (2013),
section 8.6.3.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..keys import Key
from ..units import to_si
from .base import AT_POINTS, Effect, Pieces, epoch_needed
from .ephemeris import BODIES, GM, MAX_SAMPLES, KeplerThirdBody, _ephemeris, sample_table

__all__ = ["ThirdBody", "TABLE_STEP", "MAX_SAMPLES"]

#: the default sampling interval of the Sun's and the Moon's paths, s
TABLE_STEP = {"sun": 6 * 3600.0, "moon": 3600.0}
#: a Kepler body's default sampling interval, as a fraction of its period
KEPLER_SAMPLES = 1000
_KEYS = (
    Key("body", True, "string", "", '"sun", "moon", or another name (with gm and orbit)',
        "the third body: the Sun or the Moon from the ephemeris, else a body on a Kepler orbit"),
    Key("ephemeris", False, "string", '"builtin"', '"builtin" or the path of a JPL kernel (.bsp)',
        "where the Sun's and the Moon's positions come from (a kernel needs jplephem)"),
    Key("gm", False, "gravitational parameter (m3 / s2)", "the Sun's or the Moon's", "> 0; required for a Kepler body",
        "the third body's GM"),
    Key("orbit", False, "table", "", "an orbit table (scenes: [body.orbit]); required for a Kepler body",
        "the Kepler body's osculating elements about the central body at time 0"),
    Key("table_step", False, "time (s)", '"6 h" (Sun), "1 h" (Moon), a thousandth of a Kepler period', "> 0",
        "the sampling interval of the body's path (cubic Hermite between samples)"),
    Key("indirect", False, "boolean", "true", "true, false",
        "the tidal (indirect) term of a frame centred on the central body; false: the central body held fixed"),
)  # fmt: skip


class ThirdBody(Effect):
    """A third body as an effect: ``p`` and its path's table ``tab`` as
    :mod:`emorbit.kernels.effects.third_body`, sampled by :meth:`prepare`.

    Attributes
    ----------
    body : str
        ``"sun"``, ``"moon"`` or the Kepler body's name.
    gm : float
        Its GM, m^3/s^2.
    step : float
        The sampling interval, s.
    indirect : bool
        With the tidal (indirect) term.
    center : ndarray
        (3,) the central body, m.
    """

    NAME = "third_body"
    SUMMARY = "the Sun, the Moon or a body on a Kepler orbit, on its path in time, with its tidal term"
    KEYS = _KEYS
    ACTS = {"point": AT_POINTS, "rigid": AT_POINTS, "elastic": AT_POINTS}
    CONSERVES: tuple[str, ...] = ()
    MULTIPLE = True
    SAME_KEY = "body"
    NEEDS_FIELD = True
    PATH_KEYS = ("ephemeris",)
    PIECES = Pieces(
        "emorbit.kernels.effects.third_body",
        force="third_body_piece",
        potential="third_body_potential_piece",
        prepare="third_body_prepare",
        time_work="third_body_time_work",
    )
    POTENTIAL = "U = -gm m (1/|s - d| - 1/|s| - d . s / |s|^3), d = x - c, s(t) the body's path (indirect)"
    DISCRETE_FORCE = (
        "F = m [g_em towards s(t_m) - gm s(t_m) / |s(t_m)|^3]; W = m [U(x1,t1) - U(x1,tm) + U(x0,tm) - U(x0,t0)]"
    )
    JACOBIAN_LEFT_OUT = 0.0
    JACOBIAN = "dF/dx1 = that of g_em about s(t_m) (the indirect term is constant)"

    time_dependent = True

    @property
    def needs_epoch(self) -> bool:
        """The Sun's and the Moon's paths come from an ephemeris at the run's epoch."""
        return self._kepler is None

    def scratch_size(self, n_points: int) -> int:
        return 9  # the body at the sub-step's start, middle and end

    def same_as(self, other) -> bool:
        return other.body == self.body

    def span_samples(self, t0: float, t1: float) -> int:
        """The samples :meth:`prepare` takes to cover ``t0`` to ``t1``."""
        return int(math.ceil(t1 / self.step) - math.floor(t0 / self.step)) + 3

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """Sample the path at the grid's points from before ``t0`` to after ``t1`` (a table that
        covers them already is kept).

        Raises
        ------
        InputError
            The Sun or the Moon without an epoch, times the ephemeris cannot give, or a span
            of more than :data:`MAX_SAMPLES` samples (naming ``table_step``).
        """
        if self.needs_epoch and epoch is None:
            raise epoch_needed(f"{self.key} takes the {self.body}'s position from an ephemeris")
        if self.span_samples(t0, t1) > MAX_SAMPLES:
            raise InputError(
                f"{self.key}.table_step",
                f"the run spans {self.span_samples(t0, t1)} samples of the {self.body}'s path at {self.step!r} s, "
                f"more than {MAX_SAMPLES}: raise table_step or shorten the run",
            )
        k_first = math.floor(t0 / self.step) - 1
        k_last = max(math.ceil(t1 / self.step) + 1, k_first + 2)
        stamp = None if epoch is None else (float(epoch.tdb.jd1), float(epoch.tdb.jd2))
        if self._span is not None:
            first, last, was = self._span
            if first <= k_first and last >= k_last and was == stamp:
                return
        if self._kepler is not None:
            t = np.arange(k_first, k_last + 1, dtype=np.float64) * self.step
            p, v = self._kepler.states(t)
            tab = np.ascontiguousarray(np.hstack([p, v]))
        else:
            tab = sample_table(self.body, k_first, k_last, self.step, epoch, self._ephemeris)
        self.p[6] = k_first
        self.p[7] = len(tab)
        self.tab = np.ascontiguousarray(tab.ravel())
        self._span = (k_first, k_last, stamp)

    def positions(self, t) -> np.ndarray:
        """The sampled path at times ``t`` (s from the epoch), relative to the central body:
        (n, 3) m (after :meth:`prepare` has covered them)."""
        from ..kernels.effects.third_body import table_positions

        rows = int(self.p[7])
        tab = self.tab[: 6 * rows].reshape(rows, 6)
        return table_positions(np.atleast_1d(np.asarray(t, float)), self.step, float(self.p[6]), tab)

    @classmethod
    def from_table(cls, table, context) -> ThirdBody:
        """A third body from ``body``; ``ephemeris`` (Sun, Moon), ``gm``, ``orbit`` (a Kepler
        body), ``table_step``, ``indirect``.

        Raises
        ------
        InputError
            A body that is not a string; a Kepler body without gm or orbit, or an ephemeris
            for it; the Sun or the Moon about a central body other than the Earth, or with an
            orbit; a bad GM, step, ephemeris path or indirect flag.
        """
        key, field, strict = context.key, context.field, context.strict
        name = table.get("body")
        if not isinstance(name, str) or not name.strip():
            raise InputError(
                f"{key}.body", f'"sun", "moon" or the name of a body on a Kepler orbit expected, got {name!r}'
            )
        lower = name.strip().lower()
        indirect = table.get("indirect", True)
        if not isinstance(indirect, bool):
            raise InputError(f"{key}.indirect", f"true or false expected, got {indirect!r}")
        gm = None
        if "gm" in table:
            gm = to_si(table["gm"], "gm", f"{key}.gm", strict=strict, positive=True)
        if lower in BODIES:
            if "orbit" in table:
                raise InputError(
                    f"{key}.orbit", f"the {lower}'s path comes from the ephemeris; orbit is for a Kepler body"
                )
            if field.body and field.body.lower() != "earth":
                raise InputError(
                    f"{key}.body",
                    f"the ephemeris gives the {lower} about the Earth, but the central body is {field.body!r}",
                )
            ephemeris = _ephemeris(table.get("ephemeris", "builtin"), f"{key}.ephemeris")
            step = TABLE_STEP[lower]
            kepler, body = None, lower
            gm = GM[lower] if gm is None else gm
        else:
            if "ephemeris" in table:
                raise InputError(
                    f"{key}.ephemeris", f"{name!r} is on a Kepler orbit; the ephemeris is for the Sun and Moon"
                )
            for need in ("gm", "orbit"):
                if need not in table:
                    raise InputError(
                        f"{key}.{need}", f"{name!r} is a body on a Kepler orbit: give its gm and its orbit"
                    )
            from ..orbits import orbit_state

            mu = field.gm + gm
            pos, vel = orbit_state(table["orbit"], mu, (0.0, 0.0, 0.0), field.radius, strict=strict, key=f"{key}.orbit")
            kepler = _Kepler(pos, vel, mu, 0.0)
            if not math.isfinite(kepler.period):
                raise InputError(f"{key}.orbit", "a third body on an open orbit leaves: give a bound orbit (e < 1)")
            step = kepler.period / KEPLER_SAMPLES
            ephemeris, body = None, name
        if "table_step" in table:
            step = to_si(table["table_step"], "time", f"{key}.table_step", strict=strict, positive=True)
        effect = cls(table, [gm, float(indirect), *field.center, step, 0.0, 2.0], np.zeros(12))
        effect.body, effect.gm, effect.step, effect.indirect = body, float(gm), float(step), bool(indirect)
        effect.center = np.asarray(field.center, float)
        effect._ephemeris, effect._kepler, effect._span = ephemeris, kepler, None
        return effect


class _Kepler(KeplerThirdBody):
    """A Kepler body with its exact velocities for the table."""

    def states(self, t):
        from ..orbits import propagate

        return propagate(self.position0, self.velocity0, self.gm, np.asarray(t, float) - self.epoch)
