"""A key of a scene table and what the documentation says about it.

The one declaration of a key: the scene parser (:mod:`emorbit.scene`) checks tables against
it, each effect (:mod:`emorbit.effects`) declares its own keys with it, and the key tables of
docs/scenes.md and docs/effects.md are generated from it.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Key"]


@dataclass(frozen=True)
class Key:
    """One key of a scene table and what the documentation says about it.

    Attributes
    ----------
    name : str
        The key as written in the TOML table.
    required : bool
        Whether every table of its kind must have it.
    unit : str
        The kind of quantity and its SI unit (a string with any unit of that kind is
        accepted), or the TOML type of a value without a unit.
    default : str
        The value taken when the key is absent ("" for a key without a default).
    allowed : str
        The values it may take.
    meaning : str
        What it does, in one line.
    applies : tuple of str
        For shape and mesh parameters: the shapes or meshes that take it (empty: every body
        of the table's kind).
    """

    name: str
    required: bool
    unit: str
    default: str
    allowed: str
    meaning: str
    applies: tuple[str, ...] = ()
