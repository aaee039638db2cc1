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

from .bodies.facets import FACET_KEYS
from .effects import EFFECTS, effect_kinds
from .errors import InputError
from .field import BODIES, CentralField
from .integrators import METHODS, ORDERS, ROUNDOFF
from .integrators.plan import MAX_NEWTON_ITERATIONS
from .io.drift import check_tolerance
from .io.scene_toml import MAX_DEPTH, load_toml, simulation_to_toml
from .keys import Key
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


#: the kinds of [[body]] and [[coupling]] tables
BODY_KINDS = ("point", "rigid", "elastic")
COUPLING_KINDS = ("attach",)
_RIGID_SHAPES = ("box", "cylinder", "sphere", "ellipsoid", "shell", "dumbbell", "mesh")
_ELASTIC_MESHES = ("beam", "chain", "net", "file")


def _choices(values) -> str:
    return ", ".join(f'"{v}"' if isinstance(v, str) else str(v) for v in values)


# One key per entry: Key(name, required, value, default, allowed, meaning[, applies]).
# fmt: off
_V, _ANY, _REQ = "3 strings with units", "3 finite values", " (required)"
_LENGTH, _LENGTHS = "length (m)", f"length (m), {_V}"
_IDENTITY = (
    Key("name", True, "string", "", "unique in the scene, not empty, no '/' and no control characters",
        "the body's name (its HDF5 group)"),
    Key("kind", True, "string", "", _choices(BODY_KINDS), "the kind of body"),
)


def _motion(position: str, velocity: str, orbit: str) -> tuple[Key, ...]:
    """The position, velocity and orbit keys of a body; the arguments say what they place."""
    either = "; give position and velocity, or orbit"
    return (Key("position", False, _LENGTHS, "", _ANY, position + either),
            Key("velocity", False, f"speed (m / s), {_V}", "", _ANY, velocity + either),
            Key("orbit", False, "table", "", "an orbit table (see below)",
                f"the osculating elements of {orbit} about the field's centre, instead of position and velocity"))


_ATTITUDE = (
    Key("attitude", False, "4 numbers", "[1, 0, 0, 0]", "a unit quaternion (w, x, y, z)",
        "the rotation from body axes to space axes; not together with rotation_vector"),
    Key("rotation_vector", False, f"angle (rad), {_V}", "no rotation", _ANY,
        "the attitude as angle times axis; not together with attitude"),
    Key("angular_velocity", False, f"angular speed (rad / s), {_V}", '["0 rad/s", "0 rad/s", "0 rad/s"]', _ANY,
        "the initial angular velocity of the body frame"),
    Key("angular_velocity_frame", False, "string", '"body"', _choices(("body", "space")),
        "the frame angular_velocity is written in"),
)
_GRAVITY_DEFAULT = '"volume" with a [field], else "none"'

