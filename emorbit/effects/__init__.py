"""Effects: the forces a scene names, one module per effect, each registered here by name.

A scene's bodies move in the central field of ``[field]`` (the effect ``central``) and in
whatever ``[[effect]]`` tables add (``zonal``, ``gravity_field``, ``mutual``, ``drag``,
``srp``, ``third_body``, ``thrust``, or an effect of the user's own). Each effect is one subclass of
:class:`~emorbit.effects.base.Effect` that declares everything about itself (its keys, the
body keys it owns, the bodies it acts on and how, what it conserves, its kernel pieces); the
body kinds' step kernels take any set of them compiled by :mod:`emorbit.effects.program`,
and :class:`~emorbit.effects.effectset.EffectSet` holds a simulation's.

To add an effect to emorbit: write its pieces in ``emorbit/kernels/effects/<name>.py`` (with
tests that the work equals the potential drop and the Jacobian matches finite differences),
its class in ``emorbit/effects/<name>.py``, and add the class to :data:`SHIPPED`. A user adds
one without editing emorbit: :func:`register` a subclass whose pieces live in the user's own
file, or name the file in a scene (``[[effect]] kind = "<name>", file = "<path>.py"``, see
:func:`register_file`).
"""

from __future__ import annotations

import os

from ..errors import InputError
from .base import BuildContext, Effect, check_left_out
from .central import Central
from .drag import Drag
from .gravity_field import GravityField
from .mutual import Mutual
from .srp import RadiationPressure
from .third_body import ThirdBody
from .thrust import Thrust
from .zonal import Zonal

__all__ = ["EFFECTS", "SHIPPED", "Effect", "build", "effect_kinds", "register", "register_file", "unregister"]

#: the shipped effects, in the order a step sums their forces (third bodies and burns last: a
#: scene may name several, whose work the step sums in consecutive slots)
SHIPPED = (Central, Zonal, GravityField, Mutual, Drag, RadiationPressure, ThirdBody, Thrust)
#: every registered effect by its ``kind``: the shipped ones, then the user's in the order
#: they were registered (the order a step sums their forces)
EFFECTS: dict[str, type[Effect]] = {cls.NAME: cls for cls in SHIPPED}


def effect_kinds() -> tuple[str, ...]:
    """The kinds an ``[[effect]]`` table may name (``central`` is the ``[field]`` table)."""
    return tuple(k for k in EFFECTS if k != "central")


def register(cls: type[Effect]) -> type[Effect]:
    """Register an effect class, so that scenes and :meth:`emorbit.Simulation.add_effect` may
    name its kind. Usable as a decorator.

    Parameters
    ----------
    cls : type
        A subclass of :class:`~emorbit.effects.base.Effect` with ``NAME``, ``PIECES`` and
        :meth:`~emorbit.effects.base.Effect.from_table`.

    Returns
    -------
    type
        ``cls``.

    Raises
    ------
    InputError
        Not an Effect subclass, no name or pieces, a conservative effect without a potential,
        a ``JACOBIAN_LEFT_OUT`` that is not a number >= 0, or a name that a different class
        already has.
    """
    if not (isinstance(cls, type) and issubclass(cls, Effect)):
        raise InputError("effect", f"an Effect subclass expected, got {cls!r}")
    name = getattr(cls, "NAME", "")
    if not isinstance(name, str) or not name.isidentifier():
        raise InputError("effect.NAME", f"an identifier expected, got {name!r}")
    pieces = cls.PIECES
    if pieces is None or not (pieces.force or pieces.pairs or pieces.facet):
        raise InputError(f"effect[{name!r}].PIECES", "give at least its force (or its facet or pair forces)")
    if "energy" in cls.CONSERVES and not cls.has_potential():
        raise InputError(f"effect[{name!r}].PIECES", "an effect that keeps the energy gives its potential")
    check_left_out(cls.JACOBIAN_LEFT_OUT, f"effect[{name!r}].JACOBIAN_LEFT_OUT")
    known = EFFECTS.get(name)
    if known is not None and known is not cls and _origin(known) != _origin(cls):
        where = known.PIECES.module if known.PIECES is not None else known.__module__
        raise InputError(
            f"effect[{name!r}]",
            f"the kind {name!r} is taken by {known.__name__} of {where}: give this effect another NAME, "
            f"or unregister that one first (emorbit.effects.unregister({name!r}))",
        )
    EFFECTS[name] = cls
    return cls


