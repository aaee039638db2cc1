"""Scenes: a TOML file that says which field, method and bodies a run has.

::

    [field]
    gm = "3.9478 m3 / s2"          # or: g_ref = "0.039478 m / s2" and r_ref = "10 m"; or: body = "earth"
    center = ["0 m", "0 m", "0 m"] # optional, default: the origin
    radius = "6378.1 km"           # optional collision radius (default: a named body's radius, else 0)
    [integrator]
    method = "em"                  # em | midpoint | leapfrog        (default em)
    order = 2                      # 2 | 4 | 6 | 8                   (default 2)
    dt = "0.464758 s"
    t_end = "4647.58 s"
    output_every = 10              # steps between records           (default 1)
    checkpoint_every = 1000        # steps between checkpoints       (default ~0.5 s of work)
    adaptive = 0.01                # point masses: step = 0.01 of the local Kepler time, <= dt (default: off)
    roundoff = "brouwer"           # em, point masses: "brouwer" (energy error a random walk) | "fast"
    max_newton_iterations = 50     # per implicit sub-step           (default 50)
    [[body]]
    name = "satellite"
    kind = "point"
    mass = "1 kg"
    position = ["10 m", "0 m", "0 m"]
    velocity = ["0 m/s", "0.36276 m/s", "0 m/s"]

Every dimensional value is a string with a unit (anything astropy reads: "1 km", "1 d",
"3.9478 m3 / s2"). Unknown keys, missing keys, wrong units and bad values are errors
naming the key, raised before anything runs. Shipped scenes are found by name
(:func:`list_scenes`).
"""

from __future__ import annotations

import copy
import importlib.resources
import numbers
import os
import sys
from dataclasses import dataclass

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

import numpy as np

from .errors import InputError
from .field import CentralField
from .integrators import check_order, check_roundoff, get_method
from .io.scene_toml import simulation_to_toml
from .simulation import Simulation, check_body_name
from .units import to_si

__all__ = ["Scene", "load_scene", "list_scenes", "parse_scene", "simulation_to_toml", "SCHEMA"]

#: allowed keys per table; values: required?
SCHEMA = {
    "": {"field": False, "integrator": True, "body": True, "coupling": False},
    "field": {"gm": False, "g_ref": False, "r_ref": False, "body": False, "center": False, "radius": False},
    "integrator": {
        "method": False,
        "order": False,
        "dt": True,
        "t_end": True,
        "output_every": False,
        "max_newton_iterations": False,
        "newton": False,
        "checkpoint_every": False,
        "adaptive": False,
        "roundoff": False,
    },
    "body.point": {"name": True, "kind": True, "mass": True, "position": True, "velocity": True},
    "body.rigid": {
        "name": True,
        "kind": True,
        "shape": True,
        "position": True,
        "velocity": True,
        "attitude": False,
        "rotation_vector": False,
        "angular_velocity": False,
        "angular_velocity_frame": False,
        "gravity": False,
        # shape parameters (which apply depends on the shape; see emorbit.bodies.rigid.SHAPE_PARAMETERS)
        "size": False,
        "radius": False,
        "height": False,
        "masses": False,
        "length": False,
        "end_radius": False,
        "density": False,
        "mass": False,
        "refinement": False,
        "nodes": False,
        "tetrahedra": False,
        "mesh_unit": False,
    },
    "body.elastic": {
        "name": True,
        "kind": True,
        "mesh": True,
        "position": True,
        "velocity": True,
        "young": True,
        "density": True,
        "poisson": False,
        "area": False,
        "mass_matrix": False,
        "attitude": False,
        "rotation_vector": False,
        "angular_velocity": False,
        "angular_velocity_frame": False,
        "gravity": False,
        "node_output_every": False,
        # mesh parameters (which apply depends on the mesh)
        "size": False,
        "elements": False,
        "start": False,
        "end": False,
        "file": False,
        "mesh_unit": False,
    },
    "coupling": {"kind": True, "elastic": True, "nodes": True, "to": True},
}
BODY_KINDS = ("point", "rigid", "elastic")
COUPLING_KINDS = ("attach",)
_ELASTIC_COMMON = (
    "name",
    "kind",
    "mesh",
    "position",
    "velocity",
    "young",
    "density",
    "poisson",
    "area",
    "mass_matrix",
    "attitude",
    "rotation_vector",
    "angular_velocity",
    "angular_velocity_frame",
    "gravity",
    "node_output_every",
)
_RIGID_COMMON = (
    "name",
    "kind",
    "shape",
    "position",
    "velocity",
    "attitude",
    "rotation_vector",
    "angular_velocity",
    "angular_velocity_frame",
    "gravity",
)


