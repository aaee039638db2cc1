"""The integer codes the kernels share: methods, step outcomes and rigid-body gravity models.

Every ``METHOD_*``, ``STATUS_*`` and ``GRAVITY_*`` constant is defined here and nowhere
else; kernels compare against them as compile-time constants. The mapping from a method's
name and round-off mode to a code is :func:`emorbit.integrators.dispatch.method_code`.
"""

from __future__ import annotations

__all__ = [
    "METHOD_EM",
    "METHOD_MIDPOINT",
    "METHOD_LEAPFROG",
    "METHOD_EM_PLAIN",
    "METHOD_TFE",
    "STATUS_OK",
    "STATUS_NO_CONVERGENCE",
    "STATUS_SINGULAR",
    "GRAVITY_NONE",
    "GRAVITY_POINT",
    "GRAVITY_VOLUME",
]

#: energy-momentum step, g_em solved to a correctly rounded root (roundoff "brouwer")
METHOD_EM = 0
#: implicit midpoint rule, gravity at (x0 + x1) / 2
METHOD_MIDPOINT = 1
#: explicit kick-drift-kick (Stormer-Verlet)
METHOD_LEAPFROG = 2
#: energy-momentum step in plain floating point (roundoff "fast")
METHOD_EM_PLAIN = 3
#: energy-momentum time finite element of order 2k in one implicit solve (point masses,
#: central field): :mod:`emorbit.kernels.pointmass.tfe`
METHOD_TFE = 4

#: the step succeeded
STATUS_OK = 0
#: Newton's update never fell to round-off within max_iter iterations
STATUS_NO_CONVERGENCE = 1
#: a point reached the field's centre, or the state is no longer finite
STATUS_SINGULAR = 2

#: rigid body in free motion (no field)
GRAVITY_NONE = 0
#: all mass at the centre of mass: no gravity-gradient torque
GRAVITY_POINT = 1
#: the field summed over the body's mass points: gravity-gradient torque included
GRAVITY_VOLUME = 2
