"""Scenes as TOML text: a simulation's set-up written back as a scene, in SI units, and TOML
text read with bounded nesting.

:func:`simulation_to_toml` reads only the public state of a
:class:`~emorbit.simulation.Simulation` (field, integrator settings, bodies), so the output
file can store the scene of a run built through the Python API; :mod:`emorbit.scene` parses
such text back (:func:`load_toml`). Floats are written with ``repr``, so point masses
round-trip to the last bit.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from ..errors import InputError
from .drift import DRIFT_TOLERANCE

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["simulation_to_toml", "load_toml", "MAX_DEPTH", "event_lines", "replace_events"]

#: the deepest a scene or sweep file nests tables and arrays (a mesh's rows in a [[body]]
#: table are 3 levels deep)
MAX_DEPTH = 16


def load_toml(text: str, source: str = "<string>") -> dict:
    """The tables of TOML text, nested at most :data:`MAX_DEPTH` levels deep.

    Shared by scenes and sweep files.

    Parameters
    ----------
    text : str
        The TOML text.
    source : str
        Where it came from, named in errors.

    Returns
    -------
    dict
        What :func:`tomllib.loads` gives.

    Raises
    ------
    InputError
        Text that is not TOML, or that nests deeper (naming the key that does):
        thousands of nested arrays would exhaust the parser's recursion, or that of code
        reading the tables.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, f"not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(source, f"nests tables or arrays too deep to read (at most {MAX_DEPTH} levels)") from None
    stack = [(value, 1, key) for key, value in data.items()]
    while stack:  # without recursion
        item, depth, key = stack.pop()
        if depth > MAX_DEPTH:
            raise InputError(key, f"nests tables or arrays more than {MAX_DEPTH} levels deep")
        if isinstance(item, dict):
            stack.extend((child, depth + 1, f"{key}.{name}") for name, child in item.items())
        elif isinstance(item, list):
            stack.extend((child, depth + 1, key) for child in item)
    return data


def _q(value: float, unit: str) -> str:
    return f'"{float(value)!r} {unit}"'


def _value(v) -> str:
    """A TOML value of an effect's key as given: Quantities become strings with units."""
    if hasattr(v, "unit") and hasattr(v, "value"):
        return json.dumps(f"{float(v.value)!r} {v.unit}") if np.isscalar(v.value) else _value(list(v))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):  # an inline table, e.g. a third body's orbit
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_value(x)}" for k, x in v.items()) + "}"
    return repr(float(v)) if isinstance(v, (float, np.floating)) else str(int(v))


def _v(vec, unit: str) -> str:
    return "[" + ", ".join(_q(c, unit) for c in vec) + "]"


def simulation_to_toml(sim, t_end: float | None = None, output_every: int = 1) -> str:
    """A scene reproducing a simulation's current set-up, in SI units.

    Point masses are exact to the last bit; a rigid body is written by its attitude (a
    quaternion, ~1e-16) and its angular velocity, which drops the O(dt^2) non-rigid part of
    the director velocities after steps have been taken (exact restarts keep the raw state
    instead). Elastic bodies and couplings are named in a comment only.

    Parameters
    ----------
    sim : Simulation
        The simulation.
    t_end : float, optional
        The scene's ``t_end``, s (default: one step from now).
    output_every : int
        The scene's ``output_every``.

    Returns
    -------
    str
        The scene as TOML text.
    """
    lines = []
    if sim.field is not None:
        lines.append("[field]")
        if sim.field.body:
            lines.append(f'body = "{sim.field.body}"')
        else:
            lines.append(f"gm = {_q(sim.field.gm, 'm3 / s2')}")
        lines += [f"center = {_v(sim.field.center, 'm')}", ""]
    lines += [
        "[integrator]",
        f'method = "{sim.method}"',
        f"order = {sim.order}",
        f"dt = {_q(sim.dt, 's')}",
        f"t_end = {_q(t_end if t_end is not None else sim.time + sim.dt, 's')}",
        f"output_every = {output_every}",
        f"max_newton_iterations = {sim.max_newton_iterations}",
    ]
    if sim.adaptive is not None:
        lines.append(f"adaptive = {sim.adaptive!r}")
    if sim.roundoff != "brouwer":
        lines.append(f'roundoff = "{sim.roundoff}"')
    if sim.newton != "auto":
        lines.append(f'newton = "{sim.newton}"')
    if sim.energy_range != "auto":
        lines.append(f"energy_range = {'true' if sim.energy_range else 'false'}")
    if sim.drift_tolerance != DRIFT_TOLERANCE:
        lines.append(f"drift_tolerance = {float(sim.drift_tolerance)!r}")
    if sim.epoch is not None:
        from ..epochs import epoch_text

        lines.append(f'epoch = "{epoch_text(sim.epoch)}"')
    for effect in sim.effects.named:
        lines += ["", "[[effect]]", f'kind = "{effect.kind}"']
        lines += [f"{k} = {_value(v)}" for k, v in effect.table.items() if k != "kind"]
    lines += event_lines(sim.events)
    pts = sim.points
    for i, name in enumerate(pts.names):
        lines += [
            "",
            "[[body]]",
            f"name = {json.dumps(name)}",
            'kind = "point"',
            f"mass = {_q(pts.masses[i], 'kg')}",
            f"position = {_v(pts.x[:, i], 'm')}",
            f"velocity = {_v(pts.v[:, i], 'm / s')}",
        ]
        lines += _effect_key_lines(pts.values.get(name, {}))
    if sim.rigid is not None:
        rb = sim.rigid
        now = rb.datasets(rb.current(), 1)
        for b, name in enumerate(rb.names):
            d = now[name]
            lines += [
                "",
                "[[body]]",
                f"name = {json.dumps(name)}",
                'kind = "rigid"',
                f'shape = "{rb.shapes[b]}"',
                f"position = {_v(d['position'][0], 'm')}",
                f"velocity = {_v(d['velocity'][0], 'm / s')}",
                "attitude = [" + ", ".join(repr(float(x)) for x in d["attitude"][0]) + "]",
                f"angular_velocity = {_v(d['angular_velocity'][0], 'rad / s')}",
                f'gravity = "{rb.body_attrs(b)["gravity"]}"',
            ]
            lines += _shape_lines(rb.params[b])
            lines += _surface_lines(rb.surfaces[b]) if hasattr(rb, "surfaces") else []
    if sim.structure is not None:
        lines += [
            "",
            "# elastic bodies and couplings built through the Python API are not written here: "
            + ", ".join(sim.structure.names),
        ]
    return "\n".join(lines) + "\n"


