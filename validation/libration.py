"""The cases ``libration-pitch`` and ``libration-roll-yaw``: the gravity-gradient libration of
a rigid box of mass points on a circular Earth orbit, emorbit's em method against the linear
and the pendulum theory of the libration and against Basilisk (the runs and checks:
:mod:`.libration_runner`; the referees: :mod:`.libration_referees`; the figures:
:mod:`.libration_figures`).

The body is emorbit's homogeneous box 2 x 1 x 0.5 m of 500 kg/m^3 (500 kg, 8 mass points:
``add_rigid(..., "box")``), its centre on a circular orbit of radius r = 7000 km about the Earth
(GM from astropy, n = sqrt(GM / r^3), T = 2 pi / n = 5828.5 s), size / r = 2.9e-7. It starts at
(r, 0, 0) with velocity (0, sqrt(GM / r), 0) and angular velocity n z in space: at rest in the
orbit frame. em runs at order 4 with the volume gravity (the field summed over the mass points:
the gravity-gradient torque of every order in size / r).

The body axes, the theory (first order in size / r: Hughes, Kaplan; the pendulum of Landau &
Lifshitz), the measurements, the attitude invariant K and the Basilisk model are
:mod:`.libration_referees`'s; what each case compares, and why its tolerances are what they
are, is :mod:`.libration_runner`'s.
"""

from __future__ import annotations

import math

import numpy as np

from .body_case import BodyCase, build_cases
from .libration_referees import orbit_rate, pitch_frequency, principal_moments, referee_inertia, roll_yaw_frequencies
from .libration_runner import ORDER, PitchRun, RollYawRun

__all__ = ["NAMES", "NOTE", "R_ORBIT", "BOX", "DENSITY", "cases", "run"]

NAMES = ("libration-pitch", "libration-roll-yaw")
#: the circular orbit's radius, m
R_ORBIT = 7.0e6
#: the box (m) and its density (kg/m^3): the box of ``emorbit bench`` and tests/test_rigid.py
BOX, DENSITY = (2.0, 1.0, 0.5), 500.0

NOTE = (
    "The libration cases (`libration-pitch`, `libration-roll-yaw`) put emorbit's 2 x 1 x 0.5 m box of 8 mass points "
    "on a 7000 km circular Earth orbit. Its pitch libration is checked against the linear frequency n sqrt(3 "
    "(I_roll - I_yaw) / I_pitch) and, at 10 to 60 degrees, against the pendulum's period 4 K(sin theta0) / w "
    "(Landau & Lifshitz, *Mechanics*, sec. 11), its two roll-yaw frequencies against the characteristic equation "
    "of the linearised roll-yaw equations (Hughes, *Spacecraft Attitude Dynamics*, 1986, ch. 9; Kaplan 1976), "
    "and both against Basilisk (Kenneally, Piggott & Schaub 2020: a Spacecraft hub with its first-order "
    "GravityGradientEffector, RK4 at 1 s) when it is installed; emorbit's torque of the mass points tends to "
    "Basilisk's as (size / r)^2."
)


# -- the cases ----------------------------------------------------------------------------------------------------
def _common(mode: str) -> dict:
    import emorbit

    gm = emorbit.CentralField(body="earth").gm
    I = referee_inertia(BOX, DENSITY)
    return {
        "gm": gm,
        "radius": R_ORBIT,
        "size": BOX,
        "density": DENSITY,
        "mass": DENSITY * float(np.prod(BOX)),
        "inertia": I,
        "order": ORDER,
        "steps": 500,  # per orbit; every comparison also at twice that (Richardson)
        "basilisk_dts": (1.0, 2.0),  # s: RK4's step and twice it (its own error)
        "mode": mode,
    }


def _case(name: str, title: str, s: dict, description: str, params: dict) -> BodyCase:
    """A case of the box on the circular orbit: its period is the orbit's, its parameters begin
    with the box's."""
    box = f"{list(BOX)} m, {DENSITY:g} kg/m3, {s['mass']:g} kg, 8 mass points (refinement 1)"
    period = 2 * math.pi / orbit_rate(s["gm"], s["radius"])
    return BodyCase(name, "libration", title, description, period, {"box": box, **params}, s)


def _moments(s: dict) -> str:
    """I_yaw, I_roll, I_pitch of the case's box, for its parameters."""
    roll, pitch, yaw = principal_moments(s["inertia"])
    return f"{yaw:.6g}, {roll:.6g}, {pitch:.6g} kg m2"


