"""A rigid body from user input: :func:`build_rigid` checks a shape and its parameters, the
initial state, the attitude and the gravity model, and converts them to SI.

A shape (:data:`SHAPE_PARAMETERS`: box, cylinder, sphere, ellipsoid, shell, dumbbell or a
tetrahedral mesh) is discretised into mass points by :mod:`emorbit.bodies.shapes`; the
attitude comes from a quaternion or a rotation vector, the angular velocity in the body or
the space frame (:func:`emorbit.bodies.rotations.attitude_matrix`). Errors name the key.
"""

from __future__ import annotations

import astropy.units as u

from ..errors import InputError
from ..units import to_si, vector_to_si
from . import shapes
from .rigid import GRAVITY_MODELS
from .rotations import attitude_matrix
from .shapes import MassPoints

__all__ = ["SHAPE_PARAMETERS", "build_rigid"]

#: shape -> {parameter: kind of value} ("length", "mass", "density", "masses", "lengths", "int",
#: "mesh", "unit"): the parameters a scene or :meth:`emorbit.Simulation.add_rigid` may give
SHAPE_PARAMETERS = {
    "box": {"size": "lengths", "density": "density", "mass": "mass", "refinement": "int"},
    "cylinder": {"radius": "length", "height": "length", "density": "density", "mass": "mass", "refinement": "int"},
    "sphere": {"radius": "length", "density": "density", "mass": "mass", "refinement": "int"},
    "ellipsoid": {"semi_axes": "lengths", "density": "density", "mass": "mass", "refinement": "int"},
    "shell": {"radius": "length", "mass": "mass", "refinement": "int"},
    "dumbbell": {"masses": "masses", "length": "length", "end_radius": "length", "refinement": "int"},
    "mesh": {"nodes": "mesh", "tetrahedra": "mesh", "mesh_unit": "unit", "density": "density"},
}


def _shape_points(shape: str, params: dict, strict: bool, key: str) -> MassPoints:

    if shape not in SHAPE_PARAMETERS:
        raise InputError(f"{key}.shape", f"unknown shape {shape!r}; known: {', '.join(SHAPE_PARAMETERS)}")
    allowed = SHAPE_PARAMETERS[shape]
    for p in params:
        if p not in allowed:
            raise InputError(f"{key}.{p}", f"not a parameter of shape {shape!r}; allowed: {', '.join(allowed)}")
    kw = {}
    for p, value in params.items():
        kind = allowed[p]
        where = f"{key}.{p}"
        if kind in ("length", "mass", "density"):
            kw[p] = to_si(value, kind, where, strict=strict, positive=True)
        elif kind == "lengths":
            kw[p] = vector_to_si(value, "length", where, strict=strict)
        elif kind == "masses":
            if isinstance(value, str) or not hasattr(value, "__len__") or len(value) != 2:
                raise InputError(where, f"expected two masses, got {value!r}")
            kw[p] = [to_si(x, "mass", f"{where}[{i}]", strict=strict, positive=True) for i, x in enumerate(value)]
        elif kind == "int":
            kw[p] = value
        elif kind == "unit":
            pass
        else:  # mesh arrays: numbers, nodes scaled by mesh_unit
            kw[p] = value
    if shape == "mesh":
        for need in ("nodes", "tetrahedra", "density"):
            if need not in params:
                raise InputError(f"{key}.{need}", "missing (required for a mesh)")
        nodes = params["nodes"]
        if isinstance(nodes, u.Quantity):  # the API: coordinates with their unit
            if "mesh_unit" in params:
                raise InputError(f"{key}.mesh_unit", "the nodes carry their unit; mesh_unit is for plain numbers")
            try:
                nodes = nodes.to_value(u.m)
            except u.UnitConversionError:
                raise InputError(f"{key}.nodes", f"coordinates in {nodes.unit}, not a length") from None
            scale = 1.0
        else:
            unit = params.get("mesh_unit", None if strict else "m")
            if unit is None:
                raise InputError(f"{key}.mesh_unit", "missing: give the unit of the node coordinates, e.g. 'm'")
            if not isinstance(unit, str):
                raise InputError(f"{key}.mesh_unit", f"a length unit (a string such as 'm') expected, got {unit!r}")
            scale = to_si(f"1 {unit}", "length", f"{key}.mesh_unit")
        nodes = shapes.mesh_coordinates(nodes, f"{key}.nodes") * scale
        tets = shapes.mesh_indices(params["tetrahedra"], 4, f"{key}.tetrahedra")
        kw.update(nodes=nodes, tetrahedra=tets)
        return shapes.tetra_mesh(nodes, tets, density=kw["density"], key=key), kw
    required = {
        "box": ("size",),
        "cylinder": ("radius", "height"),
        "sphere": ("radius",),
        "ellipsoid": ("semi_axes",),
        "shell": ("radius", "mass"),
        "dumbbell": ("masses", "length"),
    }[shape]
    for need in required:
        if need not in kw:
            raise InputError(f"{key}.{need}", f"missing (required for a {shape})")
    fn = shapes.SHAPES[shape]
    args = dict(kw)
    if shape == "box":
        return fn(args.pop("size"), key=key, **args), kw
    if shape == "ellipsoid":
        return fn(args.pop("semi_axes"), key=key, **args), kw
    if shape == "cylinder":
        return fn(args.pop("radius"), args.pop("height"), key=key, **args), kw
    if shape in ("sphere", "shell"):
        return fn(args.pop("radius"), key=key, **args), kw
    return fn(args.pop("masses"), args.pop("length"), key=key, **args), kw


