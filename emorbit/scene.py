"""Scenes: a TOML file that says which field, method and bodies a run has.

::

    [field]
    gm = "3.9478 m3 / s2"
    [integrator]
    method = "em"
    dt = "0.464758 s"
    t_end = "4647.58 s"
    output_every = 10
    [[body]]
    name = "satellite"
    kind = "point"
    mass = "1 kg"
    position = ["10 m", "0 m", "0 m"]
    velocity = ["0 m/s", "0.36276 m/s", "0 m/s"]

Every dimensional value is a string with a unit (anything astropy reads: "1 km", "1 d",
"3.9478 m3 / s2"). Unknown keys, missing keys, wrong units and bad values are errors naming
the key, raised before anything runs. :data:`KEYS` lists every key of every table with its
unit, default, allowed values and meaning; :data:`SCHEMA` (which keys each table allows, and
which it requires) is derived from it, and the scenes page of the documentation is generated
from it. Shipped scenes are found by name (:func:`list_scenes`).
"""

from __future__ import annotations

import copy
import importlib.resources
import numbers
import os
import re
from dataclasses import dataclass, field

from .effects import EFFECTS
from .errors import InputError
from .field import CentralField
from .io.drift import check_tolerance
from .io.scene_toml import MAX_DEPTH, load_toml, simulation_to_toml
from .keys import Key
from .scene_keys import (
    BODY_KINDS,
    COUPLING_KINDS,
    ELASTIC_COMMON,
    KEYS,
    RIGID_COMMON,
    SCHEMA,
    SIMULATION_ARGUMENTS,
)
from .simulation import MAX_OUTPUT, Simulation, check_body_name
from .units import to_si

__all__ = [
    "Scene",
    "Key",
    "KEYS",
    "SCHEMA",
    "load_scene",
    "list_scenes",
    "parse_scene",
    "scene_overrides",
    "simulation_to_toml",
    "load_toml",
    "MAX_DEPTH",
]


def check_table(table, allowed: dict, where: str, root: str = "scene") -> dict:
    """Check that ``table`` is a table with only allowed keys and every required one.

    Shared by scenes and sweep files.

    Parameters
    ----------
    table : object
        The value read from TOML.
    allowed : dict
        ``{key: required?}``, e.g. a value of :data:`SCHEMA`.
    where : str
        The table's path, prefixed to the keys named in errors (``""`` for the top level).
    root : str
        What to name in the error when a top-level value is not a table.

    Returns
    -------
    dict
        ``table`` itself.

    Raises
    ------
    InputError
        Naming ``where.key`` for an unknown or a missing key.
    """
    if not isinstance(table, dict):
        raise InputError(where or root, f"expected a table, got {table!r}")
    for key in table:
        if key not in allowed:
            raise InputError(
                f"{where}.{key}" if where else key, f"unknown key {key!r}; allowed here: {', '.join(allowed)}"
            )
    for key, required in allowed.items():
        if required and key not in table:
            raise InputError(f"{where}.{key}" if where else key, "missing (required)")
    return table


def _check_keys(table, schema_name: str, where: str) -> None:
    allowed = SCHEMA[schema_name]
    if schema_name.startswith("body."):  # and the keys of effects registered since (a user's)
        allowed = allowed | {k: False for k in _effect_body_keys(schema_name[len("body.") :])}
    check_table(table, allowed, where)


def _effect_body_keys(kind: str) -> list[str]:
    """The keys registered effects attach to bodies of a kind."""
    return list(dict.fromkeys(bk.name for cls in EFFECTS.values() for bk in cls.BODY_KEYS if kind in bk.kinds))


def _int(value, key: str, minimum: int, maximum: int = 2**63 - 1) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not minimum <= value <= maximum:
        bounds = f">= {minimum}" if maximum == 2**63 - 1 else f"in {minimum}..{maximum:,}"
        if isinstance(value, numbers.Integral) and not isinstance(value, bool) and value > maximum:
            bounds = f"<= {maximum:,}"
        raise InputError(key, f"must be an integer {bounds}, got {value!r}")
    return int(value)


