"""A rotating central body's gravity field in spherical harmonics of any degree and order
(``[[effect]] kind = "gravity_field"``), with the Jacobi integral kept to round-off.

Field. The degrees 1..N and orders 0..M of a fully normalised model (``model = "egm2008"``,
from heyoka's table, degree 150; or ``gfc``, any static field in ICGEM's format:
:mod:`emorbit.io.icgem`) in Pines' singularity-free form with the normalised column
recursion of the derived Legendre functions (:mod:`emorbit.kernels.effects.gravity_field`
has the equations). The degree-0 term is the central field's (``[field]``'s GM); the
harmonics scale with the model's own GM and radius. At degree and order 2, 20 and 70 the
acceleration agrees with heyoka's EGM2008 model to 1.2e-15 relative at 1000 points from 200 to
40 000 km altitude (``tests/test_gravity_field.py``). With only the zonal terms (``order =
0``) it gives the ``zonal`` effect's acceleration at a point; ``zonal`` stays the fast
axisymmetric case (its discrete force keeps the angular momentum about the pole as well).

Rotation. The body turns uniformly about its ``pole`` (default the scene's z axis) at the
rate ``rate``, its prime meridian at ``angle`` from the scene's x axis (projected on the
equator) at time 0; ``rotation = "earth"`` takes the Earth's rate (7.292115146706979e-5
rad/s, IERS) and the Earth rotation angle at the run's epoch (astropy, UT1 from the epoch);
``rotation = "pck"`` takes the IAU WGCCRE model of ``body`` (a NAIF id, or "moon", "mars",
...) from a NAIF text kernel the user names (``pck``, e.g. pck00011.tpc;
:mod:`emorbit.io.pck`): its pole, node, prime meridian and rate at the epoch, held uniform
over the run (the scene's axes are then ICRF's); ``rotation = "itrs"`` takes the Earth's
ITRS as erfa composes it (IAU 2006/2000A precession-nutation, the Earth rotation angle of UT1,
polar motion, from astropy's IERS tables), sampled every hour over the run and interpolated
per sub-step (cubic): against astropy's ITRS the frame is 9.5e-17 rad off at the epoch,
2.1e-14 a day later and 1.2e-13 thirty days later. The step's turn is then that of the
sampled frames between the sub-step's ends. Past the tables' end the last UT1 - UTC and polar
motion are held, with a warning. The scene's axes are then GCRS's.
A field without a rotation is refused: it would stay fixed in inertial space.

Discrete force and invariants. Over a step of length h the force is Gonzalez's midpoint
discrete gradient of the field, taken along the step's move as the rotating frame sees it with
the step's Cayley rate ``w_h = (2 / h) tan(w h / 2)``, so that its work minus the field's
change equals ``w_h . dL``: fixed em steps of order 2 of point masses in the field (with the
central field and nothing else that turns them) keep the step's Jacobi integral
``E - w_h . L`` to round-off, L the angular momentum about the centre (the run file records
``E - w . L``, ``invariants/jacobi``); ``w_h`` exceeds the spin by (w h)^2 / 12
(3.6e-6 at LEO steps of 90 s), and the field itself turns by exactly ``w h`` per step. The
true spin ``w`` instead would make the force inconsistent for a satellite at rest over the
ground (the move it sees would be the O(h^3) gap between the rotation and its midpoint
form). Every body kind keeps the energy balance ``E - E0 - W`` to round-off, W the work of
the field's motion (``invariants/work_<label>``).

References: N. K. Pavlis et al., J. Geophys. Res. 117 (2012) B04406 (EGM2008); S. Pines,
AIAA J. 11 (1973) 1508-1511; O. Gonzalez, J. Nonlinear Sci. 6 (1996) 449-467; G. Petit,
B. Luzum (eds.), IERS Conventions (2010), IERS Technical Note 36, section 5.4.4 (the Earth
rotation angle).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from astropy.time import Time

from ..errors import InputError
from ..io.icgem import MAX_DEGREE, model, read_gfc
from ..keys import Key
from ..units import to_si, vector_to_si
from .base import AT_POINTS, Effect, Pieces, epoch_needed

__all__ = ["GravityField", "EARTH_RATE"]

#: the Earth's mean rotation rate, rad/s: 2 pi 1.00273781191135448 / 86400 (IERS 2010)
EARTH_RATE = 2.0 * math.pi * 1.00273781191135448 / 86400.0
#: rotation = "itrs": the sampling interval of the Earth's orientation, s (cubic interpolation
#: between samples; its fastest nutation terms have periods of days)
ITRS_STEP = 3600.0
#: the most samples of the Earth's orientation a run may take (a century at ITRS_STEP)
MAX_ITRS_SAMPLES = 900_000
_KEYS = (
    Key("model", False, "string", "", '"egm2008" (heyoka\'s table, degree 150); or give gfc',
        "the shipped model"),
    Key("gfc", False, "string", "", "the path of an ICGEM .gfc file (static, fully normalised; .gz too)",
        "a field from a file instead of model: any published one (GRGM for the Moon, MRO for Mars)"),
    Key("degree", True, "integer", "", f"1 to {MAX_DEGREE} (and the model's)", "the highest degree N"),
    Key("order", False, "integer", "the degree", "0 to the degree", "the highest order M"),
    Key("rotation", True, "string", "", '"earth", "itrs", "uniform" or "pck"',
        "the body's rotation: the Earth's rate and rotation angle at the epoch; the Earth's ITRS at the "
        "epoch (IAU 2006/2000A, IERS data); rate and angle; or the IAU model of a NAIF text kernel"),
    Key("rate", False, "angular speed (rad / s)", "", "finite; with rotation = \"uniform\"",
        "the body's spin rate about its pole (negative: retrograde)"),
    Key("angle", False, "angle (rad)", "0", "finite; with rotation = \"uniform\"",
        "the prime meridian's angle from the scene's x axis (in the equator) at time 0"),
    Key("pole", False, "3 numbers", "[0, 0, 1]", "a vector other than 0 (normalised)",
        "the body's spin axis, in the scene's axes"),
    Key("pck", False, "string", "", 'the path of a NAIF text PCK (pck00011.tpc); with rotation = "pck"',
        "the kernel whose IAU rotation model turns the body"),
    Key("body", False, "string or integer", "the [field]'s named body",
        'a NAIF id (301, 499) or "moon", "mars", ...; with rotation = "pck"',
        "the body in the kernel"),
)  # fmt: skip


def _earth_orientation(epoch, key):
    """UT1 (an astropy Time) and the polar motion (xp, yp, rad) at ``epoch`` from astropy's IERS
    tables, without a download. Past their end (astropy would extrapolate without a word), the
    tables' last UT1 - UTC and polar motion are held, with a warning naming the effect: UT1 -
    UTC drifts by under 1 s a year, so the rotation angle is then off by under 7e-5 rad per year
    past the table."""
    import warnings

    from astropy.utils import iers

    with iers.conf.set_temp("auto_download", False), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = iers.earth_orientation_table.get()
        epoch_utc = epoch.utc
        last = float(table["MJD"][-1].to_value("d"))
        if float(np.max(epoch_utc.mjd)) <= last:
            try:
                ut1 = epoch.ut1
                xp, yp = table.pm_xy(epoch)
                return ut1, np.asarray(xp.to_value("rad"), float), np.asarray(yp.to_value("rad"), float)
            except (ValueError, IndexError):
                pass
    warnings.warn(
        f"{key}.rotation: astropy's IERS tables end at {Time(last, format='mjd', scale='utc').iso[:10]}; the "
        "Earth's orientation at the epoch holds their last UT1 - UTC and polar motion (the rotation angle off by "
        "under 7e-5 rad per year past it)",
        stacklevel=3,
    )
    ut1 = Time(epoch_utc.jd1, epoch_utc.jd2 + float(table["UT1_UTC"][-1].to_value("s")) / 86400.0,
               format="jd", scale="ut1")  # fmt: skip
    xp = np.full(np.shape(epoch_utc.jd1), float(table["PM_x"][-1].to_value("rad")))
    yp = np.full(np.shape(epoch_utc.jd1), float(table["PM_y"][-1].to_value("rad")))
    return ut1, xp, yp


def _itrs(epoch, key):
    """The GCRS-to-ITRS rotation at ``epoch`` (one Time or an array) as erfa composes it,
    ``RPOM R3(ERA) RC2I``: the celestial-to-intermediate matrix (IAU 2006/2000A), the Earth
    rotation angle (rad) and the polar motion matrix, from the UT1 and polar motion of astropy's
    IERS tables (:func:`_earth_orientation`)."""
    import erfa

    ut1, xp, yp = _earth_orientation(epoch, key)
    tt = epoch.tt
    rc2i = erfa.c2i06a(tt.jd1, tt.jd2)
    era = erfa.era00(ut1.jd1, ut1.jd2)
    rpom = erfa.pom00(xp, yp, erfa.sp00(tt.jd1, tt.jd2))
    if np.ndim(era) == 0:
        return np.asarray(rc2i, float), float(era), np.asarray(rpom, float)
    return np.asarray(rc2i, float), np.asarray(era, float), np.asarray(rpom, float)


class GravityField(Effect):
    """A rotating gravity field as an effect: ``p`` and ``tab`` as
    :mod:`emorbit.kernels.effects.gravity_field` (:func:`~emorbit.kernels.effects.gravity_field.tables`).

    Attributes
    ----------
    coefficients : emorbit.io.icgem.Coefficients
        The model as read.
    degree, order : int
        N and M.
    rate : float
        The spin rate, rad/s.
    angle : float or None
        The prime meridian's angle at time 0, rad (None: the Earth rotation angle at the epoch,
        set by :meth:`prepare`).
    frame : numpy.ndarray
        (3, 3) the columns e1 (the prime meridian at angle 0), e2, e3 (the pole).
    """

    NAME = "gravity_field"
    SUMMARY = "a rotating body's gravity field in spherical harmonics of any degree and order"
    KEYS = _KEYS
    ACTS = {"point": AT_POINTS, "rigid": AT_POINTS, "elastic": AT_POINTS}
    CONSERVES: tuple[str, ...] = ()
    NEEDS_FIELD = True
    PATH_KEYS = ("gfc", "pck")
    PIECES = Pieces(
        "emorbit.kernels.effects.gravity_field",
        force="gravity_field_piece",
        potential="gravity_field_potential_piece",
        prepare="gravity_field_prepare",
        time_work="gravity_field_time_work",
    )
    POTENTIAL = (
        "V = -m sum_{n>=1} (mu / r) (R / r)^n sum_m A_nm(u) (C_nm Re (s+it)^m + S_nm Im (s+it)^m), "
        "in the body's turning frame"
    )
    DISCRETE_FORCE = (
        "F = m [g + ((dU - g . delta) / (delta . delta)) delta], g = grad U(x_m, t_m), "
        "delta = x1 - x0 - 2 tan(w h / 2) e3 x (x_m - c), dU = U(x1, t1) - U(x0, t0); W = F . (x1 - x0) - m dU"
    )
    JACOBIAN = "none: Newton takes the central field's (LEO at T/60, 20 x 20: 4.0 sweeps per step, zonal 2.0)"

    time_dependent = True

    @property
    def needs_epoch(self) -> bool:
        """``rotation = "earth"`` and ``"pck"`` take the body's rotation angle at the run's epoch."""
        return self.angle is None

    def scratch_size(self, n_points: int) -> int:
        return 70 + 2 * (self.degree + 2)  # angles, h, the last start's U, frames, turn, two columns

    def prepare(self, t0: float, t1: float, epoch) -> None:
        """Set the angle at time 0 from the Earth rotation angle at the epoch (``rotation =
        "earth"``), or the pole, the node, the angle and the rate from the kernel's IAU model at
        the epoch (``rotation = "pck"``: the model's value and rate at the epoch, held uniform
        over the run); ``rotation = "uniform"`` has its own.

        Raises
        ------
        InputError
            ``rotation = "earth"`` or ``"pck"`` without an epoch; a kernel without the body.
        """
        if self.angle is not None:
            return
        if epoch is None:
            raise epoch_needed(f"{self.key}.rotation turns the field by the body's rotation angle at the epoch")
        if self.itrs:
            self._itrs_table(t0, t1, epoch)
            return
        if self._kernel_values is None:
            import erfa

            ut1 = _earth_orientation(epoch, self.key)[0]
            self.p[12] = float(erfa.era00(ut1.jd1, ut1.jd2))
            return
        from ..io.pck import orientation

        values, body = self._kernel_values
        pole, node, w, rate = orientation(values, body, epoch, f"{self.key}.pck")
        self.frame = np.column_stack([node, np.cross(pole, node), pole])
        self.p[3:12] = self.frame.ravel()
        self.p[12], self.p[13] = w, rate
        self.rate = rate

    @classmethod
    def from_table(cls, table, context) -> GravityField:
        """A field from ``model`` or ``gfc``, ``degree``, ``order``, ``rotation`` (with ``rate``
        and ``angle``), ``pole``.

        Raises
        ------
        InputError
            Neither or both of model and gfc; a degree or order out of range or beyond the
            model; no rotation, or rate and angle with the Earth's; a pole of length 0; a file
            that cannot be read (see :func:`emorbit.io.icgem.read_gfc`).
        """
        key, field, strict = context.key, context.field, context.strict
        name, path = table.get("model"), table.get("gfc")
        if (name is None) == (path is None):
            raise InputError(key, 'give exactly one of model (e.g. "egm2008") and gfc (an ICGEM file)')
        degree = table.get("degree")
        if isinstance(degree, bool) or not isinstance(degree, numbers.Integral) or not 1 <= degree <= MAX_DEGREE:
            raise InputError(f"{key}.degree", f"an integer from 1 to {MAX_DEGREE} expected, got {degree!r}")
        order = table.get("order", degree)
        if isinstance(order, bool) or not isinstance(order, numbers.Integral) or not 0 <= order <= degree:
            raise InputError(f"{key}.order", f"an integer from 0 to the degree {degree} expected, got {order!r}")
        rotation = table.get("rotation")
        if rotation not in ("earth", "itrs", "uniform", "pck"):
            raise InputError(
                f"{key}.rotation",
                'a gravity field turns with its body: give rotation = "earth" (the Earth\'s rate and rotation '
                'angle at the epoch), "itrs" (the Earth\'s ITRS at the epoch), "uniform" (with rate and angle) '
                f'or "pck" (with pck and body), got {rotation!r}',
            )
        for extra in ("pck", "body"):
            if extra in table and rotation != "pck":
                raise InputError(f"{key}.{extra}", f'{extra} goes with rotation = "pck"')
        kernel = None
        if rotation == "pck":
            for extra in ("rate", "angle", "pole"):
                if extra in table:
                    raise InputError(f"{key}.{extra}", 'rotation = "pck" takes the rotation from the kernel')
            kernel = cls._kernel(table, key, field)
            rate, angle = 0.0, None
        elif rotation in ("earth", "itrs"):
            for extra in ("rate", "angle") + (("pole",) if rotation == "itrs" else ()):
                if extra in table:
                    raise InputError(f"{key}.{extra}", f'rotation = "{rotation}" sets the rate and the angle itself')
            rate, angle = EARTH_RATE, None
        else:
            if "rate" not in table:
                raise InputError(f"{key}.rate", 'rotation = "uniform" needs the spin rate (e.g. "7.292115e-5 rad / s")')
            rate = to_si(table["rate"], "angular_speed", f"{key}.rate", strict=strict)
            angle = to_si(table.get("angle", 0.0), "angle", f"{key}.angle", strict=strict)
            if not (math.isfinite(rate) and math.isfinite(angle)):
                raise InputError(f"{key}.rate", f"a finite rate and angle expected, got {rate!r}, {angle!r}")
        pole = np.asarray(vector_to_si(table.get("pole", [0.0, 0.0, 1.0]), "dimensionless", f"{key}.pole"), float)
        norm = float(np.linalg.norm(pole))
        if not norm > 0.0 or not math.isfinite(norm):
            raise InputError(f"{key}.pole", f"a vector other than 0 expected, got {table.get('pole')!r}")
        e3 = pole / norm
        x_axis = np.array([1.0, 0.0, 0.0]) if abs(e3[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = x_axis - np.dot(x_axis, e3) * e3
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(e3, e1)
        frame = np.column_stack([e1, e2, e3])
        if name is not None:
            if not isinstance(name, str):
                raise InputError(f"{key}.model", f'a model name expected (e.g. "egm2008"), got {name!r}')
            coefficients = model(name, degree, f"{key}.model")
        else:
            if not isinstance(path, str) or not path.strip():
                raise InputError(f"{key}.gfc", f"the path of an ICGEM .gfc file expected, got {path!r}")
            coefficients = read_gfc(path, degree, f"{key}.gfc")
        from ..kernels.effects.gravity_field import tables

        p = [
            *field.center, *frame.ravel(), 0.0 if angle is None else angle, rate,
            coefficients.gm, coefficients.radius, float(degree), float(order), *np.eye(3).ravel(),
            0.0, 0.0, 0.0, 0.0,
        ]  # fmt: skip
        effect = cls(table, p, tables(coefficients.C, coefficients.S, degree, order))
        effect.coefficients, effect.degree, effect.order = coefficients, int(degree), int(order)
        effect.rate, effect.angle, effect.frame = float(rate), angle, frame
        effect._kernel_values = kernel
        effect.itrs = rotation == "itrs"
        effect._field_size, effect._span = effect.tab.size, None
        return effect

    @staticmethod
    def _kernel(table, key, field):
        """rotation = "pck": the kernel's values and the body's NAIF id (``body``, else the
        [field]'s named body)."""
        from ..io.pck import NAIF_IDS, read_pck

        if "pck" not in table:
            raise InputError(f"{key}.pck", 'rotation = "pck" needs the path of a NAIF text kernel (pck00011.tpc)')
        body = table.get("body", field.body)
        if isinstance(body, str) and body.strip().lower() in NAIF_IDS:
            body = NAIF_IDS[body.strip().lower()]
        if isinstance(body, bool) or not isinstance(body, numbers.Integral) or not 1 <= body <= 99999:
            known = ", ".join(NAIF_IDS)
            raise InputError(
                f"{key}.body", f"a NAIF id (e.g. 499) or one of {known} expected, got {table.get('body', field.body)!r}"
            )
        path = table["pck"]
        return read_pck(path if isinstance(path, str) else None, f"{key}.pck"), int(body)

    def facts(self) -> dict:
        """The body's frame for the run file: ``body_frame`` with ``axes`` (e1, e2, e3 as columns),
        ``angle`` at time 0 (rad; the Earth rotation angle at the epoch once prepared) and
        ``rate`` (rad/s)."""
        return {"body_frame": {"axes": self.frame.tolist(), "angle": float(self.p[12]), "rate": self.rate}}

    def span_samples(self, t0: float, t1: float) -> int:
        """The samples of the ITRS table that cover ``t0`` to ``t1``."""
        return int(math.ceil(t1 / ITRS_STEP) - math.floor(t0 / ITRS_STEP)) + 5

    def _itrs_table(self, t0: float, t1: float, epoch) -> None:
        """rotation = "itrs": the frame at the epoch (B, P, the angle) and a table over the run's
        span, every :data:`ITRS_STEP` s, of B (RC2I^T), P (RPOM) and the angle's departure from
        the uniform ``ERA(epoch) + w t``, interpolated per sub-step by the kernel.

        Raises
        ------
        InputError
            A span of more than :data:`MAX_ITRS_SAMPLES` samples.
        """
        from astropy.time import TimeDelta

        if self.span_samples(t0, t1) > MAX_ITRS_SAMPLES:
            raise InputError(
                f"{self.key}.rotation",
                f"the run spans {self.span_samples(t0, t1)} samples of the Earth's orientation at {ITRS_STEP:g} s, "
                f'more than {MAX_ITRS_SAMPLES}: shorten the run or use rotation = "earth"',
            )
        stamp = (float(epoch.tdb.jd1), float(epoch.tdb.jd2))
        k_first = math.floor(t0 / ITRS_STEP) - 2
        k_last = math.ceil(t1 / ITRS_STEP) + 2
        if self._span is not None and self._span[0] <= k_first and self._span[1] >= k_last and self._span[2] == stamp:
            return
        rc2i, era, rpom = _itrs(epoch, self.key)
        self.frame = rc2i.T.copy()
        self.p[3:12] = self.frame.ravel()
        self.p[12] = era
        self.p[18:27] = rpom.ravel()
        t = np.arange(k_first, k_last + 1, dtype=float) * ITRS_STEP
        rows = np.empty((t.size, 19))
        c2i, eras, poms = _itrs(epoch + TimeDelta(t, format="sec"), self.key)
        rows[:, 0:9] = np.transpose(c2i, (0, 2, 1)).reshape(-1, 9)
        rows[:, 9:18] = poms.reshape(-1, 9)
        departure = eras - (era + self.rate * t)  # each sample alone: a resumed run's table has its bits
        rows[:, 18] = departure - 2.0 * np.pi * np.round(departure / (2.0 * np.pi))
        self.p[27:31] = 1.0, ITRS_STEP, float(k_first), float(t.size)
        self.tab = np.ascontiguousarray(np.concatenate([self.tab[: self._field_size], rows.ravel()]))
        self._span = (k_first, k_last, stamp)

    @property
    def spin(self) -> np.ndarray:
        """The spin vector ``w e3``, rad/s (3,)."""
        return self.rate * self.frame[:, 2]