#: Every key of every scene table, in the order the parser lists them: ``""`` is the top
#: level, ``"body.<kind>"`` a ``[[body]]`` table of that kind.
KEYS: dict[str, tuple[Key, ...]] = {
    "": (
        Key("field", False, "table", "free space (no gravity)", "a [field] table", "the central field"),
        Key("integrator", True, "table", "", "an [integrator] table", "the method, the step and the run's length"),
        Key("body", True, "array of tables", "", "one or more [[body]] tables", "the bodies"),
        Key("coupling", False, "array of tables", "none", "[[coupling]] tables",
            "nodes of elastic bodies attached to other bodies"),
        Key("effect", False, "array of tables", "none: the central field alone", "[[effect]] tables",
            "effects beyond the central field (docs/effects.md)"),
    ),
    "field": (
        Key("gm", False, "gravitational parameter (m3 / s2)", "", "> 0",
            "GM of the central mass; give exactly one of gm, g_ref with r_ref, or body"),
        Key("g_ref", False, "acceleration (m / s2)", "", "> 0",
            "the acceleration at distance r_ref: GM = g_ref r_ref^2 (needs r_ref)"),
        Key("r_ref", False, _LENGTH, "", "> 0", "the distance at which the acceleration is g_ref (needs g_ref)"),
        Key("body", False, "string", "", _choices(sorted(BODIES)) + " (any case)",
            "a named central body: GM from astropy.constants (IAU 2015 nominal values)"),
        Key("center", False, _LENGTHS, '["0 m", "0 m", "0 m"]', _ANY, "the central mass's position"),
        Key("radius", False, _LENGTH, "a named body's nominal equatorial radius, else 0", ">= 0",
            "a body recorded closer to the centre than this stops the run with an error"),
    ),
    "integrator": (
        Key("method", False, "string", '"em"', _choices(METHODS), "the integration method"),
        Key("order", False, "integer", "2", _choices(ORDERS),
            "2 is the base step; 4, 6, 8 symmetric compositions of it"),
        Key("dt", True, "time (s)", "", "> 0", "the step (with adaptive: the unit of the record grid)"),
        Key("t_end", True, "time (s)", "", "> 0, at least one step",
            "the end time, rounded up to a whole step unless within 1e-9 (relative) of one"),
        Key("output_every", False, "integer", "1", ">= 1", "steps between records"),
        Key("max_newton_iterations", False, "integer", "50", f"1 to {MAX_NEWTON_ITERATIONS:,}",
            "Newton iterations per implicit sub-step"),
        Key("newton", False, "string", '"auto"', _choices(("auto", "reuse", "full")),
            'elastic structures: refactor the Jacobian every iteration ("full"), keep the factors while they '
            'converge fast ("reuse"), or choose by size ("auto")'),
        Key("checkpoint_every", False, "integer", "by wall time: at most 5 s between checkpoints", ">= 1",
            "steps between checkpoints, rounded up to a multiple of output_every"),
        Key("adaptive", False, "number", "off (fixed steps of dt)", "in (0, 1]",
            "the accuracy knob eta of adaptive, time-symmetric steps of about eta times the fastest time scale: "
            "the local Kepler time 2 pi sqrt(r^3 / GM), and for bodies their rotation and highest elastic "
            "frequency; records land on multiples of output_every dt; central field and bodies only (no effects)"),
        Key("roundoff", False, "string", '"brouwer"', _choices(ROUNDOFF),
            'em steps of point masses: "brouwer" keeps the energy error a random walk; "fast" is cheaper and '
            "drifts at round-off level (point masses in the central field alone; refused elsewhere)"),
        Key("energy_range", False, "boolean or string", '"auto"', '"auto", true, false',
            "record the least and greatest total energy over the steps between records "
            '(invariants/energy_range), so decimated records cannot alias the energy error; "auto": for methods '
            "that do not conserve energy, when output_every > 1"),
        Key("drift_tolerance", False, "number", "1000", "> 0 (inf: no check)",
            "C of the drift bound C eps sqrt(n): a conserved invariant that drifts further from the first "
            "record, in units of its round-off scale, makes the run warn (exit 3 with emorbit run --strict)"),
        Key("epoch", False, "date and time", "none", '"2026-01-01T00:00:00 TDB" (scales TDB, TT, TAI, UTC, ...)',
            "the instant time 0 stands for; required by srp and by third bodies from an ephemeris"),
        Key("max_output", False, "information (B)", f'"{MAX_OUTPUT}"', "> 0",
            "the largest output the run may project (its records, nodal positions included, in the file and in "
            "memory); a longer run is refused before anything is created"),
    ),
    "body.point": (
        *_IDENTITY,
        Key("mass", True, "mass (kg)", "", "> 0", "the point's mass"),
        *_motion("the point's position", "the point's velocity", "the point"),
    ),
    "body.rigid": (
        *_IDENTITY,
        Key("shape", True, "string", "", _choices(_RIGID_SHAPES), "the shape, discretised into mass points"),
        *_motion("the centre of mass", "the centre of mass's velocity", "the centre of mass"),
        *_ATTITUDE,
        Key("gravity", False, "string", _GRAVITY_DEFAULT, _choices(("volume", "point", "none")),
            '"volume": summed over the mass points (gravity-gradient torque); "point": all mass at the centre '
            'of mass; "none": free motion'),
        Key("facets", False, "string", '"shape"', '"shape", "none"',
            "the flat facets drag and radiation pressure act on: the shape's surface, or only [[body.facet]] tables"),
        Key("facet", False, "array of tables", "none", "[[body.facet]] tables (see below)",
            "more facets, e.g. solar panels or a fin: center, normal, area, two_sided, coefficients"),
        Key("drag_coefficient", False, "number", "2.2", ">= 0",
            "Cd of the shape's facets, and the facet tables' default"),
        Key("specular", False, "number", "0", "in [0, 1]; specular + diffuse <= 1",
            "the specular reflectivity of the shape's facets, and the facet tables' default"),
        Key("diffuse", False, "number", "0", "in [0, 1]",
            "the diffuse reflectivity of the shape's facets, and the facet tables' default"),
        Key("size", False, _LENGTHS, "", "> 0", "the edge lengths along the body axes" + _REQ, ("box",)),
        Key("radius", False, _LENGTH, "", "> 0", "the radius" + _REQ, ("cylinder", "sphere", "shell")),
        Key("semi_axes", False, _LENGTHS, "", "> 0", "the semi-axes along the body axes" + _REQ, ("ellipsoid",)),
        Key("height", False, _LENGTH, "", "> 0", "the length along the body's z axis" + _REQ, ("cylinder",)),
        Key("masses", False, "mass (kg), 2 strings with units", "", "> 0", "the masses of the two ends" + _REQ,
            ("dumbbell",)),
        Key("length", False, _LENGTH, "", "> 0", "the distance between the two ends, along x" + _REQ, ("dumbbell",)),
        Key("end_radius", False, _LENGTH, "length / 20", "in (0, length / 2)",
            "the radius of each end, a small solid sphere", ("dumbbell",)),
        Key("density", False, "density (kg / m3)", "", "> 0",
            "the density; box, cylinder, sphere, ellipsoid: give density or mass; mesh: required",
            ("box", "cylinder", "sphere", "ellipsoid", "mesh")),
        Key("mass", False, "mass (kg)", "", "> 0",
            "the total mass; box, cylinder, sphere, ellipsoid: give density or mass; shell: required",
            ("box", "cylinder", "sphere", "ellipsoid", "shell")),
        Key("refinement", False, "integer", "1", ">= 1",
            "elements per edge (more mass points: a better gravity integral, the same inertia)",
            ("box", "cylinder", "sphere", "ellipsoid", "shell", "dumbbell")),
        Key("nodes", False, "numbers in mesh_unit", "", "n >= 4 rows [x, y, z]", "the mesh's nodes" + _REQ, ("mesh",)),
        Key("tetrahedra", False, "integers", "", "rows [i, j, k, l] of 0-based node indices, positive volume",
            "the mesh's 4-node tetrahedra" + _REQ, ("mesh",)),
        Key("mesh_unit", False, "a length unit", "", 'e.g. "m", "mm"', "the unit of nodes" + _REQ, ("mesh",)),
    ),
    "body.elastic": (
        *_IDENTITY,
        Key("mesh", True, "string", "", _choices(_ELASTIC_MESHES), "a generated mesh or a mesh file"),
        *_motion("where the mesh's origin goes", "the velocity of the body frame's origin", "the body frame's origin"),
        Key("young", True, "pressure (Pa)", "", "> 0", "Young's modulus (St. Venant-Kirchhoff material)"),
        Key("density", True, "density (kg / m3)", "", "> 0", "the mass density"),
        Key("poisson", False, "number", "", "in (-1, 0.5)", "Poisson's ratio; required with tetrahedra"),
        Key("area", False, "area (m2)", "", "> 0", "the cross-section of bars; required with bars"),
        Key("mass_matrix", False, "string", '"consistent"', _choices(("consistent", "lumped")), "the mass matrix"),
        *_ATTITUDE,
        Key("gravity", False, "string", _GRAVITY_DEFAULT, _choices(("volume", "none")),
            '"volume": the field at the elements\' quadrature points; "none": free motion'),
        Key("node_output_every", False, "integer", "1", ">= 1", "records between outputs of the nodal positions"),
        Key("drag_coefficient", False, "number", "2.2", ">= 0",
            "Cd of the surface triangles of its tetrahedra under drag (bars have no surface)"),
        Key("size", False, f"{_LENGTHS} (net: 2)", "", "> 0",
            "beam: a box (Lx, Ly, Lz); net: a rectangle (Lx, Ly) in the x-y plane; centred on the origin" + _REQ,
            ("beam", "net")),
        Key("elements", False, "integers", "", ">= 1",
            "beam: cells (nx, ny, nz), 6 tetrahedra each; chain: the number of bars; net: cells (nx, ny)" + _REQ,
            ("beam", "chain", "net")),
        Key("start", False, _LENGTHS, "", _ANY, "the chain's first node" + _REQ, ("chain",)),
        Key("end", False, _LENGTHS, "", _ANY, "the chain's last node" + _REQ, ("chain",)),
        Key("file", False, "string", "", "a path, relative to the scene file",
            "an HDF5 mesh (/nodes, /tetrahedra, /bars) or any file meshio reads" + _REQ, ("file",)),
        Key("mesh_unit", False, "a length unit", "the unit attribute of an HDF5 file's /nodes", 'e.g. "m", "mm"',
            "the unit of the file's coordinates: required for a meshio file and for an HDF5 file whose /nodes has "
            "no unit attribute; where both are given they must agree", ("file",)),
    ),
    "orbit": (
        Key("a", False, _LENGTH, "", "> 0 with e < 1, < 0 with e > 1",
            "the semi-major axis; give exactly one of a, periapsis_radius and periapsis_altitude"),
        Key("e", False, "number", "0 with a", ">= 0",
            "the eccentricity; with a periapsis give e or an apoapsis (e = 1: a parabola, with a periapsis)"),
        Key("periapsis_radius", False, _LENGTH, "", "> 0", "the periapsis's distance from the centre, instead of a"),
        Key("apoapsis_radius", False, _LENGTH, "", ">= the periapsis",
            "the apoapsis's distance from the centre: with a periapsis, instead of e"),
        Key("periapsis_altitude", False, _LENGTH, "", "> -radius",
            "the periapsis's height above the field's radius, instead of a (needs a radius: a named body or "
            "[field] radius)"),
        Key("apoapsis_altitude", False, _LENGTH, "", ">= the periapsis",
            "the apoapsis's height above the field's radius: with a periapsis, instead of e"),
        Key("i", False, "angle (rad)", '"0 deg"', "in [0 deg, 180 deg]", "the inclination to the x-y plane"),
        Key("raan", False, "angle (rad)", '"0 deg"', "any", "the longitude of the ascending node, from the x axis"),
        Key("argp", False, "angle (rad)", '"0 deg"', "any", "the argument of periapsis, from the ascending node"),
        Key("nu", False, "angle (rad)", '"0 deg" (the periapsis)', "any; an open orbit: between its asymptotes",
            "the true anomaly; not with mean_anomaly"),
        Key("mean_anomaly", False, "angle (rad)", "", "any; not for e = 1",
            "the mean anomaly (Kepler's equation gives the true anomaly); not with nu"),
    ),
    "facet": FACET_KEYS,
    "coupling": (
        Key("kind", True, "string", "", _choices(COUPLING_KINDS), "the kind of coupling"),
        Key("elastic", True, "string", "", "the name of an elastic body", "the body whose nodes are attached"),
        Key("nodes", True, "integers or a string", "",
            'a list of node indices, "first", "last", or "<axis>-min" / "<axis>-max" with axis x, y or z',
            "the nodes (selectors: faces of the reference mesh)"),
        Key("to", True, "string", "", "the name of a rigid body or point mass",
            "a node rides on the rigid body's material point, or is the point mass"),
    ),
}
# fmt: on
for _kind in effect_kinds():
    KEYS[f"effect.{_kind}"] = (
        Key("kind", True, "string", "", _choices(effect_kinds()), "the effect"),
        *EFFECTS[_kind].KEYS,
    )
