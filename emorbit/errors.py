"""Exceptions raised by emorbit. Every input error names the offending key and value."""

from __future__ import annotations

__all__ = [
    "EmorbitError",
    "EmorbitWarning",
    "EpochWarning",
    "InputError",
    "IntegrationError",
    "RoundoffError",
    "RoundoffWarning",
]


class EmorbitError(Exception):
    """Base class of every error emorbit raises on purpose."""


class InputError(EmorbitError, ValueError):
    """Bad input, raised before anything runs.

    Parameters
    ----------
    key : str
        Where the value was found, e.g. ``"body[0].position"`` or ``"integrator.dt"``
        (empty when the error concerns no single key).
    message : str
        What is wrong with it and, where it helps, what to write instead.

    Attributes
    ----------
    key : str
        As given.
    message : str
        As given; ``str(error)`` is ``"<key>: <message>"``.
    """

    def __init__(self, key: str, message: str):
        self.key = key
        self.message = message
        super().__init__(f"{key}: {message}" if key else message)


class IntegrationError(EmorbitError, RuntimeError):
    """A step could not be taken: Newton did not converge, or a body reached the centre.

    Everything before ``time`` has been recorded and, for a run with an output file,
    written.

    Parameters
    ----------
    time : float
        Start of the failing step, s.
    body : str
        Name of the body whose step failed.
    reason : str
        What went wrong.

    Attributes
    ----------
    time : float
        As given, s.
    body : str
        As given.
    reason : str
        As given.
    """

    def __init__(self, time: float, body: str, reason: str):
        self.time = time
        self.body = body
        self.reason = reason
        super().__init__(f"step at t = {time!r} s failed for body {body!r}: {reason}")


class EmorbitWarning(UserWarning):
    """Base class of every warning emorbit issues; ``emorbit run`` prints each once, as
    ``emorbit: warning: ...``."""


class EpochWarning(EmorbitWarning):
    """An epoch lies where its time scale is extrapolated: a UTC date outside the years that
    the leap-second table covers, so its offset from TDB (and the Sun's and the Moon's
    positions at it) is a guess by up to a minute or more."""


class RoundoffWarning(EmorbitWarning):
    """A conserved invariant drifted further from its first record than round-off explains.

    Issued once at the end of a run (its file complete and closed); the message names the
    invariant, its largest drift, where, and what to change. ``emorbit run --strict`` and
    ``Simulation.run(strict=True)`` raise :class:`RoundoffError` instead.
    """


class RoundoffError(EmorbitError, ArithmeticError):
    """The strict form of :class:`RoundoffWarning`, raised after the run's file is complete.

    Its message is the warning's text; ``emorbit run --strict`` exits with code 3.
    """
