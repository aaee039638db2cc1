"""Scenes that several test modules run."""

import emorbit

#: the orbit and effect sets of the tfe effect tests of rigid bodies and structures: the Earth,
#: an epoch for the Moon's and the Sun's ephemerides, a 500 km perigee, J2..J6 and the third bodies
EARTH = emorbit.CentralField(body="earth")
EPOCH = "2026-03-20T00:00:00 TDB"
R0 = EARTH.radius + 500e3
ZONAL = [("zonal", dict(model="earth", degree=6))]
MOON = [("third_body", dict(body="moon"))]
SUN = [("third_body", dict(body="sun"))]


def reuse_structure(t_end: str = "2 s", node_output_every: int = 2) -> str:
    """A tumbling elastic bar (4 tetrahedra along it) solved with Newton "reuse" (sparse LU
    factors kept across steps) at order 4, dt = 0.01 s, a record every 3 steps."""
    return f"""
[integrator]
method = "em"
order = 4
dt = "0.01 s"
t_end = "{t_end}"
output_every = 3
newton = "reuse"

[[body]]
name = "bar"
kind = "elastic"
mesh = "beam"
size = ["2 m", "0.1 m", "0.1 m"]
elements = [4, 1, 1]
young = "10 MPa"
poisson = 0.3
density = "1000 kg / m3"
position = ["0 m", "0 m", "0 m"]
velocity = ["0 m/s", "0 m/s", "0 m/s"]
angular_velocity = ["0.3 rad/s", "0.2 rad/s", "3 rad/s"]
node_output_every = {node_output_every}
"""
