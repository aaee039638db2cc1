"""A body's orientation from a NAIF text PCK: the IAU WGCCRE rotation model at an epoch.

NAIF's text planetary constants kernels (``pck00011.tpc`` and its predecessors, from
https://naif.jpl.nasa.gov/pub/naif/generic_kernels/pck/; public domain, NASA/JPL) carry the
IAU Working Group on Cartographic Coordinates and Rotational Elements' models (B. A. Archinal
et al., Celest. Mech. Dyn. Astron. 130 (2018) 22) between ``\\begindata`` and ``\\begintext``
lines, as assignments ``BODY<id>_<NAME> = ( values )`` that may span lines, with Fortran
exponents (``-1.4D-12``). For a body with NAIF id ``id`` (its barycentre ``id // 100``)::

    alpha0 = RA0 + RA1 T + RA2 T^2 + sum_k NUT_PREC_RA[k]  sin E_k      (deg)
    delta0 = DEC0 + DEC1 T + DEC2 T^2 + sum_k NUT_PREC_DEC[k] cos E_k    (deg)
    W      = PM0 + PM1 d + PM2 d^2 + sum_k NUT_PREC_PM[k]  sin E_k       (deg)
    E_k    = a_k + b_k T  (BODY<barycentre>_NUT_PREC_ANGLES, pairs in deg and deg/century)

with d days and T Julian centuries of TDB since J2000. The pole is ``(cos delta0 cos alpha0,
cos delta0 sin alpha0, sin delta0)`` in ICRF axes, W the prime meridian's angle from the node
of the body's equator on the ICRF equator (right ascension alpha0 + 90 deg).

Data layout: :func:`orientation` returns the pole, the node (unit vectors, ICRF), W (rad) and
dW/dt (rad/s) at the epoch.
"""

from __future__ import annotations

import math
import os
import re

import numpy as np

from ..errors import InputError

__all__ = ["NAIF_IDS", "read_pck", "orientation", "MAX_PCK_BYTES"]

#: NAIF ids of the bodies a scene may name
NAIF_IDS = {"mercury": 199, "venus": 299, "earth": 399, "moon": 301, "mars": 499, "jupiter": 599, "saturn": 699}
#: the largest text kernel read (pck00011.tpc is 0.13 MB)
MAX_PCK_BYTES = 16 * 2**20
_ASSIGN = re.compile(r"([A-Za-z0-9_]+)\s*(\+?=)\s*\(([^)]*)\)", re.S)


def read_pck(path, key: str = "pck") -> dict[str, list[float]]:
    """The numeric assignments of a text PCK's data blocks.

    Raises
    ------
    InputError
        No such file, one larger than :data:`MAX_PCK_BYTES`, or no data block.
    """
    if not isinstance(path, str) or not os.path.isfile(path):
        raise InputError(key, f"no PCK file {path!r}")
    if os.path.getsize(path) > MAX_PCK_BYTES:
        raise InputError(key, f"{path!r} is larger than {MAX_PCK_BYTES} bytes: not a text PCK")
    with open(path, encoding="latin-1") as f:
        text = f.read()
    blocks, inside = [], False
    for line in text.splitlines():
        word = line.strip()
        if word == "\\begindata":
            inside = True
        elif word == "\\begintext":
            inside = False
        elif inside:
            blocks.append(line)
    if not blocks:
        raise InputError(key, f"{path!r} has no \\begindata block: not a NAIF text kernel")
    values: dict[str, list[float]] = {}
    for name, op, body in _ASSIGN.findall("\n".join(blocks)):
        numbers = []
        for token in body.replace(",", " ").split():
            try:
                numbers.append(float(token.replace("D", "E").replace("d", "e")))
            except ValueError:
                numbers = None  # a string value ('...'), not ours
                break
        if numbers is None:
            continue
        values[name.upper()] = values.get(name.upper(), []) + numbers if op == "+=" else numbers
    return values


def orientation(values: dict, body: int, epoch, key: str = "pck"):
    """The pole, the node, W and dW/dt of body ``body`` at ``epoch`` (astropy Time).

    Returns
    -------
    tuple
        pole (3,), node (3,) unit vectors in ICRF axes; W (rad); dW/dt (rad/s).

    Raises
    ------
    InputError
        The kernel lacks the body's POLE_RA, POLE_DEC or PM, or its nutation-precession terms
        do not match its angles.
    """
    prefix = f"BODY{int(body)}_"
    for name in ("POLE_RA", "POLE_DEC", "PM"):
        if prefix + name not in values or not 1 <= len(values[prefix + name]) <= 3:
            raise InputError(key, f"the kernel gives no {prefix + name} (1 to 3 numbers) for body {body}")
    jd = epoch.tdb.jd1 - 2451545.0 + epoch.tdb.jd2
    d, t = float(jd), float(jd) / 36525.0

    def poly(name, x):
        c = list(values[prefix + name]) + [0.0, 0.0]
        return c[0] + c[1] * x + c[2] * x * x, c[1] + 2.0 * c[2] * x

    angles = values.get(f"BODY{int(body) // 100}_NUT_PREC_ANGLES", [])
    if len(angles) % 2:
        raise InputError(key, f"BODY{int(body) // 100}_NUT_PREC_ANGLES holds an odd number of values")
    e = np.radians(np.array(angles[0::2]) + np.array(angles[1::2]) * t)
    e_dot = np.radians(np.array(angles[1::2])) / 36525.0  # rad/day

    def terms(name, fn, dfn):
        c = np.array(values.get(prefix + "NUT_PREC_" + name, []), float)
        if c.size > e.size:
            raise InputError(key, f"{prefix}NUT_PREC_{name} has {c.size} terms for {e.size} angles")
        return float(np.sum(c * fn(e[: c.size]))), float(np.sum(c * dfn(e[: c.size]) * e_dot[: c.size]))

    ra, _ = poly("POLE_RA", t)
    dec, _ = poly("POLE_DEC", t)
    w, w_dot = poly("PM", d)
    ra += terms("RA", np.sin, np.cos)[0]
    dec += terms("DEC", np.cos, lambda x: -np.sin(x))[0]
    dw, dw_dot = terms("PM", np.sin, np.cos)
    w, w_dot = w + dw, w_dot + dw_dot  # deg, deg/day
    a, b = math.radians(ra), math.radians(dec)
    pole = np.array([math.cos(b) * math.cos(a), math.cos(b) * math.sin(a), math.sin(b)])
    node = np.array([-math.sin(a), math.cos(a), 0.0])
    return pole, node, math.radians(w % 360.0), math.radians(w_dot) / 86400.0
