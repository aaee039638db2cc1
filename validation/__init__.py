"""emorbit's validation suite: emorbit against REBOUND (IAS15, WHFast), REBOUNDx, scipy's DOP853,
astropy's constants and units, first-order secular theory and the analytic Kepler solution, with a
report a reviewer can read.

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
:mod:`.effect_figures`. The rigid-rigid binary against scipy's DOP853: :mod:`.rigid_binary_case`,
:mod:`.rigid_binary`, :mod:`.rigid_binary_figures`. Drag, radiation pressure with the Earth's
shadow, and the Moon and the Sun against IAS15 carrying the same force model:
:mod:`.perturbation_cases`, :mod:`.perturbation_model`, :mod:`.perturbation_runs`,
:mod:`.perturbation_runner`, :mod:`.perturbation_figures`.
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