def _validate(name: str, s: dict) -> None:
    """Clear errors for settings that cannot give the case (naming the field and the value)."""
    for key in ("orbits", "steps"):
        if not (isinstance(s[key], (int, float)) and s[key] > 0):
            raise ValueError(f"{name}: settings[{key!r}] must be > 0, got {s[key]!r}")
    for a in s.get("amplitudes", ()):
        if not 0.0 < a < math.pi / 2:
            raise ValueError(f"{name}: settings['amplitudes'] must lie in (0, pi/2) rad, got {a!r}")
    for a in s.get("sizes", ()):
        if not 0.0 < a <= 0.05:
            raise ValueError(f"{name}: settings['sizes'] (size / r) must lie in (0, 0.05], got {a!r}")
    for a in s.get("offsets", ()):
        if not 0.0 < a < 0.05:
            raise ValueError(f"{name}: settings['offsets'] must lie in (0, 0.05) rad (linear libration), got {a!r}")


def _pitch(mode: str) -> BodyCase:
    s = _common(mode)
    n = orbit_rate(s["gm"], s["radius"])
    T = 2 * math.pi / n
    degrees = {"quick": (10.0, 30.0, 60.0), "full": (10.0, 20.0, 30.0, 45.0, 60.0)}[mode]
    s.update(
        orbits={"quick": 3, "full": 10}[mode],
        linear=0.01,  # rad: the small amplitude (linear theory's truncation 2.5e-5)
        amplitudes=(0.01, *np.radians(degrees).tolist()),
        basilisk_amplitudes=(0.01, math.radians(30.0)),
        sizes=(0.005, 0.01, 0.02),  # long edge / r of the grown boxes
        size_amplitude=math.radians(30.0),
        size_steps=1000,
        size_orbits=3,
    )
    w = pitch_frequency(n, s["inertia"])
    return _case(
        "libration-pitch",
        "Gravity-gradient pitch libration of a rigid box: linear theory, the pendulum and Basilisk",
        s,
        (
            f"emorbit's homogeneous box {' x '.join(f'{a:g}' for a in BOX)} m of {DENSITY:g} kg/m3 ({s['mass']:g} kg, "
            "8 mass points, volume gravity) on a circular Earth orbit of radius 7000 km (GM from astropy, period "
            f"T = {T:.7g} s), its long axis radial, its short axis along the orbit normal, pitched by theta0 about "
            "the normal and at rest in the orbit frame. em (order 4, T/500 and T/1000) librates in pitch at "
            f"n sqrt(3 (I_roll - I_yaw) / I_pitch) = {w / n:.6g} n for small theta0 and with the pendulum's period "
            "4 K(sin theta0) / w_pitch at 10 to 60 degrees; the pitch angle is measured in the orbit frame "
            "(e_r, e_t, e_n) from the recorded centre and attitude. Basilisk (a Spacecraft hub with the box's "
            "inertia, its first-order GravityGradientEffector, RK4 at 1 s) runs the same start, and the box grown "
            "to size / r = 0.005, 0.01, 0.02 shows emorbit's torque of the mass points tending to Basilisk's like "
            "(size / r)^2."
        ),
        {
            "I_yaw, I_roll, I_pitch (body x radial, y along track, z normal)": _moments(s),
            "orbit": f"circular, r = {R_ORBIT / 1e3:g} km, GM = {s['gm']:.10g} m3/s2, n = {n:.10g} rad/s, T = "
            f"{T:.10g} s",
            "w_pitch (linear)": f"{w:.10g} rad/s = {w / n:.8g} n",
            "amplitudes": ", ".join(f"{math.degrees(a):.4g}" for a in s["amplitudes"]) + " deg",
            "em": f"order {ORDER}, T/{s['steps']} and T/{2 * s['steps']}, {s['orbits']} T, recorded at every step",
            "Basilisk": f"RK4 at {s['basilisk_dts'][0]:g} s (and {s['basilisk_dts'][1]:g} s), amplitudes "
            + ", ".join(f"{math.degrees(a):.4g}" for a in s["basilisk_amplitudes"])
            + " deg",
            "grown boxes": "long edge / r = " + ", ".join(f"{a:g}" for a in s["sizes"]) + ", 500 kg, theta0 = 30 deg, "
            f"em at T/{s['size_steps']} over {s['size_orbits']} T",
        },
    )


