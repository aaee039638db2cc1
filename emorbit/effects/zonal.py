"""Zonal harmonics J2..J6 of the central body (``[[effect]] kind = "zonal"``).

Potential energy of a body of mass m, with ``d = x - c``, ``r = |d|``, ``z = d . p`` about
the pole p (a unit vector) and the model's reference radius R::

    V = (GM m / r) sum_{n=2}^{N} J_n (R / r)^n P_n(z / r)

(the -GM m / r part is the central field). Every term is a product f(r) g(z), so its
discrete gradient in the invariants r and z (the averaged split of each product) gives a
force over the step whose work is exactly the potential drop, and which lies in the plane
of ``d0 + d1`` and p: an em step keeps the energy and the angular momentum about the pole
(:mod:`emorbit.kernels.effects.zonal` has the equations). A coordinate discrete gradient
(Gonzalez's midpoint form) would keep the energy but not that angular momentum. Rigid bodies
feel it on their mass points, so its torque arises as the gravity gradient's does; elastic
bodies at their gravity points. Point masses under the central field and zonal harmonics
alone run the packed kernel :mod:`emorbit.kernels.effects.zonal_packed` (:meth:`Zonal.packed`).

GM and the centre are the field's; R and J_n are the model's: "earth" is EGM2008's zonal
part (tide-free, J_n = -C_n0 sqrt(2n + 1) from the fully normalised C_n0), read from the
package's ``data/egm2008_6.gfc`` (:func:`zonal_model`; written from heyoka's EGM2008 table
by ``scripts/data_egm2008.py``), or ``j`` and ``radius`` give them. References: N. K.
Pavlis et al., J. Geophys. Res. 117 (2012) B04406 (EGM2008); T. Itoh, K. Abe, J. Comput. Phys. 76 (1988) 85-102.
"""

from __future__ import annotations

import functools
import math
import numbers
import os

import numpy as np

from ..errors import InputError
from ..kernels.effects.zonal import NMAX
from ..keys import Key
from ..units import to_si, vector_to_si
from .base import Effect, Pieces

__all__ = ["Zonal", "MODELS", "zonal_model"]

#: the shipped zonal models: name -> the ICGEM file in the package's data folder
MODELS = {"earth": "egm2008_6.gfc"}


@functools.cache
def zonal_model(name: str) -> dict:
    """A shipped zonal model's constants.

    Parameters
    ----------
    name : str
        A key of :data:`MODELS`.

    Returns
    -------
    dict
        ``gm`` (m^3/s^2) and reference ``radius`` (m) of the model, ``cbar`` the fully
        normalised C_20..C_N0, ``jn`` = (J2, ..., J_N) with J_n = -C_n0 sqrt(2n + 1),
        ``tide_system`` and ``source`` (N = 6).
    """
    from ..io.icgem import read_gfc

    path = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", MODELS[name])
    c = read_gfc(path, NMAX, f"zonal model {name!r}")
    cbar = tuple(float(v) for v in c.C[2:, 0])
    return {
        "gm": c.gm,
        "radius": c.radius,
        "cbar": cbar,
        "jn": tuple(-v * math.sqrt(2 * n + 1) for n, v in enumerate(cbar, start=2)),
        "tide_system": c.tide_system,
        "source": f"{c.name} (N. K. Pavlis et al., J. Geophys. Res. 117 (2012) B04406), {path}",
    }


#: bounds of the reference radius, m (a body's: from a boulder's to beyond a star's)
MIN_RADIUS, MAX_RADIUS = 1.0, 1e12