_PARAM_UNITS = {
    "size": "m",
    "radius": "m",
    "height": "m",
    "length": "m",
    "end_radius": "m",
    "density": "kg / m3",
    "mass": "kg",
    "masses": "kg",
}


def _shape_lines(params: dict) -> list[str]:
    out = []
    for key, value in params.items():
        if key in ("size", "masses"):
            out.append(f"{key} = {_v(value, _PARAM_UNITS[key])}")
        elif key in _PARAM_UNITS:
            out.append(f"{key} = {_q(value, _PARAM_UNITS[key])}")
        elif key == "refinement":
            out.append(f"refinement = {int(value)}")
        elif key == "nodes":
            out.append('mesh_unit = "m"')
            out.append(
                "nodes = [" + ", ".join("[" + ", ".join(repr(float(c)) for c in row) + "]" for row in value) + "]"
            )
        elif key == "tetrahedra":
            out.append(
                "tetrahedra = [" + ", ".join("[" + ", ".join(str(int(c)) for c in row) + "]" for row in value) + "]"
            )
    return out


def _surface_lines(surface) -> list[str]:
    """A rigid body's facets: ``facets``, its coefficients, and a ``[[body.facet]]`` table for
    each facet beyond its shape's (exact to the last bit)."""
    if surface is None:
        return ['facets = "none"']
    mode, extra, defaults, _ = surface
    out = [] if mode == "shape" else ['facets = "none"']
    out += [f"{k} = {float(v)!r}" for k, v in defaults.items()]
    for j in range(len(extra) if extra is not None else 0):
        out += [
            "",
            "[[body.facet]]",
            f"center = {_v(extra.center[j], 'm')}",
            "normal = [" + ", ".join(repr(float(c)) for c in extra.normal[j]) + "]",
            f"area = {_q(extra.area[j], 'm2')}",
            f"two_sided = {'true' if extra.two_sided[j] else 'false'}",
            f"drag_coefficient = {float(extra.drag_coefficient[j])!r}",
            f"specular = {float(extra.specular[j])!r}",
            f"diffuse = {float(extra.diffuse[j])!r}",
        ]
    return out


def _effect_key_lines(values: dict) -> list[str]:
    """A body's effect keys (:class:`emorbit.effects.base.BodyKey`), each with its SI unit."""
    from ..effects import EFFECTS

    units = {bk.name: bk.unit for cls in EFFECTS.values() for bk in cls.BODY_KEYS}
    return [f"{k} = {_q(v, units[k])}" for k, v in values.items()]


def event_lines(events) -> list[str]:
    """The ``[[event]]`` tables of an :class:`emorbit.events.EventSet`, as TOML lines."""
    from ..events import DIRECTION_NAMES

    lines: list[str] = []
    for event in events.events:
        if event.added_by is not None:  # an effect's own: it adds it again
            continue
        lines += ["", "[[event]]", f'kind = "{event.kind}"', f"label = {json.dumps(event.label)}"]
        if event.body is not None:
            lines.append(f"body = {json.dumps(event.body)}")
        if event.other is not None:
            lines.append(f"other = {json.dumps(event.other)}")
        if event.kind in ("radius", "altitude", "distance"):
            lines.append(f'value = "{event.value!r} m"')
        elif event.kind == "time":
            lines.append(f'value = "{event.value!r} s"')
        lines.append(f'direction = "{DIRECTION_NAMES[event.direction]}"')
        lines.append(f"stop = {'true' if event.stop else 'false'}")
        if event.dv is not None:
            lines.append("dv = [" + ", ".join(f'"{c!r} m / s"' for c in event.dv) + "]")
            lines.append(f'frame = "{event.frame}"')
        if event.after is not None:
            lines.append(f"after = {json.dumps(event.after)}")
        if event.sun is not None:
            lines.append(f"sun = [{', '.join(repr(float(c)) for c in event.sun)}]")
        if event.kind == "eclipse" and event.shadow != "cylindrical":
            lines.append(f'shadow = "{event.shadow}"')
    return lines


def replace_events(text: str, events) -> str:
    """A scene's text with its ``[[event]]`` tables replaced by those of ``events``: each
    table runs from its header to the next table header."""
    out, inside = [], False
    for line in text.splitlines():
        head = line.strip()
        if head.startswith("["):
            inside = head.replace(" ", "") == "[[event]]"
        if not inside:
            out.append(line)
    return "\n".join(out + event_lines(events)) + "\n"