def _roll_yaw(mode: str) -> BodyCase:
    s = _common(mode)
    n = orbit_rate(s["gm"], s["radius"])
    T = 2 * math.pi / n
    s.update(orbits={"quick": 8, "full": 20}[mode], offsets=(2e-3, 4e-3), basilisk_record=10.0)
    f = roll_yaw_frequencies(n, s["inertia"])
    return _case(
        "libration-roll-yaw",
        "Gravity-gradient roll-yaw libration of a rigid box: the two linear modes and Basilisk",
        s,
        (
            f"The box of `libration-pitch` ({' x '.join(f'{a:g}' for a in BOX)} m, 8 mass points) on the same "
            "7000 km circular orbit, its body axes on the orbit frame's but turned by eps about the radial (yaw) "
            "and by eps about the along-track axis (roll), at rest in the orbit frame: both roll-yaw modes "
            f"librate. Its moments I_pitch > I_roll > I_yaw put it in the Lagrange region (k_R = {f['k_roll']:.4g}, "
            f"k_Y = {f['k_yaw']:.4g}); the characteristic equation of the linearised roll-yaw equations (Hughes "
            f"1986, ch. 9) gives {f['fast'] / n:.6g} n and {f['slow'] / n:.6g} n. Both frequencies are fitted to "
            "em's roll and yaw series (order 4, T/500 and T/1000, eps = 2e-3 and 4e-3 rad, extrapolated to eps = 0) "
            "and to Basilisk's (RK4 at 1 s) at eps = 2e-3 rad."
        ),
        {
            "I_yaw, I_roll, I_pitch": _moments(s),
            "k_R, k_Y": f"{f['k_roll']:.8g}, {f['k_yaw']:.8g} (Lagrange region)",
            "orbit": f"circular, r = {R_ORBIT / 1e3:g} km, n = {n:.10g} rad/s, T = {T:.10g} s",
            "linear roll-yaw frequencies": f"{f['fast']:.10g}, {f['slow']:.10g} rad/s = {f['fast'] / n:.8g} n, "
            f"{f['slow'] / n:.8g} n",
            "offsets eps (yaw and roll)": ", ".join(f"{a:g}" for a in s["offsets"]) + " rad",
            "em": f"order {ORDER}, T/{s['steps']} and T/{2 * s['steps']}, {s['orbits']} T, recorded at every step",
            "Basilisk": f"RK4 at {s['basilisk_dts'][0]:g} s (and {s['basilisk_dts'][1]:g} s), eps = "
            f"{s['offsets'][0]:g} rad, records every {s['basilisk_record']:g} s",
        },
    )


def cases(mode: str) -> dict[str, BodyCase]:
    """The libration cases of a mode by name (:func:`~.body_case.build_cases`): ``"quick"`` (pitch
    over 3 T at 0.57, 10, 30, 60 degrees; roll-yaw over 8 T) or ``"full"`` (10 T at 0.57, 10, 20,
    30, 45, 60 degrees; 20 T); settings that cannot give a case raise ValueError."""
    out = build_cases(mode, _pitch, _roll_yaw)
    for name, c in out.items():
        _validate(name, c.settings)
    return out


def run(case: BodyCase, mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True):
    """Run a libration case and return its outcome (:func:`~.runner.body_outcome`; the figure
    ``<case name>.png``).

    Raises
    ------
    ValueError
        A case that is not one of :data:`NAMES`.
    """
    from .runner import body_outcome

    kinds = {"libration-pitch": PitchRun, "libration-roll-yaw": RollYawRun}
    if case.name not in kinds:
        raise ValueError(f"case must be one of {NAMES}, got {case.name!r}")
    s = case.settings

    def summary(r):
        bsk = (
            f"Basilisk RK4 at {s['basilisk_dts'][0]:g} and {s['basilisk_dts'][1]:g} s"
            if not r.basilisk
            else "Basilisk not installed: its checks skipped"
        )
        return (
            f"em order {ORDER} runs {s['orbits']} orbits of T = {case.period:.10g} s at T/{s['steps']} and "
            f"T/{2 * s['steps']}, recorded at every step; {bsk}."
        )

    return body_outcome(
        case,
        mode,
        outdir,
        lambda: kinds[case.name](case, mode, scale, outdir),
        _draw,
        figures=figures,
        summary=summary,
        drop=("points",),
        orbits=s["orbits"],
        steps_per_period=s["steps"],
    )


def _draw(r, outdir):  # matplotlib is imported only where figures are drawn
    from .libration_figures import libration_figure

    return libration_figure(r, outdir)