def check_table(table, allowed: dict, where: str, root: str = "scene") -> dict:
    """``table`` itself, after checking that it is a table with only the keys of ``allowed``
    ({key: required?}) and every required one; errors name ``where.key`` (``root`` for a
    top-level table that is not one). Shared by scenes and sweep files."""
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
    check_table(table, SCHEMA[schema_name], where)


def _int(value, key: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise InputError(key, f"must be an integer >= {minimum}, got {value!r}")
    return int(value)


@dataclass
class Scene:
    """A checked scene. Values are kept as given (strings with units) and converted to SI
    by :meth:`build`; ``text`` is the TOML it came from (stored in output files)."""

    data: dict
    text: str
    source: str = "<string>"

    # -- the integrator settings, in SI ---------------------------------------------------
    @property
    def method(self) -> str:
        return self.data["integrator"].get("method", "em")

    @property
    def order(self) -> int:
        return int(self.data["integrator"].get("order", 2))

    @property
    def dt(self) -> float:
        return to_si(self.data["integrator"]["dt"], "time", "integrator.dt", strict=True, positive=True)

    @property
    def t_end(self) -> float:
        return to_si(self.data["integrator"]["t_end"], "time", "integrator.t_end", strict=True, positive=True)

    @property
    def output_every(self) -> int:
        return int(self.data["integrator"].get("output_every", 1))

    @property
    def checkpoint_every(self) -> int | None:
        """Steps between checkpoints, or None for the default (see Simulation.run)."""
        value = self.data["integrator"].get("checkpoint_every")
        return None if value is None else int(value)

    def with_overrides(
        self, *, t_end=None, dt=None, method=None, order=None, output_every=None, checkpoint_every=None
    ) -> Scene:
        """A copy with integrator settings replaced (values as in the TOML: strings with units),
        checked again; ``text`` gains a comment saying what was overridden."""
        data = copy.deepcopy(self.data)
        changed = {}
        for key, value in (
            ("t_end", t_end),
            ("dt", dt),
            ("method", method),
            ("order", order),
            ("output_every", output_every),
            ("checkpoint_every", checkpoint_every),
        ):
            if value is not None:
                data["integrator"][key] = value
                changed[key] = value
        note = "".join(f"# override: integrator.{k} = {v!r}\n" for k, v in changed.items())
        scene = Scene(data, note + self.text, self.source)
        scene.check()
        return scene

    def check(self) -> None:
        """Validate everything (raises :class:`InputError`); building a simulation does too."""
        self.build()

    def build(self) -> Simulation:
        """A :class:`Simulation` with this scene's field, method and bodies."""
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
        get_method(integ.get("method", "em"), "integrator.method")
        check_order(integ.get("order", 2), "integrator.order")
        _int(integ.get("output_every", 1), "integrator.output_every", 1)
        if "checkpoint_every" in integ:
            _int(integ["checkpoint_every"], "integrator.checkpoint_every", 1)
        max_iter = _int(integ.get("max_newton_iterations", 50), "integrator.max_newton_iterations", 1)
        dt = self.dt
        t_end = self.t_end
        newton = integ.get("newton", "auto")
        if newton not in ("auto", "reuse", "full"):
            raise InputError("integrator.newton", f"must be 'auto', 'reuse' or 'full', got {newton!r}")
        adaptive = integ.get("adaptive")
        if adaptive is not None and (isinstance(adaptive, bool) or not isinstance(adaptive, (int, float))):
            raise InputError("integrator.adaptive", f"a number in (0, 1] expected, got {adaptive!r}")
        roundoff = check_roundoff(integ.get("roundoff", "brouwer"), "integrator.roundoff")
        sim = Simulation(
            field,
            method=self.method,
            order=self.order,
            dt=dt,
            max_newton_iterations=max_iter,
            newton=newton,
            adaptive=adaptive,
            roundoff=roundoff,
        )
        bodies = d["body"]
        if not isinstance(bodies, list) or not bodies:
            raise InputError("body", "a scene needs at least one [[body]] table")
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
                    b["name"], mass=b["mass"], position=b["position"], velocity=b["velocity"], strict=True, key=where
                )
            elif kind == "elastic":
                mesh_params = {k: v for k, v in b.items() if k not in _ELASTIC_COMMON}
                if "file" in mesh_params and self.source not in ("<string>",) and os.path.isfile(self.source):
                    mesh_params["file"] = os.path.join(
                        os.path.dirname(os.path.abspath(self.source)), mesh_params["file"]
                    )
                sim.add_elastic(
                    b["name"],
                    b["mesh"],
                    position=b["position"],
                    velocity=b["velocity"],
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
                    strict=True,
                    key=where,
                    **mesh_params,
                )
            else:
                shape_params = {k: v for k, v in b.items() if k not in _RIGID_COMMON}
                sim.add_rigid(
                    b["name"],
                    b["shape"],
                    position=b["position"],
                    velocity=b["velocity"],
                    attitude=b.get("attitude"),
                    rotation_vector=b.get("rotation_vector"),
                    angular_velocity=b.get("angular_velocity", ["0 rad/s", "0 rad/s", "0 rad/s"]),
                    angular_velocity_frame=b.get("angular_velocity_frame", "body"),
                    gravity=b.get("gravity"),
                    strict=True,
                    key=where,
                    **shape_params,
                )
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
            sim.attach(
                cpl["elastic"], _select_nodes(sim, cpl["elastic"], cpl["nodes"], f"{where}.nodes"), cpl["to"], key=where
            )
        sim.steps_until(t_end)  # t_end must lie at least one step ahead
        sim.scene_text = self.text
        sim.t_end_requested = t_end
        return sim