@dataclass
class Scene:
    """A checked scene.

    Values are kept as given (strings with units) and converted to SI by :meth:`build`.

    Attributes
    ----------
    data : dict
        The tables as read from TOML.
    text : str
        The TOML text it came from (stored in output files).
    source : str
        The file or shipped scene it was read from (``"<string>"`` for text).
    """

    data: dict
    text: str
    source: str = "<string>"
    #: the simulation :meth:`check` built, handed out by the next :meth:`build`
    _checked: Simulation | None = field(default=None, repr=False, compare=False)

    # -- the integrator settings, in SI ---------------------------------------------------
    @property
    def method(self) -> str:
        """The method's name (``integrator.method``, default ``"em"``)."""
        return self.data["integrator"].get("method", "em")

    @property
    def order(self) -> int:
        """The order (``integrator.order``, default 2)."""
        return int(self.data["integrator"].get("order", 2))

    @property
    def dt(self) -> float:
        """The step in s (``integrator.dt``)."""
        return to_si(self.data["integrator"]["dt"], "time", "integrator.dt", strict=True, positive=True)

    @property
    def t_end(self) -> float:
        """The end time in s (``integrator.t_end``)."""
        return to_si(self.data["integrator"]["t_end"], "time", "integrator.t_end", strict=True, positive=True)

    @property
    def output_every(self) -> int:
        """Steps between records (``integrator.output_every``, default 1)."""
        return int(self.data["integrator"].get("output_every", 1))

    @property
    def checkpoint_every(self) -> int | None:
        """Steps between checkpoints, or None for the default (see :meth:`Simulation.run`)."""
        value = self.data["integrator"].get("checkpoint_every")
        return None if value is None else int(value)

    @property
    def max_output(self) -> float:
        """The largest projected output of a run in bytes (``integrator.max_output``, default 10 GB)."""
        value = self.data["integrator"].get("max_output", MAX_OUTPUT)
        return to_si(value, "information", "integrator.max_output", strict=True, positive=True)

    def _folder(self) -> str:
        """The folder of the scene's file, where relative paths in it are found ("" for text)."""
        if self.source != "<string>" and os.path.isfile(self.source):
            return os.path.dirname(os.path.abspath(self.source))
        return ""

    def with_overrides(
        self,
        *,
        t_end=None,
        dt=None,
        method=None,
        order=None,
        output_every=None,
        checkpoint_every=None,
        max_output=None,
        check: bool = True,
    ) -> Scene:
        """A copy with integrator settings replaced, checked again.

        Parameters
        ----------
        t_end, dt, method, order, output_every, checkpoint_every, max_output : optional
            New values of the ``[integrator]`` keys, written as in the TOML (strings with
            units for ``t_end``, ``dt`` and ``max_output``); ``None`` keeps the scene's.
        check : bool
            Check it now (:meth:`check`); False leaves that to :meth:`build`.

        Returns
        -------
        Scene
            The new scene; its ``text`` gains a comment line per overridden key.
        """
        data = copy.deepcopy(self.data)
        _check_keys(data, "", "")  # an [integrator] table to write the overrides into
        _check_keys(data["integrator"], "integrator", "integrator")
        changed = {}
        for key, value in (
            ("t_end", t_end),
            ("dt", dt),
            ("method", method),
            ("order", order),
            ("output_every", output_every),
            ("checkpoint_every", checkpoint_every),
            ("max_output", max_output),
        ):
            if value is not None:
                if len(repr(value)) > MAX_OVERRIDE:  # its note would not be read back (scene_overrides)
                    raise InputError(f"integrator.{key}", f"longer than {MAX_OVERRIDE} characters")
                data["integrator"][key] = value
                changed[key] = value
        note = "".join(f"# override: integrator.{k} = {v!r}\n" for k, v in changed.items())
        scene = Scene(data, note + self.text, self.source)
        if check:
            scene.check()
        return scene

    def check(self) -> None:
        """Validate everything by building the simulation, which the next :meth:`build` returns
        (a scene checked and then run is built once).

        Raises
        ------
        InputError
            Naming the first key that is wrong.
        """
        self._checked = self._build_named()

    def build(self) -> Simulation:
        """A new simulation with this scene's field, method and bodies (the one :meth:`check`
        built, the first time after a check).

        Returns
        -------
        Simulation
            Ready to run to :attr:`t_end` (not yet run).

        Raises
        ------
        InputError
            Naming the first key that is wrong.
        """
        sim, self._checked = self._checked, None
        return sim if sim is not None else self._build_named()

    def _build_named(self) -> Simulation:
        try:
            return self._build()
        except InputError as exc:
            if exc.key in SIMULATION_ARGUMENTS:  # named by the Simulation as its argument
                raise InputError(f"integrator.{exc.key}", exc.message) from None
            raise

    def _build(self) -> Simulation:
        d = self.data
        _check_keys(d, "", "")
        field = None  # no [field]: free space
        if "field" in d:
            f = d["field"]
            _check_keys(f, "field", "field")
            field = CentralField(
                gm=f.get("gm"),
                g_ref=f.get("g_ref"),
                r_ref=f.get("r_ref"),
                body=f.get("body"),
                center=f.get("center", ["0 m", "0 m", "0 m"]),
                radius=f.get("radius"),
                strict=True,
            )
        integ = d["integrator"]
        _check_keys(integ, "integrator", "integrator")
        _int(integ.get("output_every", 1), "integrator.output_every", 1)
        if "checkpoint_every" in integ:
            _int(integ["checkpoint_every"], "integrator.checkpoint_every", 1)
        dt = self.dt
        t_end = self.t_end
        max_output = self.max_output
        sim = Simulation(  # checks the method and its settings once (the Plan), naming them as arguments
            field,
            method=integ.get("method", "em"),
            order=integ.get("order", 2),
            dt=dt,
            max_newton_iterations=integ.get("max_newton_iterations", 50),
            newton=integ.get("newton", "auto"),
            adaptive=integ.get("adaptive"),
            roundoff=integ.get("roundoff", "brouwer"),
            epoch=integ.get("epoch"),
        )
        sim.keys = {k: f"integrator.{k}" for k in ("t_end", "dt", "max_output")} | {"every": "integrator.output_every"}
        sim.max_output = max_output
        bodies = d["body"]
        if not isinstance(bodies, list) or not bodies:
            raise InputError("body", "a scene needs at least one [[body]] table")
        _add_effects(sim, d.get("effect", []), self._folder())
        for i, b in enumerate(bodies):
            where = f"body[{i}]"
            if not isinstance(b, dict):
                raise InputError(where, f"expected a table, got {b!r}")
            kind = b.get("kind")
            if kind not in BODY_KINDS:
                raise InputError(f"{where}.kind", f"unknown body kind {kind!r}; known: {', '.join(BODY_KINDS)}")
            _check_keys(b, f"body.{kind}", where)
            check_body_name(b["name"], f"{where}.name")
            if kind == "point":
                sim.add_point(
                    b["name"],
                    mass=b["mass"],
                    **_placement(b),
                    strict=True,
                    key=where,
                    **{k: b[k] for k in _effect_body_keys("point") if k in b},
                )
            elif kind == "elastic":
                mesh_params = {k: v for k, v in b.items() if k not in ELASTIC_COMMON}
                if "file" in mesh_params and not isinstance(mesh_params["file"], str):
                    raise InputError(f"{where}.file", f"a path (a string) expected, got {mesh_params['file']!r}")
                if "file" in mesh_params and self._folder():
                    mesh_params["file"] = os.path.join(self._folder(), mesh_params["file"])
                sim.add_elastic(
                    b["name"],
                    b["mesh"],
                    **_placement(b),
                    young=b["young"],
                    density=b["density"],
                    poisson=b.get("poisson"),
                    area=b.get("area"),
                    attitude=b.get("attitude"),
                    rotation_vector=b.get("rotation_vector"),
                    angular_velocity=b.get("angular_velocity", ["0 rad/s", "0 rad/s", "0 rad/s"]),
                    angular_velocity_frame=b.get("angular_velocity_frame", "body"),
                    gravity=b.get("gravity"),
                    mass_matrix=b.get("mass_matrix", "consistent"),
                    node_output_every=b.get("node_output_every", 1),
                    drag_coefficient=b.get("drag_coefficient", 2.2),
                    strict=True,
                    key=where,
                    **mesh_params,
                )
            else:
                shape_params = {k: v for k, v in b.items() if k not in RIGID_COMMON}
                sim.add_rigid(
                    b["name"],
                    b["shape"],
                    **_placement(b),
                    attitude=b.get("attitude"),
                    rotation_vector=b.get("rotation_vector"),
                    angular_velocity=b.get("angular_velocity", ["0 rad/s", "0 rad/s", "0 rad/s"]),
                    angular_velocity_frame=b.get("angular_velocity_frame", "body"),
                    gravity=b.get("gravity"),
                    facets=b.get("facets", "shape"),
                    facet=b.get("facet"),
                    drag_coefficient=b.get("drag_coefficient", 2.2),
                    specular=b.get("specular", 0.0),
                    diffuse=b.get("diffuse", 0.0),
                    strict=True,
                    key=where,
                    **shape_params,
                )
        _add_events(sim, d.get("event", []))
        couplings = d.get("coupling", [])
        if not isinstance(couplings, list):
            raise InputError("coupling", "expected [[coupling]] tables")
        for i, cpl in enumerate(couplings):
            where = f"coupling[{i}]"
            _check_keys(cpl, "coupling", where)
            if cpl["kind"] not in COUPLING_KINDS:
                raise InputError(
                    f"{where}.kind", f"unknown coupling kind {cpl['kind']!r}; known: {', '.join(COUPLING_KINDS)}"
                )
            sim.attach(cpl["elastic"], cpl["nodes"], cpl["to"], key=where)
        _check_couplings(sim, couplings)
        sim.check()
        if "energy_range" in integ:
            try:
                sim.energy_range = integ["energy_range"]
            except InputError as exc:
                raise InputError("integrator.energy_range", exc.message) from None
        if "drift_tolerance" in integ:
            sim.drift_tolerance = check_tolerance(integ["drift_tolerance"], "integrator.drift_tolerance")
        sim.steps_until(t_end)  # t_end must lie at least one step ahead
        sim.scene_text = self.text
        sim.t_end_requested = t_end
        return sim