for _body in BODY_KINDS:  # the keys the shipped effects attach to bodies (drag's ballistic_coefficient)
    KEYS[f"body.{_body}"] += tuple(
        dict.fromkeys(bk.key for cls in EFFECTS.values() for bk in cls.BODY_KEYS if _body in bk.kinds)
    )

#: allowed keys per table: {table: {key: required?}}, derived from :data:`KEYS`
SCHEMA: dict[str, dict[str, bool]] = {table: {k.name: k.required for k in keys} for table, keys in KEYS.items()}
#: [integrator] keys that :class:`Simulation` names as its arguments in errors
_SIMULATION_ARGUMENTS = ("method", "order", "adaptive", "newton", "roundoff", "max_newton_iterations")
_SIMULATION_ARGUMENTS += ("checkpoint_every", "epoch")
#: the keys of a rigid or elastic body that are not parameters of its shape or mesh
_RIGID_COMMON = tuple(k.name for k in KEYS["body.rigid"] if not k.applies)
_ELASTIC_COMMON = tuple(k.name for k in KEYS["body.elastic"] if not k.applies)


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
            if exc.key in _SIMULATION_ARGUMENTS:  # named by the Simulation as its argument
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
                mesh_params = {k: v for k, v in b.items() if k not in _ELASTIC_COMMON}
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
                shape_params = {k: v for k, v in b.items() if k not in _RIGID_COMMON}
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