def _select_nodes(sim: Simulation, elastic: str, nodes, key: str) -> list[int]:
    """Node indices from a list, or a selector: "first", "last" (chains), "<axis>-min" or
    "<axis>-max" (the nodes on that face of the reference mesh, axis x, y or z)."""
    if not isinstance(nodes, str):
        return nodes
    st = sim.structure
    if st is None or elastic not in st.names:
        raise InputError(key, f"no elastic body named {elastic!r} to select nodes from")
    ref = st._body(elastic)["spec"].ref
    if nodes == "first":
        return [0]
    if nodes == "last":
        return [ref.shape[0] - 1]
    axes = {"x": 0, "y": 1, "z": 2}
    parts = nodes.split("-")
    if len(parts) == 2 and parts[0] in axes and parts[1] in ("min", "max"):
        col = ref[:, axes[parts[0]]]
        target = col.min() if parts[1] == "min" else col.max()
        tol = 1e-9 * max(float(np.ptp(ref, axis=0).max()), 1e-300)
        return np.flatnonzero(np.abs(col - target) <= tol).tolist()
    raise InputError(
        key,
        f"unknown node selector {nodes!r}; use a list of indices, 'first', 'last', "
        "or '<axis>-min' / '<axis>-max' with axis x, y or z",
    )


def parse_scene(text: str, source: str = "<string>") -> Scene:
    """Parse and check a scene from TOML text."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, f"not valid TOML: {exc}") from None
    scene = Scene(data, text, source)
    scene.check()
    return scene


def _shipped():
    return importlib.resources.files("emorbit") / "scenes"


def list_scenes() -> list[str]:
    """Names of the scenes shipped with emorbit."""
    return sorted(p.name[:-5] for p in _shipped().iterdir() if p.name.endswith(".toml"))


def read_text(path: str, what: str) -> str:
    """The UTF-8 text of the file ``path``, or an error naming it (``what``: "scene",
    "sweep")."""
    with open(path, "rb") as fh:
        raw = fh.read()
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(path, f"a {what} file must be UTF-8 text") from None


def load_scene(name_or_path) -> Scene:
    """A shipped scene by name (see :func:`list_scenes`) or a TOML file by path."""
    path = os.fspath(name_or_path)
    if os.path.isfile(path):
        return parse_scene(read_text(path, "scene"), path)
    shipped = _shipped() / f"{path}.toml"
    if shipped.is_file():
        return parse_scene(shipped.read_text(encoding="utf-8"), path)
    raise InputError("scene", f"{path!r} is neither a file nor a shipped scene; shipped: {', '.join(list_scenes())}")
