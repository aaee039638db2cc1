"""emorbit's validation suite: emorbit against REBOUND (IAS15, WHFast), REBOUNDx, scipy's DOP853,
astropy's constants and units, first-order secular theory and the analytic Kepler solution, and
rigid and elastic bodies against Basilisk, Exudyn and closed forms, with a report a reviewer can
read.

The repository's ``validation/`` folder is installed as ``emorbit.validation`` (never as a
top-level module ``validation``, which any file of that name in the working folder would
shadow). Run it with ``emorbit validate [--quick] --report DIR`` or from Python::

    from emorbit.validation import run_suite
    suite = run_suite("report-dir", quick=True)
    assert suite["passed"]

Modules: :mod:`.cases` (initial conditions, steps, run lengths), :mod:`.runs` (emorbit,
REBOUND and Kepler trajectories on shared record times), :mod:`.checks` (tolerances with
units and reasons), :mod:`.runner` (one case: runs, checks, convergence study),
:mod:`.brouwer` (round-off over many steps: the paper's orbit in the full suite, and
``brouwer-j2``, with J2..J6, a case of both suites), :mod:`.figures`, :mod:`.report`
(Markdown and JSON), :mod:`.suite` (the whole suite), :mod:`.cli` (``emorbit validate``).
The cases of the effects (zonal harmonics, mutual gravity): :mod:`.effect_cases`,
:mod:`.effect_runs`, :mod:`.effect_runner`, :mod:`.effect_checks`, :mod:`.secular`,
:mod:`.effect_figures`; :mod:`.effect_eval` evaluates emorbit's effects at given states through
a simulation's compiled effect set. The rigid-rigid binary against scipy's DOP853: :mod:`.rigid_binary_case`,
:mod:`.rigid_binary`, :mod:`.rigid_binary_figures`. Drag, radiation pressure with the Earth's
shadow, and the Moon and the Sun against IAS15 carrying the same force model:
:mod:`.perturbation_cases`, :mod:`.perturbation_model`, :mod:`.perturbation_runs`,
:mod:`.perturbation_runner`, :mod:`.perturbation_figures`. Rigid and elastic bodies against outside
referees (:mod:`.body_case`, what their cases share): gravity-gradient libration against linear and
pendulum theory and Basilisk, :mod:`.libration`, :mod:`.libration_runner`,
:mod:`.libration_referees`, :mod:`.libration_figures`; the Dzhanibekov flip against Jacobi's
elliptic period, DOP853 and Exudyn, :mod:`.torque_free`, :mod:`.torque_free_referees`,
:mod:`.torque_free_figures`; the resultant gravity force and torque and the centre of gravity
against exact sums and closed forms, :mod:`.centre_of_gravity`, :mod:`.centre_of_gravity_referees`,
:mod:`.centre_of_gravity_figures`; elastic bars and beams against the exact chain, Euler-Bernoulli
and the SVK law, :mod:`.elastic_bodies`, :mod:`.elastic_common`, :mod:`.elastic_bar`,
:mod:`.elastic_cantilever`, :mod:`.elastic_spinning`, :mod:`.elastic_bodies_figures`.
"""

import importlib

__all__ = ["run_suite", "case_names", "get_cases"]

#: the public names and their modules, imported on first use: ``emorbit run`` builds the
#: command line, which imports :mod:`.cli`, and must not load the cases (rigid bodies among them)
_LAZY = {"run_suite": ".suite", "case_names": ".cases", "get_cases": ".cases"}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
