"""Effects: the forces a scene names, one module per effect, each registered here by name.

A scene's bodies move in the central field of ``[field]`` (the effect ``central``) and in
whatever ``[[effect]]`` tables add (``zonal``, ``mutual``, ``drag``, ``srp``, ``third_body``). Each
effect module declares:

``NAME``, ``SUMMARY``
    its ``kind`` in scenes and one line on what it is;
``KEYS``
    its scene keys (:class:`~emorbit.keys.Key`: units, defaults, allowed values), checked
    by :func:`build` and listed in docs/effects.md, which is generated from these
    declarations (``scripts/docs_effects.py``);
``POTENTIAL``, ``DISCRETE_FORCE``, ``JACOBIAN``, ``CONSERVES``, ``BODY_KINDS``
    its potential energy, its force over a step (the g_em analogue: its work equals the
    drop in its potential exactly; a non-conservative force such as drag has no potential
    (``HAS_POTENTIAL = False``), keeps nothing and declares the ``work`` code that sums its
    discrete work; a potential that changes in time sums the work of that change), the
    Jacobian of that force for Newton, what an em step with it conserves, and the body kinds
    it acts on;
``build(table, field, key)``
    a checked :class:`~emorbit.effects.base.EffectTerm` from the scene table (or the Python
    API's keywords, :meth:`emorbit.Simulation.add_effect`);
``KERNEL``
    the kernel functions and the code that :mod:`emorbit.effects.compose` puts into the
    step compiled for a scene's set of effects, so that a scene pays only for the effects it
    names; an effect that depends on time has ``substep`` code, which reads the sub-step's
    start, middle and end times ``ta``, ``tm``, ``tb``, and its term samples its path in
    :meth:`~emorbit.effects.base.EffectTerm.prepare` before the steps.

To add an effect: write its force, potential and Jacobian as kernels in
``emorbit/kernels/effects/`` (with tests that the work equals the potential drop and the
Jacobian matches finite differences), write its module here with the names above, and add
it to :data:`EFFECTS`.
"""

from __future__ import annotations

from ..errors import InputError
from . import central, drag, mutual, srp, third_body, zonal
from .base import EffectTerm

__all__ = ["EFFECTS", "EffectTerm", "build", "effect_kinds", "has_potential"]

#: every effect by its ``kind``, in the order a step adds their forces (third bodies last: a
#: scene may name several, whose work the step sums in consecutive slots)
EFFECTS = {m.NAME: m for m in (central, zonal, mutual, drag, srp, third_body)}


def has_potential(module) -> bool:
    """Whether an effect has a potential energy, recorded as ``invariants/potential_<label>``
    (drag and radiation pressure have none: only their work is recorded)."""
    return getattr(module, "HAS_POTENTIAL", True)


def effect_kinds() -> tuple[str, ...]:
    """The kinds an ``[[effect]]`` table may name (``central`` is the ``[field]`` table)."""
    return tuple(k for k in EFFECTS if k != "central")


def build(table: dict, field, key: str, bodies=None, strict: bool = False) -> EffectTerm:
    """A checked effect from an ``[[effect]]`` table or :meth:`~emorbit.Simulation.add_effect`.

    Parameters
    ----------
    table : dict
        ``kind`` and the effect's keys (values with units, as scenes give them, or
        Quantities and SI numbers from Python).
    field : CentralField or None
        The scene's central field.
    key : str
        The table's name in errors, e.g. ``"effect[0]"``.
    bodies : list of str, optional
        The scene's body names, for effects that name bodies (None: checked when the
        simulation runs).
    strict : bool
        Require units on every dimensional value (scenes do).

    Returns
    -------
    EffectTerm
        The effect, its parameters in SI.

    Raises
    ------
    InputError
        An unknown kind, an unknown key, or a value that the effect refuses, naming the key.
    """
    if not isinstance(table, dict):
        raise InputError(key, f"an effect is a table with a kind, got {table!r}")
    kind = table.get("kind")
    if kind not in effect_kinds():
        raise InputError(f"{key}.kind", f"unknown effect {kind!r}; known: {', '.join(effect_kinds())}")
    module = EFFECTS[kind]
    allowed = {"kind"} | {k.name for k in module.KEYS}
    for name in table:
        if name not in allowed:
            raise InputError(
                f"{key}.{name}", f"unknown key of a {kind!r} effect; its keys: {', '.join(sorted(allowed))}"
            )
    term = module.build(table, field, key, bodies, strict)
    term.key = key
    return term
