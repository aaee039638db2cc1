"""The cases of rigid and elastic bodies against outside referees: what they share.

Each family of cases is one module of :data:`BODY_MODULES` (gravity-gradient libration
:mod:`.libration`, the torque-free body :mod:`.torque_free`, the centre of gravity
:mod:`.centre_of_gravity`, elastic bars and beams :mod:`.elastic_bodies`). A module gives

- ``NAMES``: its cases' names, in the order they run;
- ``NOTE``: a paragraph for the report (the referees, cited);
- ``cases(mode)``: {name: :class:`BodyCase`}, through :func:`build_cases`;
- ``run(case, mode, outdir, *, scale=1.0, figures=True)``: the outcome of a :class:`BodyRun`,
  through :func:`~.runner.body_outcome`.

A referee that is an optional package (Basilisk, Exudyn: the ``rigid-peers`` extra) gives a
skipped check when it is absent (:meth:`BodyRun.skip`): the case still passes.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field

import numpy as np

from .checks import Check

__all__ = [
    "BODY_MODULES",
    "BodyCase",
    "BodyRun",
    "Trajectory",
    "body_case_names",
    "body_cases",
    "body_notes",
    "build_cases",
]

#: the modules of the body cases, in the order their cases run (after the rigid binary)
BODY_MODULES = ("libration", "torque_free", "centre_of_gravity", "elastic_bodies")


@dataclass
class BodyCase:
    """One case: its name, words for the report, its time scale and its settings.

    ``module`` names the module of :data:`BODY_MODULES` that runs it; ``period`` is the case's
    time unit (s: an orbit, a libration or a vibration period), ``params`` the parameters the
    report lists (strings with units), ``settings`` what the module's runner reads (SI).
    """

    name: str
    module: str
    title: str
    description: str
    period: float
    params: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)


@dataclass
class Trajectory:
    """One run of a case: a label, the record times (s), the recorded series by name, the wall
    time (s) and ``info`` for the report (``method``, ``order``, ``dt_s``, ``steps``, ...)."""

    label: str
    t: np.ndarray
    series: dict
    wall: float
    info: dict = field(default_factory=dict)


class BodyRun:
    """The runs, checks and measurements of one body case (what the figures read).

    A module subclasses it and writes ``run()``: it fills ``runs`` (label to
    :class:`Trajectory`), calls :meth:`check`, :meth:`skip` and :meth:`metric`, and may fill
    ``convergence`` and ``timing``.
    """

    def __init__(self, case: BodyCase, mode: str, scale: float, outdir: str):
        self.case, self.mode, self.scale, self.outdir = case, mode, scale, outdir
        self.checks: list[Check] = []
        self.metrics: dict = {}
        self.runs: dict[str, Trajectory] = {}
        self.convergence: dict = {}
        self.timing: dict = {}

    def run(self):  # pragma: no cover - every module writes its own
        raise NotImplementedError

    def add(self, tr: Trajectory) -> Trajectory:
        """Keep a run under its label."""
        self.runs[tr.label] = tr
        return tr

    def check(self, id_, what, against, value, tolerance, unit, reason, detail=""):
        """A check; ``tolerance`` is multiplied by the suite's ``scale``."""
        self.checks.append(Check(id_, what, against, value, tolerance * self.scale, unit, reason, detail))

    def skip(self, id_, what, against, why, unit="1", reason="an optional referee"):
        """A check that did not run: ``why`` starts with "skipped:" (a referee not installed)."""
        why = why if why.startswith("skipped") else f"skipped: {why}"
        self.checks.append(Check(id_, what, against, float("nan"), 0.0, unit, reason, skipped=why))

    def metric(self, key, value, unit, note=""):
        """A measurement the report lists without a tolerance."""
        v = value.item() if isinstance(value, np.generic) else value
        self.metrics[key] = {"value": v, "unit": unit, "note": note}


def build_cases(mode: str, *builders) -> dict:
    """A module's cases of a mode by name: what its ``cases(mode)`` returns.

    Parameters
    ----------
    mode : str
        ``"quick"`` or ``"full"``.
    *builders : callable
        ``builder(mode)`` gives one :class:`BodyCase`; the cases keep the builders' order.

    Returns
    -------
    dict
        {name: BodyCase}.

    Raises
    ------
    ValueError
        A mode other than "quick" and "full".
    """
    if mode not in ("quick", "full"):
        raise ValueError(f"mode must be 'quick' or 'full', got {mode!r}")
    return {c.name: c for c in (build(mode) for build in builders)}


def _module(name: str):
    return importlib.import_module(f".{name}", __package__)


def body_case_names() -> tuple[str, ...]:
    """Every body case's name, in the order they run.

    Returns
    -------
    tuple of str
        The names.
    """
    return tuple(n for m in BODY_MODULES for n in _module(m).NAMES)


def body_cases(mode: str) -> dict[str, BodyCase]:
    """The body cases of a mode by name.

    Parameters
    ----------
    mode : str
        ``"quick"`` or ``"full"``.

    Returns
    -------
    dict
        {name: BodyCase}.
    """
    return {name: case for m in BODY_MODULES for name, case in _module(m).cases(mode).items()}


def body_notes(names) -> list[str]:
    """The report's paragraphs of the modules that have a case among ``names``."""
    names = set(names)
    return [_module(m).NOTE for m in BODY_MODULES if names & set(_module(m).NAMES)]


def run_body_case(case: BodyCase, mode: str, outdir: str, *, scale: float = 1.0, figures: bool = True) -> dict:
    """Run a body case through its module's ``run``: in ``mode`` (``"quick"`` or ``"full"``), its
    report files in ``outdir``, every tolerance multiplied by ``scale``, its figure drawn if
    ``figures``; returns the outcome (:func:`~.runner.body_outcome`)."""
    return _module(case.module).run(case, mode, outdir, scale=scale, figures=figures)