def _origin(cls) -> tuple:
    """Where a class was defined (a user file loaded twice defines equal classes)."""
    return (cls.__module__, cls.__qualname__, cls.PIECES)


def unregister(name: str) -> None:
    """Remove a user's effect from the registry (a shipped effect stays)."""
    if name in EFFECTS and EFFECTS[name] not in SHIPPED:
        del EFFECTS[name]


def register_file(path, key: str = "file") -> list[type[Effect]]:
    """Import a user's effect file and register every Effect subclass it defines.

    The file is ordinary Python: it imports :class:`~emorbit.effects.base.Effect` and
    :class:`~emorbit.effects.base.Pieces`, defines its pieces with
    :func:`emorbit.kernels.jit.kernel` (or ``numba.njit``), and a subclass whose
    ``PIECES.module`` is ``__file__``. Importing runs the file's code, as any Python module.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    key : str
        Its name in errors.

    Returns
    -------
    list of type
        The registered classes.

    Raises
    ------
    InputError
        No such file, a file that fails to import (its error named), or one that defines no
        effect.
    """
    from .program import load_user_module

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(key, f"no effect file {path!r}")
    try:
        module = load_user_module(path)
    except Exception as exc:  # the user's code: any error it raises is reported, not raised
        raise InputError(key, f"{path!r} failed to import: {type(exc).__name__}: {exc}") from None
    found = [
        obj
        for obj in vars(module).values()
        if isinstance(obj, type) and issubclass(obj, Effect) and obj.__module__ == module.__name__
    ]
    if not found:
        raise InputError(key, f"{path!r} defines no subclass of emorbit.effects.base.Effect")
    return [register(cls) for cls in found]


def build(table: dict, field, key: str, bodies=None, strict: bool = False, folder: str = "") -> Effect:
    """A checked effect from an ``[[effect]]`` table or :meth:`~emorbit.Simulation.add_effect`.

    Parameters
    ----------
    table : dict
        ``kind`` and the effect's keys (values with units, as scenes give them, or
        Quantities and SI numbers from Python); ``file`` names a user's effect file.
    field : CentralField or None
        The scene's central field.
    key : str
        The table's name in errors, e.g. ``"effect[0]"``.
    bodies : list of str, optional
        The scene's body names, for effects that name bodies (None: checked when the
        simulation runs).
    strict : bool
        Require units on every dimensional value (scenes do).
    folder : str
        The folder a relative ``file``, and a relative path in the effect's
        :attr:`~emorbit.effects.base.Effect.PATH_KEYS` where a file of that name is there, is
        found in (the scene's).

    Returns
    -------
    Effect
        The effect, its parameters in SI.

    Raises
    ------
    InputError
        An unknown kind, an unknown key, an effect of a central field in free space, or a value
        that the effect refuses, naming the key.
    """
    if not isinstance(table, dict):
        raise InputError(key, f"an effect is a table with a kind, got {table!r}")
    table = dict(table)
    if "file" in table:
        file = table["file"]
        if not isinstance(file, str) or not file.strip():
            raise InputError(f"{key}.file", f"the path of a Python file expected, got {file!r}")
        register_file(os.path.join(folder, file) if folder and not os.path.isabs(file) else file, f"{key}.file")
    kind = table.get("kind")
    if kind not in effect_kinds():
        raise InputError(f"{key}.kind", f"unknown effect {kind!r}; known: {', '.join(effect_kinds())}")
    cls = EFFECTS[kind]
    allowed = {"kind", "file"} | {k.name for k in cls.KEYS}
    for name in table:
        if name not in allowed:
            raise InputError(
                f"{key}.{name}", f"unknown key of a {kind!r} effect; its keys: {', '.join(sorted(allowed))}"
            )
    if cls.NEEDS_FIELD and field is None:
        raise InputError(key, f"{kind} needs a central body: the scene needs a [field]")
    for name in cls.PATH_KEYS:
        value = table.get(name)
        if folder and isinstance(value, str) and not os.path.isabs(value):
            if os.path.isfile(os.path.join(folder, value)):
                table[name] = os.path.join(folder, value)
    effect = cls.from_table(table, BuildContext(field, key, bodies, strict))
    effect.key = key
    return effect
