"""An effect set compiled into the seven functions every body kind's step kernel takes.

:func:`compile_set` writes, for an ordered set of effect classes, a small Python module that
imports each effect's pieces (:class:`~emorbit.effects.base.Pieces`) and defines the seven
functions of :mod:`emorbit.kernels.effects.signatures` as Numba ``cfunc`` s of those types:
``forces`` (each point's summed force over the step per unit mass, its diagonal Jacobian
blocks, the pair coupling), ``prepare`` (each effect's per-sub-step values), ``work`` (each
working effect's work on each point), ``potential`` (each effect's potential energy at each
point), ``facets`` (the surface effects' force on each facet and its work) and ``cross``
(the pair effects' blocks between bodies, for a structure's Newton matrix) and ``rate``
(the time scale of adaptive steps, from the effects that set one). The step
kernels of point masses, rigid bodies and elastic structures take these as first-class
function arguments, so they compile once per install; a new effect set compiles only these
seven small functions, whatever body kinds it reaches.

The per-point loops come from a second kind of generated module, one per effect
(:func:`loop_module`): ``forces_jac`` and ``forces_plain`` add the effect's force at each point
of a block of points (:mod:`emorbit.kernels.effects.blocks`), with its Jacobian block and
without, and ``work`` writes its work there. Each loop calls the effect's piece at every point
of the block, keeps it where the point's coefficient is not 0, and vectorises where the piece
does. These loops are C callbacks compiled once per install and effect; the set's ``forces``
and ``work`` call them block by block by name (:func:`~emorbit.kernels.effects.blocks.call_c`),
as they call the block loads and stores (:mod:`emorbit.kernels.effects.block_calls`), each
name bound to its code in this process before the set's functions compile or load. Linked
instead, their code would be optimised and emitted again in every set; called by name, a new
set compiles only its own short functions.

Every module goes into the per-user kernel cache (:func:`emorbit.kernels.jit.cache_dir`,
folder ``effects``), named by the set's kinds (an effect's kind) and a digest of its source,
of every kernel source and of any user module it imports, and is compiled with
``cache=True``: a set compiled once loads from disk in later processes. A file found there is
imported only if its content has the digest its name states. A function takes the views
``p3, t3, s3`` of the effects it reads, and no others.

Summation order: a point's force is the pair effects' forces, then each per-point effect's
in the set's order (that of :data:`emorbit.effects.EFFECTS`, then user effects in the order
they were registered); every piece adds its Jacobian into the same 3 x 3 block in that
order. With ``mode`` MODE_MIDPOINT the conservative effects take the midpoint twice,
``(x_m, x_m)`` (the force at the midpoint, whose derivative with respect to x1 is half the
field's gradient, as the midpoint rule's), and the others the step ``(x0, x1)``.

The compiled functions, with ``mode`` :data:`MODE_STEP` (the em step's discrete forces),
:data:`MODE_MIDPOINT` (conservative effects at the midpoint (x0 + x1) / 2, others over the
step), :data:`MODE_EXPLICIT` (x0 = x1 = x: the force at a point, leapfrog's kicks) or
:data:`MODE_POINT` (a time finite element's stage at the midpoint of a segment (x0, x1) over
which its velocity is the mean: forces that depend on the velocity over the segment, every
other at the midpoint), plus :data:`MODE_WEIGHTED` for forces rather than forces per unit
mass::

    forces(x0, x1, m, body, coef, h, mode, P, I, T, S, F, W, R, jac, first) -> status
        F (3, n) per unit mass, W (9, n) its diagonal Jacobian blocks ``W[3 a + b, i] =
        dF_a,i / dx1_b,i`` where ``jac``, R (n,) the pair coupling bounds; weighted, F and W
        are the pair effects' own plus the point's mass times the others' sum (N, N/m);
        status :data:`~emorbit.kernels.codes.STATUS_SINGULAR` where a force is not finite.
    prepare(ta, tm, tb, P, I, T, S)
    work(x0, dx, m, body, coef, h, mode, P, I, T, S, out)
        out (w, n): each working effect's work on each point over the step from x0 to
        x0 + dx (J): ``m F . dx`` for a force that does work, the ``time_work`` of a potential
        that changes in time; w is the number of working effects, in the set's order. With
        :data:`MODE_POINT`, every working effect's ``m F(x0) . dx``: its force at x0 (a stage
        of a time finite element) times a displacement; a force that depends on the velocity
        takes it as ``dx / h``, over ``(x0 - dx / 2, x0 + dx / 2)``. A set
        with an effect that changes mass (a ``mass`` piece) has one more row, its *ledger
        row* (the last): the point's work over the step at its true mean mass, ``(1 + sum
        dmu) sum_k out[k, i]``, dmu the ``mass`` pieces' parts where they act on the point.
    potential(x, m, body, coef, P, I, T, S, out)
        out (k, n): each effect's potential energy at each point (J; 0 for effects without
        one; a pair effect puts half of each pair's energy on each point), after ``prepare``
        at the time of x.
    rate(x, v, m, body, coef, P, I, T, S) -> (W, dW)
        the largest squared rate over the points, the effects' ``rate`` and pairs'
        ``pair_rate`` (0 where none gives one), and its rate of change.
    cross(x0, x1, m, body, coef, on, sc, acc, P, I, T, S)
        the pair effects' blocks between bodies, summed onto each pair of bodies' slots: for
        points a, b of bodies A < B (``on`` not 0 for both), with slot coefficients ``sc``
        (4, n), ``acc[A, B, i, j] += sc[i, a] sc[j, b] J_ab`` (acc (nb, nb, 4, 4, 3, 3)).
    facets(a, b, nrm, area, kf, h, P, I, T, S, F, out, want_work) -> status
        a, b, nrm (3, nf): facet centres at the step's start and end, unit normals at its
        middle; area (nf,); kf (4, nf) the facet coefficients; F (3, nf) the surface
        effects' summed force on each facet (N); where ``want_work``, out (w, nf) gets each
        working effect's work ``F_e . (b - a)`` (J; 0 in the slots of effects without
        surfaces), and in the ledger row (where the set has one) the facet's mass mark: the
        ``mass`` pieces' dmu at the facets that are their own, 0 at others. A body kind that
        loses mass evenly (a rigid body) weighs all its work by ``1 + sum`` of its facets'
        marks.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
import tempfile
from dataclasses import dataclass

import numba.experimental.function_type  # noqa: F401  (registers Numba's typeof of cfuncs, kept below)
from numba.core.ccallback import CFunc
from numba.core.typing.typeof import typeof_impl

from ..kernels.effects import block_calls
from ..kernels.effects.blocks import ROW_COEF, ROW_K, ROW_OUT
from ..kernels.jit import cache_dir, cache_enabled, cached_sources_digest

__all__ = ["Program", "compile_set", "set_source"]

_numba_typeof_cfunc = typeof_impl.dispatch(CFunc)


@typeof_impl.register(CFunc)
def _typeof_cfunc(val, c):
    """A cfunc's Numba type, built once (Numba built it anew in every call of a kernel taking
    it), and its address by Numba's wrapper address protocol (``__wrapper_address__``), which
    a call reads instead of comparing the cfunc's signature with its type's again."""
    t = val.__dict__.get("_emorbit_numba_type")
    if t is None:
        t = val._emorbit_numba_type = _numba_typeof_cfunc(val, c)
        val.__wrapper_address__ = lambda address=val.address: address
    return t


@dataclass(frozen=True)
class Program:
    """The seven compiled functions of an effect set and what they were made from.

    Attributes
    ----------
    forces, prepare, work, potential, facets, cross, rate
        The compiled functions (Numba cfuncs of :mod:`emorbit.kernels.effects.signatures`),
        for compiled callers: a cfunc called from Python runs its Python source, where
        ``forces`` and ``work`` cannot call their loops (``forces`` from Python:
        :func:`~emorbit.kernels.effects.blocks.run_forces`).
    kinds : tuple of str
        The effect kinds, in the set's order (a kind named twice appears twice).
    working : tuple of int
        The indices in the set of the effects whose work the step sums, in slot order.
    ledger : bool
        Whether the work has a ledger row after the working effects' (an effect changes mass).
    compiled : bool
        Whether this process compiled them (False: loaded from the disk cache).
    """

    forces: object
    prepare: object
    work: object
    potential: object
    facets: object
    cross: object
    rate: object
    kinds: tuple
    working: tuple
    ledger: bool
    compiled: bool


_HEADER = '''"""The compiled functions of the effect set: {names}.

