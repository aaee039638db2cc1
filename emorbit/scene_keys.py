"""Every key of every scene table: :data:`KEYS`, with its unit, default, allowed values and
meaning, and :data:`SCHEMA` derived from it (which keys each table allows and requires).

The parser (:mod:`emorbit.scene`) checks scenes against them and the scenes page of the
documentation is generated from them (``scripts/docs_scene_keys.py``). The keys an effect
attaches to bodies (drag's ``ballistic_coefficient``) come from the effects' declarations
(:attr:`emorbit.effects.base.Effect.BODY_KEYS`), so no key of an effect is written here.
"""

from __future__ import annotations

from .bodies.facets import FACET_KEYS
from .effects import EFFECTS, effect_kinds
from .events import KINDS as _EVENT_KINDS
from .field import BODIES
from .integrators import METHODS, ORDERS, ROUNDOFF, TFE_ORDERS
from .integrators.plan import MAX_NEWTON_ITERATIONS
from .keys import Key
from .simulation import MAX_OUTPUT

__all__ = ["KEYS", "SCHEMA", "BODY_KINDS", "COUPLING_KINDS", "SIMULATION_ARGUMENTS", "RIGID_COMMON", "ELASTIC_COMMON"]


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

EVENT_KINDS = tuple(_EVENT_KINDS)

#: Every key of every scene table, in the order the parser lists them: ``""`` is the top
#: level, ``"body.<kind>"`` a ``[[body]]`` table of that kind.
KEYS: dict[str, tuple[Key, ...]] = {
    "": (
        Key("field", False, "table", "free space (no gravity)", "a [field] table", "the central field"),
        Key("integrator", True, "table", "", "an [integrator] table", "the method, the step and the run's length"),
        Key("body", True, "array of tables", "", "one or more [[body]] tables", "the bodies"),
        Key("coupling", False, "array of tables", "none", "[[coupling]] tables",
            "nodes of elastic bodies attached to other bodies"),
        Key("event", False, "array of tables", "none: the run ends at t_end", "[[event]] tables",
            "zero crossings found after every step, located to round-off in time, logged, or ending the run"),
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
            "a named central body: GM, radius and rate from astropy.constants (earth, sun, jupiter) "
            "or pyshtools (moon, mars; the bodies extra)"),
        Key("center", False, _LENGTHS, '["0 m", "0 m", "0 m"]', _ANY, "the central mass's position"),
        Key("radius", False, _LENGTH, "a named body's nominal equatorial radius, else 0", ">= 0",
            "a body recorded closer to the centre than this stops the run with an error"),
    ),
    "integrator": (
        Key("method", False, "string", '"em"', _choices(METHODS), "the integration method"),
        Key("order", False, "integer", "2", _choices(sorted(set(ORDERS) | set(TFE_ORDERS))),
            "2 is the base step; 4, 6, 8 symmetric compositions of it; tfe runs at 4 to 12 in one solve"),
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
        Key("drift_tolerance", False, "number", "20", "> 0 (inf: no check)",
            "C of the drift bound C eps sqrt(n): a conserved invariant that drifts further from the first "
            "record, in units of its round-off scale, makes the run warn (exit 3 with emorbit run --strict)"),
        Key("epoch", False, "date and time", "none", '"2000-01-01T12:00:00 TDB" (scales TDB, TT, TAI, UTC, ...)',
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
    "event": (
        Key("kind", True, "string", "", _choices(EVENT_KINDS),
            "what crosses zero: |x - c| - value, the altitude above the field's radius less value, (x - c) . v, "
            "the z coordinate of x - c, t - value, the distance to other less value, or the edge of the "
            "central body's shadow (shadow)"),
        Key("body", False, "string", "", "the name of a body; not for time",
            "the body whose state it reads (a rigid or elastic body's centre of mass)"),
        Key("value", False, "length (m), or time (s) for time", "", "finite; radius, altitude, distance and time only",
            "the level"),
        Key("direction", False, "string", "the kind's: rising for periapsis and time, falling for apoapsis, else "
            "either", _choices(("rising", "falling", "either")), "the crossings that count"),
        Key("stop", False, "boolean", "false", "true or false", "end the run at the event (status stopped)"),
        Key("other", False, "string", "", "the name of a body; distance only", "the second body"),
        Key("label", False, "string", '"<kind>[<i>]"', "a name without /", "its name in the log"),
        Key("dv", False, "3 speeds (m / s)", "", "finite; not with stop",
            "an impulse added to the body's velocity at the event, once; its work is kept in the energy balance"),
        Key("frame", False, "string", '"inertial"', _choices(("inertial", "rsw", "vnc")) + "; with dv",
            "the axes of dv: the scene's; radial, along-track, normal; velocity, normal, their cross product"),
        Key("after", False, "string", "", "the label of an event before this one",
            "the event counts only once that one has happened"),
        Key("sun", False, "3 numbers", "the Sun of astropy's builtin ephemeris (needs the epoch)",
            "a direction other than 0; eclipse only", "the direction to the Sun, in the scene's axes"),
        Key("shadow", False, "string", '"cylindrical"', _choices(("cylindrical", "penumbra", "umbra")) +
            "; eclipse only", "the shadow's edge: cylindrical, or the conical shadow's penumbra or umbra"),
    ),
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
SIMULATION_ARGUMENTS = ("method", "order", "adaptive", "newton", "roundoff", "max_newton_iterations")
SIMULATION_ARGUMENTS += ("checkpoint_every", "epoch")
#: the keys of a rigid or elastic body that are not parameters of its shape or mesh
RIGID_COMMON = tuple(k.name for k in KEYS["body.rigid"] if not k.applies)
ELASTIC_COMMON = tuple(k.name for k in KEYS["body.elastic"] if not k.applies)