def build_rigid(
    shape,
    params,
    *,
    position,
    velocity,
    attitude,
    rotation_vector,
    angular_velocity,
    frame,
    gravity,
    has_field: bool,
    strict: bool,
    key: str,
) -> dict:
    """Check and convert a rigid body's input as a scene or the Python API gives it.

    Parameters
    ----------
    shape : str
        A key of :data:`SHAPE_PARAMETERS`.
    params : dict
        The shape's parameters.
    position, velocity : Quantity or sequence
        The centre of mass's initial state, m and m/s.
    attitude, rotation_vector, angular_velocity, frame
        The attitude and angular velocity (see
        :func:`~emorbit.bodies.rotations.attitude_matrix`).
    gravity : str or None
        A key of :data:`GRAVITY_MODELS`; None: ``"volume"`` with a field, else ``"none"``.
    has_field : bool
        Whether the simulation has a central field.
    strict : bool
        Require units on every value.
    key : str
        Prefix of the keys that error messages name.

    Returns
    -------
    dict
        ``points`` (MassPoints), ``gravity`` (model name), ``position``, ``velocity``, ``R``
        (3, 3), ``omega_space`` and ``params`` (the shape's parameters in SI).

    Raises
    ------
    InputError
        An unknown shape, parameter or gravity model, or a bad value.
    """

    if not isinstance(shape, str):
        raise InputError(f"{key}.shape", f"expected a shape name, got {shape!r}")
    points, si_params = _shape_points(shape, params, strict, key)
    if gravity is None:
        gravity = "volume" if has_field else "none"
    if gravity not in GRAVITY_MODELS:
        raise InputError(f"{key}.gravity", f"unknown gravity model {gravity!r}; known: {', '.join(GRAVITY_MODELS)}")
    if gravity != "none" and not has_field:
        raise InputError(
            f"{key}.gravity",
            f"{gravity!r} needs a central field or an effect that acts at points; without one use 'none'",
        )
    x = vector_to_si(position, "length", f"{key}.position", strict=strict)
    v = vector_to_si(velocity, "speed", f"{key}.velocity", strict=strict)
    R, omega_space = attitude_matrix(attitude, rotation_vector, angular_velocity, frame, strict, key)
    return {
        "points": points,
        "gravity": gravity,
        "position": x,
        "velocity": v,
        "R": R,
        "omega_space": omega_space,
        "params": si_params,
    }