#: the longest value an override line may hold (a string with a unit, an integer, as repr
#: writes them); a longer one is not read: evaluating thousands of nested brackets or signs
#: exhausts the parser's memory or recursion
MAX_OVERRIDE = 1000
#: the comment line :meth:`Scene.with_overrides` writes for each key it sets
_OVERRIDE = re.compile(
    r"# override: integrator\.(t_end|dt|method|order|output_every|checkpoint_every|max_output) = (.+)"
)


def scene_overrides(text: str) -> dict:
    """The ``[integrator]`` values that :meth:`Scene.with_overrides` set on a scene, read back
    from the comments it writes into the scene's text (the last of each key wins).

    Parameters
    ----------
    text : str
        A scene's text, as a run file stores it.

    Returns
    -------
    dict
        {key: value}, as passed to :meth:`Scene.with_overrides`. A line whose value is not a
        Python literal, or longer than :data:`MAX_OVERRIDE` characters, is skipped.
    """
    import ast

    found = {}
    for line in text.splitlines():
        m = _OVERRIDE.fullmatch(line.strip())
        if m and len(m.group(2)) <= MAX_OVERRIDE:  # longer: not one that with_overrides wrote
            try:
                found[m.group(1)] = ast.literal_eval(m.group(2))
            except (ValueError, SyntaxError, MemoryError, RecursionError):
                continue
    return found