Generated by emorbit.effects.program from the effects' pieces; do not edit.
Digest of the kernel sources and user modules: {digest}
"""

import math

import numba
import numpy as np

from emorbit.kernels.codes import STATUS_OK, STATUS_SINGULAR
from emorbit.kernels.effects.blocks import BLOCK, LD, call_c, copy_row
from emorbit.kernels.effects.signatures import CROSS, FACETS, FORCES, MODE_MIDPOINT, MODE_POINT, MODE_WEIGHTED
from emorbit.kernels.effects.signatures import POTENTIAL, PREPARE, RATE, WORK
{imports}

_OPTIONS = {options}
'''

_VIEWS = {
    "p": "p{e} = P[I[{e}, 0] : I[{e}, 1]]",
    "t": "t{e} = T[I[{e}, 2] : I[{e}, 3]]",
    "s": "s{e} = S[I[{e}, 4] : I[{e}, 5]]",
}
#: where a function's views of the effects' parameters, tables and scratch go
_VIEWS_AT = "# views"


def _with_views(function: str, k: int) -> str:
    """A function's source with the views it reads (``p3``, ``t3``, ``s3``) at
    :data:`_VIEWS_AT`: a view it does not read would cost its compile without use."""
    code = function.split(_VIEWS_AT, 1)
    used = [v.format(e=e) for e in range(k) for name, v in _VIEWS.items() if re.search(rf"\b{name}{e}\b", code[-1])]
    return function.replace(_VIEWS_AT, "\n    ".join(used) or "pass", 1)


#: one per-point effect's loop over a block of ``forces``: its force added into the rows of F
#: where its coefficient is not 0, its Jacobian block (on the stack, so that LLVM keeps it in
#: registers) into those of W; computed at every point and kept where it acts, so that the loop
#: has no branches
_EFFECT_LOOP = """for j in range(nb):
    k = B[ROW_K * LD + j]
    a0 = B[j]
    a1 = B[LD + j]
    a2 = B[2 * LD + j]
{ends}
    J = block33()
    if jac:
        for a in range(3):
            for b in range(3):
                J[a, b] = B[(9 + 3 * a + b) * LD + j]
    gx, gy, gz = force_({at}, h, k, p, t, s, J, jac)
    on = k != 0.0
    B[6 * LD + j] += gx if on else 0.0
    B[7 * LD + j] += gy if on else 0.0
    B[8 * LD + j] += gz if on else 0.0
    if jac:
        for a in range(3):
            for b in range(3):
                B[(9 + 3 * a + b) * LD + j] = J[a, b] if on else B[(9 + 3 * a + b) * LD + j]"""


def _ends(e0: str, e1: str, e2: str, conservative: bool, point: bool = False, moving: bool = False) -> str:
    """The step's end ``b`` from the expressions of its components and, for a conservative
    effect, the points its force takes: ``u = w =`` the midpoint with ``mid``, else ``a, b``;
    where ``point`` (the work function), with ``pt`` (MODE_POINT): ``b = a`` (the force at a),
    or, for a force that depends on the velocity (``moving``), the displacement d centred on a,
    ``(a - d / 2, a + d / 2)``, whose velocity is ``d / h``."""
    code = f"b0 = {e0}\nb1 = {e1}\nb2 = {e2}"
    if point and moving:
        code += (
            "\nif pt:\n    a0 = a0 - 0.5 * d0\n    a1 = a1 - 0.5 * d1\n    a2 = a2 - 0.5 * d2\n"
            "    b0 = a0 + d0\n    b1 = a1 + d1\n    b2 = a2 + d2"
        )
    elif point:
        code += "\nif pt:\n    b0 = a0\n    b1 = a1\n    b2 = a2"
    if conservative:
        code += (
            "\nif mid:\n    u0 = 0.5 * (a0 + b0)\n    u1 = 0.5 * (a1 + b1)\n    u2 = 0.5 * (a2 + b2)\n"
            "    w0 = u0\n    w1 = u1\n    w2 = u2\nelse:\n    u0 = a0\n    u1 = a1\n    u2 = a2\n"
            "    w0 = b0\n    w1 = b1\n    w2 = b2"
        )
    return _indent(code, 4)


def _force_ends(e0: str, e1: str, e2: str, conservative: bool) -> str:
    """``forces``' step end ``b`` and the points ``u, w`` the force of an effect whose force is a
    function of position and time takes: with ``pt`` (MODE_POINT: a time finite element's stage
    at the segment's midpoint, beside forces that read their velocity from the segment) the
    midpoint twice, as with ``mid`` for a conservative effect; else ``a, b``."""
    cond = "mid or pt" if conservative else "pt"
    code = (
        f"b0 = {e0}\nb1 = {e1}\nb2 = {e2}\n"
        f"if {cond}:\n    u0 = 0.5 * (a0 + b0)\n    u1 = 0.5 * (a1 + b1)\n    u2 = 0.5 * (a2 + b2)\n"
        "    w0 = u0\n    w1 = u1\n    w2 = u2\nelse:\n    u0 = a0\n    u1 = a1\n    u2 = a2\n"
        "    w0 = b0\n    w1 = b1\n    w2 = b2"
    )
    return _indent(code, 4)


def _indent(code: str, spaces: int) -> str:
    pad = " " * spaces
    return "\n".join(pad + line if line.strip() else "" for line in code.strip("\n").splitlines())


#: the pieces an effect's loop module calls (:func:`_loops_source`); a set's module the others
_LOOP_PIECES = ("force", "time_work")
_PIECES = ("force", "potential", "prepare", "time_work", "facet", "pairs", "pair_potential", "pair_block", "rate",
           "pair_rate", "mass")  # fmt: skip


def _import_line(index: int | str, pieces, loops: bool) -> tuple[str, list[str]]:
    """The import of one effect's pieces that a module calls (as ``<piece>_<index>``): with
    ``loops``, those of its loop module (``force_``), else the set module's (``prepare_3``); and
    the names of every piece the effect has."""
    names = [(attr, getattr(pieces, attr)) for attr in _PIECES if getattr(pieces, attr)]
    aliases = ", ".join(f"{name} as {attr}_{index}" for attr, name in names if (attr in _LOOP_PIECES) == loops)
    if pieces.module.endswith(".py"):  # a user's file: imported as a module of its own name
        module = _user_module_name(pieces.module)
    else:
        module = pieces.module
    return (f"from {module} import {aliases}" if aliases else ""), [attr for attr, _ in names]


def _user_module_name(path: str) -> str:
    """The module name a user's effect file is imported under (stable for its absolute path)."""
    digest = hashlib.sha1(os.path.abspath(path).encode()).hexdigest()[:12]
    return f"emorbit_user_effect_{digest}"


def load_user_module(path: str):
    """Import a user's effect file (once per process) under :func:`_user_module_name`."""
    name = _user_module_name(path)
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, os.path.abspath(path))
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


