"""emorbit: energy-momentum conserving integration in a central gravity field.

The scripting API::

    import astropy.units as u
    import emorbit

    sim = emorbit.Simulation(emorbit.CentralField(gm=3.9478 * u.m**3 / u.s**2), method="em", dt=0.464758 * u.s)
    sim.add_point("satellite", mass=1 * u.kg, position=[10, 0, 0] * u.m, velocity=[0, 0.36276, 0] * u.m / u.s)
    result = sim.run(t_end=4647.58 * u.s, every=10)

Scenes (TOML) are loaded with :func:`load_scene`; files are read with :func:`read`.
"""

from ._version import __version__
from .errors import (
    EmorbitError,
    EmorbitWarning,
    EpochWarning,
    InputError,
    IntegrationError,
    RoundoffError,
    RoundoffWarning,
)
from .field import BODIES, CentralField
from .integrators import METHODS, ORDERS
from .io.reader import read
from .io.resume import resume
from .result import Result
from .scene import Scene, list_scenes, load_scene, parse_scene
from .simulation import Simulation

__all__ = [
    "__version__",
    "BODIES",
    "CentralField",
    "EmorbitError",
    "EmorbitWarning",
    "EpochWarning",
    "InputError",
    "IntegrationError",
    "METHODS",
    "ORDERS",
    "Result",
    "RoundoffError",
    "RoundoffWarning",
    "Scene",
    "Simulation",
    "list_scenes",
    "load_scene",
    "parse_scene",
    "read",
    "resume",
]