class Zonal(Effect):
    """Zonal harmonics as an effect: ``p = [c0, c1, c2, p0, p1, p2, GM, R, J2, ..., J_degree]``."""

    NAME = "zonal"
    SUMMARY = "zonal harmonics J2..J6 of the central body, about its pole"
    KEYS = (
        Key("model", False, "string", "", '"earth" (EGM2008); or give j and radius',
            "the shipped zonal coefficients and reference radius"),
        Key("j", False, "array of numbers", "", "1 to 5 finite numbers: J2, J3, ... J6",
            "the zonal coefficients J_n (unnormalized), instead of model"),
        Key("radius", False, "length (m)", "the model's", "1 to 1e12", "the reference radius R of the coefficients"),
        Key("degree", False, "integer", "every degree given", f"2 to {NMAX}", "use J2..J<degree>"),
        Key("pole", False, "3 numbers", "[0, 0, 1]", "a vector other than 0 (normalised)",
            "the body's axis of symmetry, in the scene's axes"),
    )  # fmt: skip
    CONSERVES = ("energy", "angular momentum about the pole")
    NEEDS_FIELD = True
    PIECES = Pieces("emorbit.kernels.effects.zonal", force="zonal_piece", potential="zonal_potential_piece")
    POTENTIAL = "V = (GM m / r) sum_n J_n (R / r)^n P_n(z / r), z = (x - c) . p"
    DISCRETE_FORCE = "F = -m (A (d0 + d1) / (r0 + r1) + B p): A, B the averaged discrete derivatives in r and z"
    JACOBIAN_LEFT_OUT = 0.0
    JACOBIAN = "dF/dx1 = -m (u dA/dx1^T + A du/dx1 + p dB/dx1^T), u = (d0 + d1) / (r0 + r1)"

    @staticmethod
    def packed(effects):
        """The packed point-mass kernel for exactly the central field and these harmonics about
        the same centre (:func:`emorbit.kernels.effects.zonal_packed.chunk`), with its parameter
        arrays; None for any other set."""
        if [e.kind for e in effects] != ["central", "zonal"] or not np.array_equal(effects[0].p[:3], effects[1].p[:3]):
            return None
        from ..kernels.effects.zonal_packed import chunk

        return chunk, (effects[0].p, effects[1].p[:8].copy(), effects[1].p[8:].copy())

    @classmethod
    def from_table(cls, table, context) -> Zonal:
        """Zonal harmonics from ``model`` or ``j`` with ``radius``; ``degree``, ``pole``.

        Raises
        ------
        InputError
            Neither or both of ``model`` and ``j``, an unknown model, coefficients or a
            radius that are not finite, a degree out of range, a pole of length 0.
        """
        key, field, strict = context.key, context.field, context.strict
        model, given = table.get("model"), table.get("j")
        if (model is None) == (given is None):
            raise InputError(key, 'give exactly one of model (e.g. "earth") and j (with radius)')
        if model is not None:
            if not isinstance(model, str) or model.lower() not in MODELS:
                raise InputError(f"{key}.model", f"unknown zonal model {model!r}; known: {', '.join(MODELS)}")
            shipped = zonal_model(model.lower())
            jn, radius = list(shipped["jn"]), shipped["radius"]
        else:
            if (
                not isinstance(given, (list, tuple))
                or not 1 <= len(given) <= NMAX - 1
                or not all(isinstance(v, numbers.Real) and not isinstance(v, bool) and np.isfinite(v) for v in given)
            ):
                raise InputError(f"{key}.j", f"1 to {NMAX - 1} finite numbers (J2, J3, ...) expected, got {given!r}")
            jn = [float(v) for v in given]
            if "radius" not in table:
                raise InputError(f"{key}.radius", "j needs the reference radius of its coefficients")
            radius = None
        if "radius" in table:
            radius = to_si(table["radius"], "length", f"{key}.radius", strict=strict, positive=True)
            if not MIN_RADIUS <= radius <= MAX_RADIUS:  # gm / R^2 and (R / r)^n stay in float64's range
                raise InputError(
                    f"{key}.radius", f"{radius!r} m is no body's radius: give one in [{MIN_RADIUS:g}, {MAX_RADIUS:g}] m"
                )
            if field.radius > 0.0 and not 1e-3 <= radius / field.radius <= 1e3:
                raise InputError(
                    f"{key}.radius",
                    f"{radius!r} m is not within a factor 1000 of the central body's radius {field.radius!r} m",
                )
        degree = table.get("degree", len(jn) + 1)
        if isinstance(degree, bool) or not isinstance(degree, numbers.Integral) or not 2 <= degree <= len(jn) + 1:
            raise InputError(f"{key}.degree", f"an integer from 2 to {len(jn) + 1} expected, got {degree!r}")
        pole = np.asarray(vector_to_si(table.get("pole", [0.0, 0.0, 1.0]), "dimensionless", f"{key}.pole"), float)
        norm = float(np.linalg.norm(pole))
        if not norm > 0.0:
            raise InputError(f"{key}.pole", f"a vector other than 0 expected, got {table.get('pole')!r}")
        return cls(table, [*field.center, *(pole / norm), field.gm, radius, *jn[: degree - 1]])