_LOOPS_HEADER = '''"""The block loops of the effect {name}: its force, with its Jacobian and without, and its work.

Generated by emorbit.effects.program from the effect's pieces; do not edit.
Digest of the kernel sources and user modules: {digest}
"""

import numba

from emorbit.kernels.effects.blocks import FORCES_LOOP, LD, ROW_K, ROW_OUT, WORK_LOOP, block33
{imports}

_OPTIONS = {options}
'''


#: a loop's arrays from their pointers and lengths, its flags from int64
#: (:data:`~emorbit.kernels.effects.blocks.FORCES_LOOP`)
_UNPACK = _indent(
    "B = numba.carray(Bp, nB)\np = numba.carray(pp, n_p)\nt = numba.carray(tp, n_t)\ns = numba.carray(sp, n_s)\n"
    "mid = mid_ != 0\npt = pt_ != 0",
    4,
)


def _loop_names(cls) -> list[str]:
    """The functions of an effect's loop module (:func:`loop_module`; none: it has none)."""
    names = ["forces_jac", "forces_plain"] if cls.PIECES.force else []
    return names + (["work"] if cls.does_work() else [])


def _loops_source(cls) -> str:
    """The source of an effect's loop module, with ``{digest}`` where its digest goes.

    ``forces_jac(B, nb, h, p, t, s, mid, pt)`` and ``forces_plain`` (the same without the
    Jacobian) add the effect's force at each point of a block (its coefficients in the row
    ``ROW_K``) into the rows of F and its Jacobian block into those of W; ``work(B, nb, mb, h,
    p, t, s, mid, pt)`` writes its work at each point (masses ``mb``) into the row ``ROW_OUT``
    (the rows of :mod:`emorbit.kernels.effects.blocks`, all at constant offsets). Each is a C callback
    (:data:`~emorbit.kernels.effects.blocks.FORCES_LOOP`, ``WORK_LOOP``: arrays as pointers
    and lengths, flags as int64) compiled once per install and effect, and called by the name
    ``<module>_<function>``: a new set compiles only its own short functions."""
    line, names = _import_line("", cls.PIECES, loops=True)
    has = set(names)
    code = []
    if "force" in has:
        cons = "energy" in cls.CONSERVES
        at = "u0, u1, u2, w0, w1, w2" if cons or cls.EXPLICIT else "a0, a1, a2, b0, b1, b2"
        if cls.EXPLICIT:
            ends = _force_ends("B[3 * LD + j]", "B[4 * LD + j]", "B[5 * LD + j]", cons)
        else:
            ends = _ends("B[3 * LD + j]", "B[4 * LD + j]", "B[5 * LD + j]", cons)
        loop = _EFFECT_LOOP.format(ends=ends, at=at)
        for name, literal in (("forces_jac", "True"), ("forces_plain", "False")):
            # jac a literal, so that Numba prunes the branch not taken (a loop with the
            # Jacobians' code in it, even untaken, runs about ten times slower)
            body = loop.replace("if jac:", f"if {literal}:").replace(", J, jac)", f", J, {literal})")
            code.append(
                f"@numba.cfunc(FORCES_LOOP, **_OPTIONS)\n"
                f"def {name}(Bp, nB, nb, h, pp, n_p, tp, n_t, sp, n_s, mid_, pt_):\n{_UNPACK}\n{_indent(body, 4)}\n"
            )
    if cls.does_work():
        row = "B[ROW_OUT * LD + j]"
        if "time_work" in has:  # at a point (MODE_POINT), its force's work instead
            body = (
                "if pt:\n    gx, gy, gz = force_(a0, a1, a2, a0, a1, a2, h, kc, p, t, s, J, False)\n"
                "    tw = mb[j] * (gx * d0 + gy * d1 + gz * d2)\n"
                "else:\n    tw = mb[j] * time_work_(a0, a1, a2, b0, b1, b2, kc, p, t, s)\n"
                f"{row} = tw if kc != 0.0 else 0.0"
            )
            cons = False
        elif "force" in has:
            cons = "energy" in cls.CONSERVES
            at = "u0, u1, u2, w0, w1, w2" if cons else "a0, a1, a2, b0, b1, b2"
            body = (
                f"gx, gy, gz = force_({at}, h, kc, p, t, s, J, False)\n"
                f"{row} = mb[j] * (gx * d0 + gy * d1 + gz * d2) if kc != 0.0 else 0.0"
            )
        else:
            body = None
        if body is None:
            loop = f"for j in range(nb):\n    {row} = 0.0"
        else:
            ends = _ends("a0 + d0", "a1 + d1", "a2 + d2", cons, point=True, moving=not cls.EXPLICIT)
            loop = (
                "for j in range(nb):\n    kc = B[ROW_K * LD + j]\n    J = block33()\n"
                "    a0 = B[j]\n    a1 = B[LD + j]\n    a2 = B[2 * LD + j]\n"
                f"    d0 = B[3 * LD + j]\n    d1 = B[4 * LD + j]\n    d2 = B[5 * LD + j]\n{ends}\n{_indent(body, 4)}"
            )
        code.append(
            "@numba.cfunc(WORK_LOOP, **_OPTIONS)\n"
            "def work(Bp, nB, nb, mbp, n_mb, h, pp, n_p, tp, n_t, sp, n_s, mid_, pt_):\n"
            f"{_UNPACK}\n    mb = numba.carray(mbp, n_mb)\n{_indent(loop, 4)}\n"
        )
    options = {"cache": cache_enabled(), "error_model": "numpy", "fastmath": False}
    header = _LOOPS_HEADER.format(name=cls.NAME, digest="{digest}", imports=line, options=repr(options))
    return header + "\n\n" + "\n\n".join(code)


