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
third body at their mass points (its tidal torque included).

Data layout of the kernel's parameters, all third bodies of a simulation stacked: ``tb_p``
(k, 9) rows ``[gm, indirect, c0, c1, c2, step, k0, offset, rows]``, ``tb_tab`` (N, 6) the
tables one after another (rows ``offset .. offset + rows``: x, y, z, vx, vy, vz at the times
``(k0 + j) step``). References: O. Montenbruck, E. Gill, Satellite Orbits (Springer, 2000),
section 3.3; D. A. Vallado, Fundamentals of Astrodynamics and Applications, 4th ed. (2013),
section 8.6.3.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..keys import Key
from ..units import to_si
from .base import EffectTerm
from .ephemeris import BODIES, GM, KeplerThirdBody, _ephemeris, sample_table

__all__ = ["NAME", "SUMMARY", "KEYS", "CONSERVES", "BODY_KINDS", "KERNEL", "build", "ThirdBody", "stack", "TABLE_STEP"]

NAME = "third_body"
SUMMARY = "the Sun, the Moon or a body on a Kepler orbit, on its path in time, with its tidal term"
#: the default sampling interval of the Sun's and the Moon's paths, s
TABLE_STEP = {"sun": 6 * 3600.0, "moon": 3600.0}
#: a Kepler body's default sampling interval, as a fraction of its period
KEPLER_SAMPLES = 1000
KEYS = (
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
POTENTIAL = "U = -gm m (1/|s - d| - 1/|s| - d . s / |s|^3), d = x - c, s(t) the body's path (indirect)"
DISCRETE_FORCE = (
    "F = m [g_em towards s(t_m) - gm s(t_m) / |s(t_m)|^3]; W = m [U(x1,t1) - U(x1,tm) + U(x0,tm) - U(x0,t0)]"
)
JACOBIAN = "dF/dx1 = that of g_em about s(t_m) (the indirect term is constant)"
CONSERVES: tuple[str, ...] = ()
BODY_KINDS = ("point", "rigid")

KERNEL = {
    "imports": (
        "from emorbit.kernels.effects.third_body import table_position, third_body_force, third_body_jacobian, "
        "tidal_potential"
    ),
    "setup": "tb_s = np.empty((tb_p.shape[0], 3, 3))  # each body at the sub-step's start, middle and end",
    "substep": """
for jb in range(tb_p.shape[0]):
    o = int(tb_p[jb, 7])
    tab = tb_tab[o : o + int(tb_p[jb, 8])]
    tb_s[jb, 0, 0], tb_s[jb, 0, 1], tb_s[jb, 0, 2] = table_position(ta, tb_p[jb, 5], tb_p[jb, 6], tab)
    tb_s[jb, 1, 0], tb_s[jb, 1, 1], tb_s[jb, 1, 2] = table_position(tm, tb_p[jb, 5], tb_p[jb, 6], tab)
    tb_s[jb, 2, 0], tb_s[jb, 2, 1], tb_s[jb, 2, 2] = table_position(tb, tb_p[jb, 5], tb_p[jb, 6], tab)
""",
    "own": """
for jb in range(tb_p.shape[0]):
    gx, gy, gz = third_body_force(
        x0, y0, z0, x1, y1, z1, tb_p[jb, 2], tb_p[jb, 3], tb_p[jb, 4], tb_s[jb, 1, 0], tb_s[jb, 1, 1],
        tb_s[jb, 1, 2], tb_p[jb, 0], tb_p[jb, 1] != 0.0,
    )
    fx += gx
    fy += gy
    fz += gz
    third_body_jacobian(
        x0, y0, z0, x1, y1, z1, tb_p[jb, 2], tb_p[jb, 3], tb_p[jb, 4], tb_s[jb, 1, 0], tb_s[jb, 1, 1],
        tb_s[jb, 1, 2], tb_p[jb, 0], J,
    )
""",
    "pairs": "",
    # the work of the potential's change in time over the converged sub-step: the body at the
    # sub-step's end against its middle at x1, the middle against the start at x0
    "work": """
for jb in range(tb_p.shape[0]):
    gm3 = tb_p[jb, 0]
    ind = tb_p[jb, 1] != 0.0
    a0 = x[0, i] - tb_p[jb, 2]
    a1 = x[1, i] - tb_p[jb, 3]
    a2 = x[2, i] - tb_p[jb, 4]
    b0 = a0 + dx[0, i]
    b1 = a1 + dx[1, i]
    b2 = a2 + dx[2, i]
    ue = tidal_potential(b0, b1, b2, tb_s[jb, 2, 0], tb_s[jb, 2, 1], tb_s[jb, 2, 2], gm3, ind) - tidal_potential(
        b0, b1, b2, tb_s[jb, 1, 0], tb_s[jb, 1, 1], tb_s[jb, 1, 2], gm3, ind
    )
    us = tidal_potential(a0, a1, a2, tb_s[jb, 1, 0], tb_s[jb, 1, 1], tb_s[jb, 1, 2], gm3, ind) - tidal_potential(
        a0, a1, a2, tb_s[jb, 0, 0], tb_s[jb, 0, 1], tb_s[jb, 0, 2], gm3, ind
    )
    y = m[i] * (ue + us) + cwork[WORK_SLOT + jb, i]  # Kahan, as x and v
    t = work[WORK_SLOT + jb, i] + y
    cwork[WORK_SLOT + jb, i] = y - (t - work[WORK_SLOT + jb, i])
    work[WORK_SLOT + jb, i] = t
""",
}


class ThirdBody(EffectTerm):
    """A third body as an effect term. Its path is sampled by :meth:`prepare` into
    ``params["tb_p"]`` (1, 9) and ``params["tb_tab"]`` (n, 6) (layout: the module's
    docstring); :func:`stack` joins several for the kernels.

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
    needs_epoch : bool
        The path comes from an ephemeris: the run needs an epoch.
    """

    time_dependent = True

    def setup(self, body, gm, step, indirect, center, ephemeris=None, kepler=None) -> None:
        """Set the path (called by :func:`build`)."""
        self.body, self.gm, self.step, self.indirect = body, float(gm), float(step), bool(indirect)
        self.center = np.asarray(center, float)
        self._ephemeris, self._kepler = ephemeris, kepler
        self.needs_epoch = kepler is None
        self._span = None  # (k_first, k_last, epoch text) of the sampled table

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """Sample the path at the grid's points from before ``t0`` to after ``t1`` (a table that
        covers them already is kept).

        Raises
        ------
        InputError
            The Sun or the Moon without an epoch, or times the ephemeris cannot give.
        """
        if self.needs_epoch and epoch is None:
            raise InputError(
                "integrator.epoch",
                f"{self.key} takes the {self.body}'s position from an ephemeris: the run needs an epoch "
                '(e.g. epoch = "2026-01-01T00:00:00 TDB")',
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
        c = self.center
        self.params["tb_p"] = np.array([[self.gm, float(self.indirect), *c, self.step, k_first, 0, len(tab)]], float)
        self.params["tb_tab"] = tab
        self._span = (k_first, k_last, stamp)

    def potential(self, x, masses, active, t=None):
        from ..kernels.effects.third_body import third_body_potentials

        if t is None or "tb_tab" not in self.params:
            raise RuntimeError(f"{self.key}: the third body's potential needs the records' times and a sampled path")
        p = self.params["tb_p"][0]
        m = np.ascontiguousarray(np.where(active, masses, 0.0), dtype=float)
        return third_body_potentials(
            np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(t, dtype=float), m, self.center,
            self.gm, self.indirect, self.step, float(p[6]), self.params["tb_tab"],
        )  # fmt: skip

    def positions(self, t) -> np.ndarray:
        """The sampled path at times ``t`` (s from the epoch), relative to the central body:
        (n, 3) m (after :meth:`prepare` has covered them)."""
        from ..kernels.effects.third_body import table_positions

        p = self.params["tb_p"][0]
        return table_positions(np.atleast_1d(np.asarray(t, float)), self.step, float(p[6]), self.params["tb_tab"])


def stack(terms) -> tuple[np.ndarray, np.ndarray]:
    """The kernels' ``tb_p`` (k, 9) and ``tb_tab`` (N, 6) of several sampled third bodies.

    Parameters
    ----------
    terms : sequence of ThirdBody
        Prepared terms, in their work slots' order.

    Returns
    -------
    tb_p, tb_tab : ndarray
        Rows of ``tb_p`` point into ``tb_tab`` (column 7 the offset, 8 the rows).
    """
    rows, tabs, offset = [], [], 0
    for term in terms:
        p = term.params["tb_p"][0].copy()
        p[7] = offset
        offset += len(term.params["tb_tab"])
        rows.append(p)
        tabs.append(term.params["tb_tab"])
    return np.ascontiguousarray(np.array(rows, float)), np.ascontiguousarray(np.vstack(tabs))


class _Kepler(KeplerThirdBody):
    """A Kepler body with its exact velocities for the table."""

    def states(self, t):
        from ..orbits import propagate

        return propagate(self.position0, self.velocity0, self.gm, np.asarray(t, float) - self.epoch)


def build(table, field, key: str, bodies, strict: bool = False) -> ThirdBody:
    """A third body from its table.

    Parameters
    ----------
    table : dict
        ``body``; ``ephemeris`` (Sun, Moon), ``gm``, ``orbit`` (a Kepler body), ``table_step``,
        ``indirect`` (see :data:`KEYS`).
    field : CentralField or None
        The central body: the third body moves about it.
    key : str
        The table's name in errors.
    bodies : list of str or None
        Unused: a third body attracts every body.
    strict : bool
        Require units on dimensional values.

    Returns
    -------
    ThirdBody

    Raises
    ------
    InputError
        No field; a body that is not a string; a Kepler body without gm or orbit, or an
        ephemeris for it; the Sun or the Moon about a central body other than the Earth, or
        with an orbit; a bad GM, step, ephemeris path or indirect flag.
    """
    if field is None:
        raise InputError(key, "a third body moves about the central body: the scene needs a [field]")
    name = table.get("body")
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"{key}.body", f'"sun", "moon" or the name of a body on a Kepler orbit expected, got {name!r}')
    lower = name.strip().lower()
    indirect = table.get("indirect", True)
    if not isinstance(indirect, bool):
        raise InputError(f"{key}.indirect", f"true or false expected, got {indirect!r}")
    gm = None
    if "gm" in table:
        gm = to_si(table["gm"], "gm", f"{key}.gm", strict=strict, positive=True)
    term = ThirdBody("third_body", "third_body", dict(table), {})
    term.key = key
    if lower in BODIES:
        if "orbit" in table:
            raise InputError(f"{key}.orbit", f"the {lower}'s path comes from the ephemeris; orbit is for a Kepler body")
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
                raise InputError(f"{key}.{need}", f"{name!r} is a body on a Kepler orbit: give its gm and its orbit")
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
    term.setup(body, gm, step, indirect, field.center, ephemeris, kepler)
    return term
