"""Exceptions raised by emorbit. Every input error names the offending key and value."""

from __future__ import annotations

__all__ = ["EmorbitError", "InputError", "IntegrationError"]


class EmorbitError(Exception):
    """Base class of every error emorbit raises on purpose."""


class InputError(EmorbitError, ValueError):
    """Bad input: ``key`` is where it was found (e.g. ``"body[0].position"``)."""

    def __init__(self, key: str, message: str):
        self.key = key
        self.message = message
        super().__init__(f"{key}: {message}" if key else message)


class IntegrationError(EmorbitError, RuntimeError):
    """A step could not be taken (Newton did not converge, a point reached the centre).

    ``time`` is the start of the failing step in s, ``body`` the body's name, ``reason``
    what went wrong. Everything before ``time`` has been recorded and written.
    """

    def __init__(self, time: float, body: str, reason: str):
        self.time = time
        self.body = body
        self.reason = reason
        super().__init__(f"step at t = {time!r} s failed for body {body!r}: {reason}")