def loop_module(cls) -> tuple[str, str]:
    """An effect's loop module (:func:`_loops_source`): its name, which states its digest, and
    its source."""
    key = (cls.NAME, cls.PIECES, cls.EXPLICIT, cls.CONSERVES, cls.does_work())
    if key not in _LOOPS:
        template = _loops_source(cls)
        digest = _digest(template, (cls,))
        _LOOPS[key] = f"emorbit_effect_loops_{cls.NAME}_{digest}", template.replace("{digest}", digest, 1)
    return _LOOPS[key]


_LOOPS: dict = {}


def _symbol(cls, function: str) -> str:
    """The name a set calls an effect's loop by: its loop module's (which states its digest)
    and the function's."""
    return f"{loop_module(cls)[0]}_{function}"


def set_source(effects) -> tuple[str, tuple[int, ...], bool]:
    """The source of the module compiled for an ordered set of effect classes.

    Parameters
    ----------
    effects : sequence of type
        :class:`~emorbit.effects.base.Effect` subclasses, in the order their forces are summed.

    Returns
    -------
    source : str
        The module.
    working : tuple of int
        The indices of the effects whose work the step sums, in slot order.
    ledger : bool
        Whether the work has a ledger row (an effect of the set changes mass).
    """
    imports, has, working = [], [], []
    for e, cls in enumerate(effects):
        line, names = _import_line(e, cls.PIECES, loops=False)
        imports.append(line)
        has.append(set(names))
        if cls.does_work():
            working.append(e)
    views = _VIEWS_AT
    slot_of = {e: k for k, e in enumerate(working)}

    # forces: pairs first, then every point's own effects in order
    pairs = "\n".join(
        f"pairs_{e}(x0, x1, m, body, coef[{e}], h, p{e}, s{e}, F, W, R, jac, first, weighted)"
        for e in range(len(effects))
        if "pairs" in has[e]
    )
    # every per-point effect's own loop over a block of points (its loop module's, compiled
    # once per install: it vectorises where its piece does)
    own_jac, own_plain = [], []
    for e in range(len(effects)):
        if "force" in has[e]:
            args = f"(B, nb, h, p{e}, t{e}, s{e}, mid, pt))"
            row = f"copy_row(B, {ROW_COEF + e}, {ROW_K}, nb)\n"
            own_jac.append(f"{row}call_c('{_symbol(effects[e], 'forces_jac')}', {args}")
            own_plain.append(f"{row}call_c('{_symbol(effects[e], 'forces_plain')}', {args}")
    forces = f"""
@numba.cfunc(FORCES, **_OPTIONS)
def forces(x0, x1, m, body, coef, h, mode, P, I, T, S, F, W, R, jac, first):
    n = m.shape[0]
    weighted = (mode & MODE_WEIGHTED) != 0
    mode = mode & (MODE_WEIGHTED - 1)
{_indent(views, 4)}
    for c in range(3):
        F[c, :] = 0.0
    if jac:
        for c in range(9):
            W[c, :] = 0.0
{_indent(pairs, 4) if pairs else ""}
    mid = mode == MODE_MIDPOINT
    pt = mode == MODE_POINT
    B = np.empty(({ROW_COEF + len(effects)}) * LD)
    bad = 0
    # (a set of pair effects alone has nothing to add, unless weighted: F + m 0)
    for lo in range(0, n if {bool(own_jac)} or weighted else 0, BLOCK):
        nb = min(BLOCK, n - lo)
        call_c('emorbit_block_load_forces', (B, x0, x1, F, W, coef, lo, nb, jac, weighted))
        if jac:  # two copies of the loops, so that those without Jacobians have none of their code
{_indent(chr(10).join(own_jac), 12) if own_jac else "            pass"}
        else:
{_indent(chr(10).join(own_plain), 12) if own_plain else "            pass"}
        call_c('emorbit_block_store_forces', (B, F, W, m, lo, nb, jac, weighted))
    f0, f1, f2 = F[0], F[1], F[2]
    for i in range(n):
        bad += 0 if abs(f0[i]) + abs(f1[i]) + abs(f2[i]) < math.inf else 1
    return STATUS_SINGULAR if bad else STATUS_OK
"""
    prep = "\n".join(f"prepare_{e}(ta, tm, tb, p{e}, t{e}, s{e})" for e in range(len(effects)) if "prepare" in has[e])
    prepare = f"""
@numba.cfunc(PREPARE, **_OPTIONS)
def prepare(ta, tm, tb, P, I, T, S):
{_indent(views, 4)}
{_indent(prep, 4) if prep else "    pass"}
"""
    work_loops = [
        f"copy_row(B, {ROW_COEF + e}, {ROW_K}, nb)\n"
        f"call_c('{_symbol(effects[e], 'work')}', (B, nb, mb, h, p{e}, t{e}, s{e}, mid, pt))\n"
        f"copy_row(B, {ROW_OUT}, {ROW_COEF + len(effects) + slot_of[e]}, nb)"
        for e in working
    ]
    massive = [e for e in range(len(effects)) if "mass" in has[e]]
    ledger = ""
    if massive:  # the ledger row: the point's work at its true mean mass
        last = len(working)
        ledger = (
            "mu = 1.0\n"
            + "".join(
                f"if coef[{e}, i] != 0.0:\n    mu += mass_{e}(coef[{e}, i], False, p{e}, s{e})\n" for e in massive
            )
            + f"total = 0.0\nfor k in range({last}):\n    total += out[k, i]\nout[{last}, i] = mu * total"
        )
    work = f"""
@numba.cfunc(WORK, **_OPTIONS)
def work(x0, dx, m, body, coef, h, mode, P, I, T, S, out):
    n = m.shape[0]
{_indent(views, 4)}
    mid = mode == MODE_MIDPOINT
    pt = mode == MODE_POINT
    B = np.empty(({ROW_COEF + len(effects) + len(working)}) * LD)
    for lo in range(0, n, BLOCK):
        nb = min(BLOCK, n - lo)
        call_c('emorbit_block_load_work', (B, x0, dx, coef, lo, nb))
        mb = m[lo : lo + nb]
{_indent(chr(10).join(work_loops), 8) if work_loops else "        pass"}
        call_c('emorbit_block_store_work', (B, out, {len(effects)}, lo, nb, {len(working)}))
        for j in range(nb if {bool(ledger)} else 0):
            i = lo + j
{_indent(ledger, 12) if ledger else ""}
"""
    pot_lines = []
    for e in range(len(effects)):
        if "pair_potential" in has[e]:
            pot_lines.append(f"pair_potential_{e}(x, m, body, coef[{e}], p{e}, out[{e}])")
    own_pot = []
    for e in range(len(effects)):
        if "potential" in has[e]:
            own_pot.append(
                f"k = coef[{e}, i]\n"
                f"if k != 0.0:\n"
                f"    out[{e}, i] = m[i] * potential_{e}(x[0, i], x[1, i], x[2, i], k, p{e}, t{e}, s{e})"
            )
    potential = f"""
@numba.cfunc(POTENTIAL, **_OPTIONS)
def potential(x, m, body, coef, P, I, T, S, out):
    n = m.shape[0]
{_indent(views, 4)}
    for e in range(out.shape[0]):
        for i in range(n):
            out[e, i] = 0.0
{_indent(chr(10).join(pot_lines), 4) if pot_lines else ""}
    for i in range(n):
{_indent(chr(10).join(own_pot), 8) if own_pot else "        pass"}
"""
    facet_lines = []
    for e in range(len(effects)):
        if "facet" not in has[e]:
            continue
        line = (
            f"gx, gy, gz = facet_{e}(a0, a1, a2, b0, b1, b2, n0, n1, n2, area[f], kf[0, f], kf[1, f], kf[2, f], "
            f"kf[3, f], h, p{e}, t{e}, s{e})\nfx += gx\nfy += gy\nfz += gz"
        )
        if e in slot_of:
            line += f"\nif want_work:\n    out[{slot_of[e]}, f] = gx * (b0 - a0) + gy * (b1 - a1) + gz * (b2 - a2)"
        facet_lines.append(line)
    if massive:  # the ledger row: the facet's mass mark
        facet_lines.append(
            "if want_work:\n"
            + "".join(f"    out[{len(working)}, f] += mass_{e}(kf[3, f], True, p{e}, s{e})\n" for e in massive)
        )
    facets = f"""
@numba.cfunc(FACETS, **_OPTIONS)
def facets(a, b, nrm, area, kf, h, P, I, T, S, F, out, want_work):
    nf = area.shape[0]
{_indent(views, 4)}
    if want_work:
        for k in range(out.shape[0]):
            for f in range(nf):
                out[k, f] = 0.0
    bad = False
    for f in range(nf):
        a0 = a[0, f]
        a1 = a[1, f]
        a2 = a[2, f]
        b0 = b[0, f]
        b1 = b[1, f]
        b2 = b[2, f]
        n0 = nrm[0, f]
        n1 = nrm[1, f]
        n2 = nrm[2, f]
        fx = 0.0
        fy = 0.0
        fz = 0.0
{_indent(chr(10).join(facet_lines), 8) if facet_lines else "        pass"}
        F[0, f] = fx
        F[1, f] = fy
        F[2, f] = fz
        if not (abs(fx) + abs(fy) + abs(fz) < math.inf):
            bad = True
    return STATUS_SINGULAR if bad else STATUS_OK
"""
    blocks = []
    for e in range(len(effects)):
        if "pair_block" not in has[e]:
            continue
        blocks.append(f"""
for a in range(n):
    if coef[{e}, a] == 0.0 or on[a] == 0.0:
        continue
    for b in range(a + 1, n):
        if coef[{e}, b] == 0.0 or on[b] == 0.0 or body[b] == body[a]:
            continue
        pair_block_{e}(
            x0[0, a] - x0[0, b], x0[1, a] - x0[1, b], x0[2, a] - x0[2, b], x1[0, a] - x1[0, b],
            x1[1, a] - x1[1, b], x1[2, a] - x1[2, b], m[a], m[b], p{e}, J,
        )
        A = body[a]
        B = body[b]
        for i in range(4):
            ca = sc[i, a]
            if ca == 0.0:
                continue
            for j in range(4):
                cab = ca * sc[j, b]
                if cab == 0.0:
                    continue
                for d in range(3):
                    for f in range(3):
                        acc[A, B, i, j, d, f] += cab * J[d, f]""")
    cross = f"""
@numba.cfunc(CROSS, **_OPTIONS)
def cross(x0, x1, m, body, coef, on, sc, acc, P, I, T, S):
    n = m.shape[0]
{_indent(views, 4)}
    acc[...] = 0.0
    J = np.empty((3, 3))
{_indent(chr(10).join(blocks), 4) if blocks else "    pass"}
"""
    rates = []
    for e in range(len(effects)):
        if "rate" in has[e]:
            rates.append(f"""
for i in range(n):
    if coef[{e}, i] != 0.0:
        w, dw = rate_{e}(x[0, i], x[1, i], x[2, i], v[0, i], v[1, i], v[2, i], coef[{e}, i], p{e})
        if w > best:
            best = w
            slope = dw""")
        if "pair_rate" in has[e]:
            rates.append(f"""
for a in range(n):
    if coef[{e}, a] == 0.0:
        continue
    for b in range(a + 1, n):
        if coef[{e}, b] == 0.0 or body[b] == body[a]:
            continue
        w, dw = pair_rate_{e}(
            x[0, a] - x[0, b], x[1, a] - x[1, b], x[2, a] - x[2, b], v[0, a] - v[0, b], v[1, a] - v[1, b],
            v[2, a] - v[2, b], m[a], m[b], p{e},
        )
        if w > best:
            best = w
            slope = dw""")
    rate = f"""
@numba.cfunc(RATE, **_OPTIONS)
def rate(x, v, m, body, coef, P, I, T, S):
    n = m.shape[0]
{_indent(views, 4)}
    best = 0.0
    slope = 0.0
{_indent(chr(10).join(rates), 4) if rates else ""}
    return best, slope
"""
    options = {"cache": cache_enabled(), "error_model": "numpy", "fastmath": False}
    header = _HEADER.format(
        names=", ".join(cls.NAME for cls in effects) or "none",
        digest="{digest}",
        imports="\n".join(line for line in imports if line),
        options=repr(options),
    )
    functions = "".join(_with_views(f, len(effects)) for f in (forces, prepare, work, potential, facets, cross, rate))
    return header + functions, tuple(working), bool(massive)


