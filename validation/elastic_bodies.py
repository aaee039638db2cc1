"""The elastic cases: emorbit's St. Venant-Kirchhoff bars and tetrahedra against closed forms
and a discrete referee, in free space (``Simulation(None, ...)``: elastic and rigid bodies need
no field), through the public API. Each case is a module:

- ``elastic-bar-axial`` (:mod:`.elastic_bar`): the axial frequencies of a free-free bar of N
  bars, lumped and consistent mass, against the exact chain carried by the midpoint rule and,
  under refinement, against f_n = n c / (2 L) at order 2;
- ``elastic-cantilever`` (:mod:`.elastic_cantilever`): the first two bending frequencies of a
  cantilever of linear tetrahedra attached to a heavy rigid base, against the referee's own
  eigenmodes of the same mesh and base and, extrapolated over 3 (quick) or 4 (full) meshes,
  against Euler-Bernoulli within Timoshenko's shear and rotary-inertia correction;
- ``elastic-spinning-bar`` (:mod:`.elastic_spinning`): two end masses on one SVK bar spinning
  at stretches up to 2: em keeps the closed-form steady spin exactly, the radial oscillation
  matches the linearised closed form, and the strain energy of bars and tetrahedra at large
  deformation matches the SVK law.

What they share (frequencies from records, the midpoint rule's frequency, the invariants at
round-off) is :mod:`.elastic_common`; the figures are :mod:`.elastic_bodies_figures`. This
module gives the suite its ``NAMES``, ``NOTE``, ``cases`` and ``run``
(:data:`~.body_case.BODY_MODULES`).

References: see the case modules.
"""

from __future__ import annotations

from .body_case import BodyCase, build_cases
from .elastic_bar import BarRun, bar_case
from .elastic_cantilever import CantileverRun, cantilever_case
from .elastic_spinning import SpinningRun, spinning_case

__all__ = ["NAMES", "NOTE", "RUNS", "cases", "run"]

#: the cases, in the order they run
NAMES = ("elastic-bar-axial", "elastic-cantilever", "elastic-spinning-bar")

NOTE = (
    "The elastic cases run emorbit's St. Venant-Kirchhoff bars and tetrahedra in free space against closed forms: "
    "the axial frequencies of a free-free bar (`elastic-bar-axial`) against the exact lumped and consistent chains "
    "carried by the midpoint rule and, under refinement, against n c / (2L) at order 2 (Hughes 1987; Graff 1975); "
    "the first two bending frequencies of a cantilever of tetrahedra on a heavy rigid base (`elastic-cantilever`) "
    "against the referee's own eigenmodes of the same mesh (scipy's eigsh) and, extrapolated over 3 or 4 meshes, "
    "against Euler-Bernoulli within Timoshenko's shear and rotary-inertia correction (Timoshenko 1921; Cowper "
    "1966); and a bar spinning at stretches up to 2 between two end masses (`elastic-spinning-bar`), whose steady "
    "spin em keeps exactly at the closed-form rate of the SVK tension A E lam (lam^2 - 1) / 2, whose radial "
    "oscillation matches the linearised closed form, and whose strain energy at large deformation matches the SVK "
    "law (Simo & Tarnow 1992; Holzapfel 2000). Every run keeps energy, momentum and angular momentum at round-off."
)


def cases(mode: str) -> dict[str, BodyCase]:
    """The elastic cases of a mode by name (:func:`~.body_case.build_cases`): ``"quick"`` (coarser
    meshes, fewer stretches) or ``"full"``."""
    return build_cases(mode, bar_case, cantilever_case, spinning_case)


#: the run class of each case by name
RUNS = {"elastic-bar-axial": BarRun, "elastic-cantilever": CantileverRun, "elastic-spinning-bar": SpinningRun}


def run(case: BodyCase, mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True, young_factor: float = 1.0):
    """Run one elastic case and return its outcome (:func:`~.runner.body_outcome`; the figure
    ``<case name>.png``).

    ``young_factor`` is the referees' Young's modulus over emorbit's (1: the same; another value
    shows the checks that referee the elastic law fail).

    Raises
    ------
    ValueError
        A case that is not one of :data:`NAMES`.
    """
    from .runner import body_outcome

    if case.name not in RUNS:
        raise ValueError(f"case must be one of {', '.join(NAMES)}, got {case.name!r}")
    return body_outcome(
        case,
        mode,
        outdir,
        lambda: RUNS[case.name](case, mode, scale, outdir, young_factor=young_factor),
        _draw,
        figures=figures,
        summary=_summary(case),
    )


def _draw(r, outdir):  # matplotlib is imported only where figures are drawn
    from .elastic_bodies_figures import FIGURES

    return FIGURES[r.case.name](r, outdir)


def _summary(case: BodyCase) -> str:
    s = case.settings
    if case.name == "elastic-bar-axial":
        return (
            f"em order 2 at T_1/{s['steps_per_period']} for {s['periods']} T_1, recorded at every step, on "
            f"{len(s['elements'])} meshes x 2 mass matrices."
        )
    if case.name == "elastic-cantilever":
        return (
            f"em order 2 at T_2/{s['steps_per_period']} of each mesh for {s['periods']} periods of its first mode, "
            f"recorded at every step, on {len(s['meshes'])} meshes and one at nu = 0.3."
        )
    return (
        f"em orders {', '.join(map(str, s['orders']))} at T/{s['steps_per_turn']} for {s['turns']} turns (steady), "
        f"order 2 at T_Omega/{', '.join(map(str, s['radial_steps']))} for {s['radial_periods']} radial periods."
    )