def _add_effects(sim: Simulation, tables, folder: str) -> None:
    """The scene's [[effect]] tables, added before its bodies (mutual gravity lets point masses
    move in free space; the names of bodies they give are checked once the bodies are there),
    a relative ``file`` found in the scene's folder."""
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise InputError("effect", f"[[effect]] tables expected, got {tables!r}")
    for i, table in enumerate(tables):
        keys = {k: v for k, v in table.items() if k != "kind"}
        sim.add_effect(table.get("kind"), key=f"effect[{i}]", strict=True, folder=folder, **keys)


def _add_events(sim: Simulation, tables) -> None:
    """The scene's [[event]] tables (their bodies are checked when the run starts)."""
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise InputError("event", f"[[event]] tables expected, got {tables!r}")
    for i, table in enumerate(tables):
        _check_keys(table, "event", f"event[{i}]")
        keys = {k: v for k, v in table.items() if k != "kind"}
        sim.add_event(table.get("kind"), key=f"event[{i}]", strict=True, **keys)


def _check_couplings(sim: Simulation, couplings: list) -> None:
    """Lay out a copy of the structure, so that an attached node that does not move with the
    point it rides on is an error naming its [[coupling]] table, before anything runs."""
    if sim.structure is None or not couplings:
        return
    try:
        copy.deepcopy(sim.structure).build()
    except InputError as exc:  # the structure names a coupling by its bodies
        pair = re.fullmatch(r"coupling \((.*) -> (.*)\)", exc.key)
        for i, cpl in enumerate(couplings):
            if pair and (cpl["elastic"], cpl["to"]) == pair.groups():
                raise InputError(f"coupling[{i}]", exc.message) from None
        raise