def _digest(source: str, effects) -> str:
    """A digest of the module's source, every kernel source it may inline and any user files."""
    h = hashlib.sha1(source.encode())
    h.update(cached_sources_digest().encode())
    for cls in effects:
        if cls.PIECES.module.endswith(".py"):
            with open(cls.PIECES.module, "rb") as f:
                h.update(f.read())
    return h.hexdigest()[:16]


_LOADED: dict = {}


def compile_set(effects, announce=None) -> Program:
    """The compiled functions of an effect set (loaded from the disk cache when compiled before).

    Parameters
    ----------
    effects : sequence of type
        Effect classes, in the order their forces are summed.
    announce : callable, optional
        Called with a message before a compile that the cache cannot spare (the module is
        new to the cache): the command line prints it on stderr.

    Returns
    -------
    Program
    """
    effects = tuple(effects)
    kinds = tuple(cls.NAME for cls in effects)
    key = tuple((cls.NAME, cls.PIECES) for cls in effects)
    if key in _LOADED:
        return _LOADED[key]
    for cls in effects:  # a user's file is importable before the module that imports it
        if cls.PIECES.module.endswith(".py"):
            load_user_module(cls.PIECES.module)
    template, working, ledger = set_source(effects)
    digest = _digest(template, effects)
    source = template.replace("{digest}", digest, 1)
    stem = "_".join(kinds)[:80] or "none"
    # each effect's loops (imported first), then the set's functions
    modules = [loop_module(cls) for cls in dict.fromkeys(effects) if _loop_names(cls)]
    modules.append((f"emorbit_effects_{stem}_{digest}", source))
    try:
        folder = os.path.join(cache_dir(), "effects")
        os.makedirs(folder, mode=0o700, exist_ok=True)
        fresh = [_place(folder, name, text) for name, text in modules]
    except OSError:  # no writable cache: a private folder for this process
        folder = tempfile.mkdtemp(prefix="emorbit-effects-")
        fresh = [_place(folder, name, text) for name, text in modules]
    fresh = any(fresh)
    if fresh and announce is not None:
        what = f"the effect set {' + '.join(kinds)}" if kinds else "free motion"
        announce(f"compiling the kernels of {what} (first run only)")
    for name, _ in modules[:-1]:
        _import(folder, name)
    # the names the set's functions call bound to their code before those compile or load
    block_calls.bind()
    block_calls.bind({_symbol(cls, f): getattr(_import(folder, loop_module(cls)[0]), f) for cls in effects
                      for f in _loop_names(cls)})  # fmt: skip
    module = _import(folder, modules[-1][0])
    functions = (module.forces, module.prepare, module.work, module.potential, module.facets, module.cross, module.rate)
    program = Program(*functions, kinds, working, ledger, fresh)
    _LOADED[key] = program
    return program


def _import(folder: str, name: str):
    """Module ``name`` of ``folder`` (imported once per process)."""
    module = sys.modules.get(name)
    if module is None:
        spec = importlib.util.spec_from_file_location(name, os.path.join(folder, name + ".py"))
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return module


def _place(folder: str, name: str, source: str) -> bool:
    """Write module ``name`` into ``folder`` unless it is there with ``source``; whether its
    compiled code is still to be made (new to the cache, or no index of Numba's beside it)."""
    path = os.path.join(folder, name + ".py")
    if os.path.exists(path) and _reads_back(path, source):
        return not _has_index(folder, name)
    fd, temp = tempfile.mkstemp(dir=folder, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        f.write(source)
    os.replace(temp, path)
    return True


def _reads_back(path: str, source: str) -> bool:
    """Whether the file at ``path`` holds exactly ``source`` (else it is written again)."""
    try:
        with open(path) as f:
            return f.read() == source
    except OSError:
        return False


def _has_index(folder: str, name: str) -> bool:
    """Whether Numba's cache holds compiled code of the module (its index files)."""
    cache = os.path.join(folder, "__pycache__")
    try:
        return any(entry.startswith(name + ".") and entry.endswith(".nbi") for entry in os.listdir(cache))
    except OSError:
        return False
