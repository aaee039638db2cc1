"""Sweep files: a base scene, values set for every run, and the parameters to vary.

::

    [sweep]
    scene = "paper-ellipse"   # a shipped scene or a TOML file (relative to this file)
    seed = 2024               # root seed, 0 to 2**63 - 1 (default 0)
    combine = "product"       # every combination (default) | "zip": the lists side by side
    samples = 1               # runs per combination; random parameters draw anew in each
    bodies = ["satellite"]    # bodies whose final elements the summary lists (default: all)
    max_runs = 100000         # the most runs the sweep may have (default MAX_RUNS)
    [set]                     # the same value in every run
    "integrator.t_end" = "46.4758 s"
    [[parameter]]             # values = [...] | range = {start, stop, num or step, spacing}
    key = "body[0].velocity[1]"             # | random = {distribution, its parameters}
    range = { start = 0.30, stop = 0.40, num = 11 }
    unit = "m / s"

A key is a dotted path into the scene (``body[satellite].velocity[1]``); every table on the
path must exist in the base scene and the last name must be a key that table allows. A
parameter with ``unit`` writes ``"<number> <unit>"`` into the scene; one without writes its
values unchanged. Unknown keys, keys the scene does not have, and a unit where the scene has
none (or the other way round) are errors naming the key, raised before anything runs; a bad
*value* (a negative step, say) fails its run alone. Runs are numbered in the order of the
combinations (``product``: the last parameter changes fastest), ``samples`` consecutive runs
per combination. Run i draws its random values, in the order of the tables, from
``default_rng(SeedSequence(seed).spawn(n)[i])``, which depends only on (seed, i). The runs
are counted before any range is listed: more than ``max_runs`` (the argument of
:func:`parse_sweep`, else the file's ``max_runs``, else :data:`MAX_RUNS`) is an error naming
the parameters and the count. ``docs/sweeps.md`` has the whole schema.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import numbers
import os
import re
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..scene import SCHEMA, Scene, check_table, load_scene, load_toml, read_text
from .scene_text import scene_toml
from .values import check_quantity, check_unit, has_unit, integer, number

__all__ = ["Sweep", "Parameter", "Task", "MAX_RUNS", "load_sweep", "parse_sweep", "parse_key", "set_value", "run_scene"]

_TOP = {"sweep": True, "set": False, "parameter": False}
_SWEEP = {"scene": True, "seed": False, "combine": False, "samples": False, "bodies": False, "max_runs": False}
_PARAMETER = {"key": True, "values": False, "range": False, "random": False, "unit": False}
_RANGE = {"start": True, "stop": True, "num": False, "step": False, "spacing": False}
#: random distributions and their parameters
DISTRIBUTIONS = {"uniform": ("low", "high"), "normal": ("mean", "std"), "loguniform": ("low", "high")}
#: the most runs a sweep may have unless its ``max_runs`` (or the caller's) says more
MAX_RUNS = 100_000
#: the largest root seed: a 64-bit signed integer, as the summary file stores it
MAX_SEED = 2**63 - 1


def _check_table(table, allowed: dict, where: str) -> dict:
    return check_table(table, allowed, where, root="sweep")


# -- keys into a scene -------------------------------------------------------------------
_SEGMENT = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[[^\[\]]+\])*)\Z")
_INDEX = re.compile(r"\[([^\[\]]+)\]")


def parse_key(key, where: str = "key") -> tuple:
    """Split a dotted key into its path.

    ``"body[0].velocity[1]"`` gives ``("body", 0, "velocity", 1)``; a bracket that is not an
    integer selects the list element of that ``name``: ``body[sat]`` gives
    ``("body", ("name", "sat"))``. Dots inside brackets belong to the name.

    Parameters
    ----------
    key : str
        The key.
    where : str
        Where it came from, for the error message.

    Returns
    -------
    tuple
        Names, indices and ("name", ...) selectors.

    Raises
    ------
    InputError
        Not a key.
    """
    if not isinstance(key, str) or not key:
        raise InputError(where, f"a dotted key such as 'integrator.dt' expected, got {key!r}")
    segments, depth, start = [], 0, 0
    for j, ch in enumerate(key):  # split at dots outside brackets (a body name may hold a dot)
        depth += ch == "["
        depth -= ch == "]"
        if ch == "." and depth == 0:
            segments.append(key[start:j])
            start = j + 1
    segments.append(key[start:])
    path = []
    for seg in segments:
        m = _SEGMENT.match(seg)
        if m is None:
            raise InputError(
                where,
                f"{key!r} is not a key: use names joined by dots with [index] or [name] "
                "after a name, e.g. 'body[0].velocity[1]'",
            )
        path.append(m.group(1))
        for inner in _INDEX.findall(m.group(2)):
            inner = inner.strip().strip("'\"")
            path.append(int(inner) if re.fullmatch(r"-?\d+", inner) else ("name", inner))
    return tuple(path)


def _schema_of(path: tuple, node) -> str | None:
    """Which scene SCHEMA table ``node`` (reached by ``path``) is checked against, if any."""
    if not path:
        return ""
    if len(path) == 1 and path[0] in ("field", "integrator"):
        return path[0]
    if len(path) == 2 and path[0] == "body" and isinstance(node, dict):
        kind = node.get("kind")
        return f"body.{kind}" if f"body.{kind}" in SCHEMA else None
    if len(path) == 2 and path[0] == "coupling":
        return "coupling"
    return None


def _show(path) -> str:
    out = ""
    for p in path:
        if isinstance(p, int):
            out += f"[{p}]"
        elif isinstance(p, tuple):
            out += f"[{p[1]}]"
        else:
            out += ("." if out else "") + p
    return out


def _locate(data: dict, path: tuple, where: str):
    """(container, last part, schema name of the container) for ``path`` in ``data``."""
    node = data
    for j, part in enumerate(path[:-1]):
        here = _show(path[: j + 1])
        if isinstance(part, str):
            if not isinstance(node, dict):
                raise InputError(where, f"{_show(path[:j])} is not a table, so it has no key {part!r}")
            if part not in node:
                raise InputError(where, f"the base scene has no {here!r}")
            node = node[part]
        else:
            if not isinstance(node, list):
                raise InputError(where, f"{_show(path[:j])} is not a list, so {here!r} does not exist")
            node = node[_list_index(node, part, here, where)]
    return node, path[-1], _schema_of(path[:-1], node)


def _list_index(node: list, part, here: str, where: str) -> int:
    if isinstance(part, tuple):
        names = [e.get("name") for e in node if isinstance(e, dict)]
        if part[1] not in names:
            raise InputError(
                where, f"no element named {part[1]!r} for {here!r}; names: {', '.join(map(str, names)) or 'none'}"
            )
        return names.index(part[1])
    if not -len(node) <= part < len(node):
        raise InputError(where, f"{here!r} does not exist: the list has {len(node)} elements")
    return part


def check_key(data: dict, path: tuple, where: str):
    """Check that a path can be set in a scene (see the module notes).

    Parameters
    ----------
    data : dict
        The base scene.
    path : tuple
        From :func:`parse_key`.
    where : str
        Where the key came from, for the error message.

    Returns
    -------
    object
        The current value there, or None if the key is allowed but absent.

    Raises
    ------
    InputError
        A table on the path does not exist, or the last name is not a key its table allows.
    """
    node, last, schema = _locate(data, path, where)
    if isinstance(last, str):
        if not isinstance(node, dict):
            raise InputError(where, f"{_show(path[:-1])} is not a table, so it has no key {last!r}")
        if last not in node:
            allowed = SCHEMA.get(schema) if schema is not None else None
            if allowed is None or last not in allowed:
                hint = f"; allowed here: {', '.join(allowed)}" if allowed else ""
                raise InputError(
                    where, f"unknown key {_show(path)!r}: {_show(path[:-1]) or 'the scene'} has no {last!r}{hint}"
                )
            return None
        return node[last]
    if not isinstance(node, list):
        raise InputError(where, f"{_show(path[:-1])} is not a list, so {_show(path)!r} does not exist")
    return node[_list_index(node, last, _show(path), where)]


def set_value(data: dict, path: tuple, value) -> None:
    """Set a value at a path in a scene, in place.

    Parameters
    ----------
    data : dict
        The scene.
    path : tuple
        From :func:`parse_key`.
    value : object
        The value, as written in a scene.
    """
    node, last, _ = _locate(data, path, _show(path))
    if isinstance(last, str):
        node[last] = value
    else:
        node[_list_index(node, last, _show(path), _show(path))] = value


# -- parameters --------------------------------------------------------------------------
def _with_unit(value, unit: str | None, where: str):
    """A value as written into the scene: numbers with ``unit`` become "<number> <unit>"."""
    if unit is None:
        return value
    if isinstance(value, list):
        return [_with_unit(v, unit, f"{where}[{j}]") for j, v in enumerate(value)]
    number(value, where)
    text = str(int(value)) if isinstance(value, numbers.Integral) else repr(float(value))
    return f"{text} {unit}"


@dataclass
class Parameter:
    """One ``[[parameter]]``: a key, and a list of values or a random distribution.

    Attributes
    ----------
    key : str
        The key as written.
    path : tuple
        The key's path (:func:`parse_key`).
    unit : str or None
        The values' unit: numbers become ``"<number> <unit>"`` in the scene.
    values : list or None
        The values (None for a random parameter).
    distribution : str or None
        ``"uniform"``, ``"normal"`` or ``"loguniform"``.
    args : tuple
        The distribution's parameters.
    """

    key: str
    path: tuple
    unit: str | None = None
    values: list | None = None  # numbers (with unit) or scene values; None for random
    distribution: str | None = None
    args: tuple = ()

    @property
    def random(self) -> bool:
        """Whether the parameter is drawn at random."""
        return self.values is None

    def draw(self, rng: np.random.Generator) -> float:
        """Draw one value of a random parameter.

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.

        Returns
        -------
        float
            The value (in the parameter's unit).
        """
        a, b = self.args
        if self.distribution == "uniform":
            return float(rng.uniform(a, b))
        if self.distribution == "normal":
            return float(rng.normal(a, b))
        return float(math.exp(rng.uniform(math.log(a), math.log(b))))

    def scene_value(self, value, where: str):
        """A value as written into the scene.

        Parameters
        ----------
        value : object
            A value of the parameter.
        where : str
            Where it came from, for the error message.

        Returns
        -------
        object
            With a unit, numbers become ``"<number> <unit>"`` (lists element by element); without
            one, the value unchanged.
        """
        return _with_unit(value, self.unit, where)

    @property
    def column_unit(self) -> str:
        """The unit of its summary column: ``unit``; "1" for bare numbers; "" for text such as "0.4 s"."""
        if self.unit:
            return self.unit
        if self.random or all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in self.values):
            return "1"
        return ""


def _range_count(r, where: str) -> int | float:
    """How many values a range table gives, checked, without listing them (inf: too many to count)."""
    _check_table(r, _RANGE, where)
    start = number(r["start"], f"{where}.start")
    stop = number(r["stop"], f"{where}.stop")
    spacing = r.get("spacing", "linear")
    if spacing not in ("linear", "log"):
        raise InputError(f"{where}.spacing", f"must be 'linear' or 'log', got {spacing!r}")
    if ("num" in r) == ("step" in r):
        raise InputError(where, "give exactly one of num and step")
    if spacing == "log":
        if "num" not in r:
            raise InputError(f"{where}.step", "a log range takes num, not step")
        if not (start > 0 and stop > 0):
            raise InputError(where, f"a log range needs start, stop > 0, got {start!r}, {stop!r}")
    if "num" in r:
        return integer(r["num"], f"{where}.num", 1)
    step = number(r["step"], f"{where}.step")
    if step == 0 or (stop - start) * step < 0:
        raise InputError(f"{where}.step", f"{step!r} does not lead from {start!r} to {stop!r}")
    count = (stop - start) / step
    return int(math.floor(count + 1e-9)) + 1 if math.isfinite(count) else math.inf


def _range_values(r, where: str) -> list:
    n = _range_count(r, where)
    start, stop, step = r["start"], r["stop"], r.get("step")
    if "num" in r:
        if n == 1:
            return [start]
        grid = np.geomspace(start, stop, n) if r.get("spacing") == "log" else np.linspace(start, stop, n)
        return [float(x) for x in grid]
    if all(isinstance(r[k], numbers.Integral) for k in ("start", "stop", "step")):
        return list(range(start, start + n * step, step))
    return (start + np.arange(n, dtype=np.float64) * step).tolist()  # start + j * step, as in Python


def _parameter(p, j: int, scene_data: dict) -> Parameter:
    where = f"parameter[{j}]"
    _check_table(p, _PARAMETER, where)
    sources = [k for k in ("values", "range", "random") if k in p]
    if len(sources) != 1:
        raise InputError(where, "give exactly one of values, range and random")
    path = parse_key(p["key"], f"{where}.key")
    current = check_key(scene_data, path, f"{where}.key ({p['key']})")
    unit = p.get("unit")
    if unit is not None:
        if not isinstance(unit, str) or not unit.strip():
            raise InputError(f"{where}.unit", f"a unit such as 'm / s' expected, got {unit!r}")
        check_unit(unit, f"{where}.unit")
    param = Parameter(key=p["key"], path=path, unit=unit)
    if "values" in p:
        vals = p["values"]
        if not isinstance(vals, list) or not vals:
            raise InputError(f"{where}.values", f"a non-empty list expected, got {vals!r}")
        for k, v in enumerate(vals):
            param.scene_value(v, f"{where}.values[{k}]")  # numbers where a unit is given
        param.values = list(vals)
    elif "range" in p:
        try:
            param.values = _range_values(p["range"], f"{where}.range")
        except MemoryError:  # only where max_runs was raised that far
            raise InputError(f"{where}.range", "too many values to hold in memory; vary fewer") from None
    else:
        r = p["random"]
        rw = f"{where}.random"
        if not isinstance(r, dict) or r.get("distribution") not in DISTRIBUTIONS:
            got = r.get("distribution") if isinstance(r, dict) else r
            raise InputError(f"{rw}.distribution", f"one of {', '.join(DISTRIBUTIONS)} expected, got {got!r}")
        names = DISTRIBUTIONS[r["distribution"]]
        _check_table(r, {"distribution": True, **{n: True for n in names}}, rw)
        args = tuple(float(number(r[n], f"{rw}.{n}")) for n in names)
        if r["distribution"] == "normal" and not args[1] >= 0:
            raise InputError(f"{rw}.std", f"must be >= 0, got {args[1]!r}")
        if r["distribution"] != "normal" and not args[0] < args[1]:
            raise InputError(rw, f"needs low < high, got {args[0]!r}, {args[1]!r}")
        if r["distribution"] == "loguniform" and not args[0] > 0:
            raise InputError(f"{rw}.low", f"must be > 0, got {args[0]!r}")
        param.distribution = r["distribution"]
        param.args = args
    quantity = has_unit(current)
    if unit is None and not param.random and "range" not in p:
        for k, v in enumerate(param.values):  # a bare number where the scene has a quantity fails every run
            check_quantity(current, v, f"{where}.unit", f"{p['key']} (values[{k}])")
        return param
    # generated numbers: the scene must want a quantity exactly when a unit is given
    if unit is None and quantity:
        raise InputError(
            f"{where}.unit",
            f"{p['key']} takes a value with a unit (the scene has {current!r}); "
            'give the unit of the numbers, e.g. unit = "m"',
        )
    if unit is not None and current is not None and not quantity:
        raise InputError(f"{where}.unit", f"{p['key']} takes a bare number (the scene has {current!r}); drop the unit")
    return param


# -- the sweep ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Task:
    """One run of a sweep.

    Attributes
    ----------
    index : int
        The run's number.
    seed : int
        Its seed (from ``SeedSequence(seed).spawn(n)[index]``).
    values : dict
        {key: value} of every parameter, as written into the scene.
    digest : str
        Identifies the run (base scene, fixed values, its values and seed) in its file.
    """

    index: int
    seed: int
    values: dict
    digest: str


@dataclass
class Sweep:
    """A checked sweep: the base scene, fixed values, parameters and how they combine.

    Attributes
    ----------
    scene : Scene
        The base scene.
    parameters : list of Parameter
        The ``[[parameter]]`` tables, in order.
    fixed : dict
        {key: value} written into every run.
    seed : int
        The root seed.
    combine : str
        ``"product"`` or ``"zip"``.
    samples : int
        Runs per combination.
    bodies : list of str or None
        Bodies whose final elements the summary lists (None: all).
    text : str
        The sweep file's text.
    source : str
        Where it came from.
    """

    scene: Scene
    parameters: list[Parameter]
    fixed: dict = field(default_factory=dict)  # key -> value written into every run
    seed: int = 0
    combine: str = "product"
    samples: int = 1
    bodies: list[str] | None = None
    text: str = ""
    source: str = "<string>"

    def __len__(self) -> int:
        sizes = [len(p.values) for p in self._axes()] or [1]
        return (sizes[0] if self.combine == "zip" else math.prod(sizes)) * self.samples

    def _axes(self) -> list[Parameter]:
        return [p for p in self.parameters if not p.random]

    def tasks(self) -> list[Task]:
        """Every run, in order (see the module notes).

        Returns
        -------
        list of Task
            ``len(self)`` tasks.
        """
        return list(self.iter_tasks())

    def iter_tasks(self):
        """Every run, in order, one at a time (as :meth:`tasks`, without holding them all).

        Yields
        ------
        Task
            Run 0, 1, ... ``len(self) - 1``.
        """
        axes = self._axes()
        if not axes:
            combos = [()]
        elif self.combine == "zip":
            combos = zip(*[p.values for p in axes])
        else:
            combos = itertools.product(*[p.values for p in axes])
        root = np.random.SeedSequence(self.seed)
        base = json.dumps(
            {"scene": self.scene.text, "fixed": self.fixed, "bodies": self.bodies}, sort_keys=True, default=str
        )
        for c, combo in enumerate(combos):
            chosen = dict(zip([p.key for p in axes], combo))
            for s in range(self.samples):
                i = c * self.samples + s
                # SeedSequence(seed).spawn(n)[i], made alone
                child = np.random.SeedSequence(root.entropy, spawn_key=(i,), pool_size=root.pool_size)
                rng = np.random.default_rng(child)
                values = {}
                for p in self.parameters:
                    values[p.key] = p.draw(rng) if p.random else chosen[p.key]
                seed = int(child.generate_state(1, np.uint64)[0])
                digest = hashlib.sha256(
                    json.dumps([base, values, seed], sort_keys=True, default=str).encode()
                ).hexdigest()[:32]
                yield Task(i, seed, values, digest)

    def scene_for(self, task: Task) -> Scene:
        """The scene of one run, unchecked (building it checks it).

        Parameters
        ----------
        task : Task
            The run.

        Returns
        -------
        Scene
            The base scene with the fixed values and the run's values set.
        """
        return run_scene(
            self.scene.data,
            self.scene.source,
            self.fixed,
            [(p.key, p.path, p.unit) for p in self.parameters],
            task.index,
            task.values,
        )

    def body_names(self) -> list[str]:
        """The bodies whose final elements the summary lists.

        Returns
        -------
        list of str
            ``bodies``, or every named body of the scene.
        """
        if self.bodies is not None:
            return list(self.bodies)
        return [b["name"] for b in self.scene.data.get("body", []) if isinstance(b, dict) and "name" in b]


def run_scene(data: dict, source: str, fixed: dict, params, index: int, values: dict) -> Scene:
    """One run's scene: the base scene with the fixed values and the run's values set.

    Its text is the run's scene as TOML (:func:`~emorbit.sweep.scene_text.scene_toml`) after
    comments naming what was set: a run file stores it, and ``emorbit resume`` rebuilds the
    run from it. Unchecked: building it checks it.

    Parameters
    ----------
    data : dict
        The base scene.
    source : str
        Where the base scene came from.
    fixed : dict
        {key: value} set in every run.
    params : list of tuple
        (key, path, unit) of each parameter.
    index : int
        The run's number.
    values : dict
        {key: value} of the run.

    Returns
    -------
    Scene
        The run's scene.
    """
    data = copy.deepcopy(data)
    notes = []
    for key, value in fixed.items():
        set_value(data, parse_key(key), value)
        notes.append(f"# sweep: {key} = {json.dumps(value)}\n")
    for key, path, unit in params:
        value = _with_unit(values[key], unit, key)
        set_value(data, path, value)
        notes.append(f"# sweep run {index}: {key} = {json.dumps(value)}\n")
    return Scene(data, "".join(notes) + scene_toml(data), source)


def _flatten(table: dict, prefix: str = "") -> dict:
    """``{"integrator": {"t_end": x}}`` (TOML's reading of a bare dotted key) -> ``{"integrator.t_end": x}``."""
    out = {}
    for key, value in table.items():
        full = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict):
            out.update(_flatten(value, full))
        else:
            out[full] = value
    return out


def _size(value) -> str:
    return f"{value:,}" if isinstance(value, int) else "over 1e308"


def _count_runs(params_raw: list, combine: str, samples: int, limit: int, limit_from: str) -> None:
    """Count the runs from the tables as written, before any range is listed; raise above ``limit``."""
    counts = []
    for j, p in enumerate(params_raw):
        if not isinstance(p, dict) or sum(k in p for k in ("values", "range", "random")) != 1:
            continue  # reported when the table is read
        if isinstance(p.get("values"), list):
            counts.append((j, p.get("key"), len(p["values"])))
        elif "range" in p:
            counts.append((j, p.get("key"), _range_count(p["range"], f"parameter[{j}].range")))
    sizes = [n for _, _, n in counts] or [1]
    total = (max(sizes) if combine == "zip" else math.prod(sizes)) * samples
    if total <= limit:
        return
    parts = [f"parameter[{j}] ({key}): {_size(n)} values" for j, key, n in counts]
    parts += [f"samples = {_size(samples)}"] if samples > 1 or not parts else []
    sep = " side by side with " if combine == "zip" else " x "
    raise InputError(
        "parameter" if counts else "sweep.samples",
        f"the sweep has {_size(total)} runs ({sep.join(parts)}), more than {limit_from} ({_size(limit)}); "
        "vary fewer values, or raise the limit with max_runs in [sweep], emorbit sweep --max-runs N "
        "or run_sweep(..., max_runs=N)",
    )


def parse_sweep(text: str, source: str = "<string>", max_runs: int | None = None) -> Sweep:
    """Parse and check a sweep from TOML text.

    Parameters
    ----------
    text : str
        The sweep file's text.
    source : str
        Its path: a relative scene path is taken from its folder.
    max_runs : int, optional
        The most runs the sweep may have; default: the file's ``max_runs``, else
        :data:`MAX_RUNS`. The runs are counted before anything is listed.

    Returns
    -------
    Sweep
        The checked sweep.

    Raises
    ------
    InputError
        Bad TOML, an unknown or misplaced key, a key the scene does not have, a unit where the
        scene has none (or the other way round), inconsistent options, or more runs than
        ``max_runs``; the error names the key.
    """
    if max_runs is not None:
        integer(max_runs, "max_runs", 1)
    data = load_toml(text, source)
    _check_table(data, _TOP, "")
    sw = _check_table(data["sweep"], _SWEEP, "sweep")
    scene_ref = sw["scene"]
    if not isinstance(scene_ref, str) or not scene_ref:
        raise InputError("sweep.scene", f"a shipped scene's name or a TOML path expected, got {scene_ref!r}")
    if source != "<string>" and not os.path.isabs(scene_ref):
        candidate = os.path.join(os.path.dirname(os.path.abspath(source)), scene_ref)
        if os.path.isfile(candidate):
            scene_ref = candidate
    try:
        scene = load_scene(scene_ref)
    except InputError as exc:
        raise InputError("sweep.scene", str(exc)) from None
    seed = integer(sw.get("seed", 0), "sweep.seed", 0, MAX_SEED)
    combine = sw.get("combine", "product")
    if combine not in ("product", "zip"):
        raise InputError("sweep.combine", f"must be 'product' or 'zip', got {combine!r}")
    samples = integer(sw.get("samples", 1), "sweep.samples", 1)
    params_raw = data.get("parameter", [])
    if not isinstance(params_raw, list):
        raise InputError("parameter", "expected [[parameter]] tables")
    limit = max_runs if max_runs is not None else integer(sw.get("max_runs", MAX_RUNS), "sweep.max_runs", 1)
    named = "max_runs" if max_runs is not None else "sweep.max_runs" if "max_runs" in sw else "the default limit"
    _count_runs(params_raw, combine, samples, limit, named)
    params = [_parameter(p, j, scene.data) for j, p in enumerate(params_raw)]
    for p in params:
        same = [k for k, q in enumerate(params) if q.path == p.path]
        if len(same) > 1:
            raise InputError(f"parameter[{same[1]}].key", f"{p.key!r} is varied twice (parameter {same})")
    fixed_raw = data.get("set", {})
    if not isinstance(fixed_raw, dict):
        raise InputError("set", f"expected a table, got {fixed_raw!r}")
    fixed = _flatten(fixed_raw)
    for key in fixed:
        path = parse_key(key, f"set.{key}")
        check_quantity(check_key(scene.data, path, f"set.{key}"), fixed[key], f"set.{key}", key)
        if any(p.path == path for p in params):
            raise InputError(f"set.{key}", f"{key!r} is also a parameter: set it in one place")
    axes = [p for p in params if not p.random]
    if combine == "zip" and len({len(p.values) for p in axes}) > 1:
        raise InputError(
            "sweep.combine",
            "zip needs lists of equal length; got " + ", ".join(f"{p.key}: {len(p.values)}" for p in axes),
        )
    if samples > 1 and not any(p.random for p in params):
        raise InputError(
            "sweep.samples",
            f"{samples} samples of a sweep without random parameters would repeat "
            "identical runs; add a [[parameter]] with random = {...}",
        )
    bodies = sw.get("bodies")
    names = [b.get("name") for b in scene.data.get("body", []) if isinstance(b, dict)]
    if bodies is not None:
        if not isinstance(bodies, list) or not all(isinstance(b, str) for b in bodies):
            raise InputError("sweep.bodies", f"a list of body names expected, got {bodies!r}")
        for b in bodies:
            if b not in names:
                raise InputError("sweep.bodies", f"no body named {b!r} in the scene; bodies: {', '.join(names)}")
    return Sweep(scene, params, fixed, seed, combine, samples, bodies, text, source)


def load_sweep(path, max_runs: int | None = None) -> Sweep:
    """Read and check a sweep file.

    Parameters
    ----------
    path : str or os.PathLike
        The TOML file.
    max_runs : int, optional
        The most runs the sweep may have (see :func:`parse_sweep`).

    Returns
    -------
    Sweep
        The checked sweep.

    Raises
    ------
    InputError
        No such file, or what :func:`parse_sweep` raises.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError("sweep", f"{path!r} is not a file")
    return parse_sweep(read_text(path, "sweep"), path, max_runs)