def _placement(body: dict) -> dict:
    """The keys of a body table that place it: position, velocity and orbit (None where absent)."""
    return {k: body.get(k) for k in ("position", "velocity", "orbit")}


def parse_scene(text: str, source: str = "<string>", check: bool = True) -> Scene:
    """Parse and check a scene from TOML text.

    Parameters
    ----------
    text : str
        The TOML text.
    source : str
        Where it came from (named in errors; a file's path also locates mesh files).
    check : bool
        Check it now (:meth:`Scene.check`); False leaves that to :meth:`Scene.build`.

    Returns
    -------
    Scene
        The scene, checked where ``check``.

    Raises
    ------
    InputError
        For text that is not TOML and for every wrong key or value.
    """
    data = load_toml(text, source)
    scene = Scene(data, text, source)
    if check:
        scene.check()
    return scene


def _shipped():
    return importlib.resources.files("emorbit") / "scenes"


def list_scenes() -> list[str]:
    """The names of the scenes shipped with emorbit, sorted.

    Returns
    -------
    list of str
        Names that :func:`load_scene` takes.
    """
    return sorted(p.name[:-5] for p in _shipped().iterdir() if p.name.endswith(".toml"))


def read_text(path: str, what: str) -> str:
    """The UTF-8 text of the file ``path``.

    Parameters
    ----------
    path : str
        The file.
    what : str
        What the file is (``"scene"``, ``"sweep"``), named in the error.

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    InputError
        If the file is not UTF-8 text.
    """
    with open(path, "rb") as fh:
        raw = fh.read()
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(path, f"a {what} file must be UTF-8 text") from None


def load_scene(name_or_path, check: bool = True) -> Scene:
    """Load and check a shipped scene by name or a TOML file by path.

    Parameters
    ----------
    name_or_path : str or os.PathLike
        A file, or the name of a shipped scene (see :func:`list_scenes`).
    check : bool
        Check it now (:meth:`Scene.check`); False leaves that to :meth:`Scene.build`.

    Returns
    -------
    Scene
        The scene, checked where ``check``.

    Raises
    ------
    InputError
        If it is neither a file nor a shipped scene, or the scene is wrong.
    """
    path = os.fspath(name_or_path)
    if os.path.isfile(path):
        return parse_scene(read_text(path, "scene"), path, check)
    shipped = _shipped() / f"{path}.toml"
    if shipped.is_file():
        return parse_scene(shipped.read_text(encoding="utf-8"), path, check)
    raise InputError("scene", f"{path!r} is neither a file nor a shipped scene; shipped: {', '.join(list_scenes())}")
