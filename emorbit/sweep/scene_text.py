"""TOML text of a scene's tables, so that a sweep run's file stores the scene it ran.

A run file's ``scene`` attribute is what ``emorbit resume`` rebuilds the run from, so a
sweep run writes its own scene (the base scene with the run's values set), not the base
scene's text. :func:`scene_toml` writes tables as ``[table]``, arrays of tables as
``[[table]]`` and deeper tables inline; ``tomllib.loads(scene_toml(d)) == d`` for every
dict that TOML can hold.
"""

from __future__ import annotations

import datetime
import json
import math

__all__ = ["scene_toml"]


def _key(key: str) -> str:
    return _string(str(key))


def _string(text: str) -> str:
    # JSON's escapes are TOML's, except that TOML has no surrogate pairs (keep characters
    # beyond U+FFFF as they are) and refuses a raw DEL
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (datetime.date, datetime.time)):
        return v.isoformat()
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return _string(str(v))


def _table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def scene_toml(data: dict) -> str:
    """TOML text that reads back as ``data``.

    Parameters
    ----------
    data : dict
        A scene's tables, as :func:`tomllib.loads` gives them.

    Returns
    -------
    str
        The text: top-level values first, then each table and array of tables.
    """
    head, body = [], []
    for key, value in data.items():
        if isinstance(value, dict):
            body += ["", f"[{_key(key)}]"] + [f"{_key(k)} = {_value(v)}" for k, v in value.items()]
        elif _table_array(value):
            for item in value:
                body += ["", f"[[{_key(key)}]]"] + [f"{_key(k)} = {_value(v)}" for k, v in item.items()]
        else:
            head.append(f"{_key(key)} = {_value(value)}")
    return "\n".join(head + body).strip("\n") + "\n"
