"""A run's clean stop on SIGINT and SIGTERM: the request a signal sets, and the exception after.

While a run steps, :func:`stop_on_signals` installs a handler that records the first SIGINT
or SIGTERM in a :class:`StopRequest` instead of ending the process; the chunk driver
(:mod:`emorbit.stepping`) checks it between chunks, writes the records, the final state and
a checkpoint, marks the file "interrupted" and raises :class:`RunInterrupted`, which
``emorbit`` turns into exit status 128 + signum.
"""

from __future__ import annotations

import contextlib
import signal
import threading

__all__ = ["RunInterrupted", "StopRequest", "STOP_SIGNALS", "stop_on_signals"]

#: the signals that stop a run cleanly
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class RunInterrupted(KeyboardInterrupt):
    """A run stopped by SIGINT or SIGTERM after writing its records, final state and checkpoint.

    Parameters
    ----------
    signum : int
        The signal; ``emorbit`` exits with 128 + signum (130 for SIGINT, 143 for SIGTERM).

    Attributes
    ----------
    signum : int
        As given.
    """

    def __init__(self, signum: int):
        self.signum = int(signum)
        super().__init__(f"interrupted by {signal.Signals(self.signum).name}")


class StopRequest:
    """A signal handler that records the first SIGINT or SIGTERM instead of ending the process.

    Attributes
    ----------
    signum : int or None
        The first signal received, or None.
    """

    def __init__(self):
        self.signum: int | None = None

    def __call__(self, signum, frame) -> None:
        if self.signum is None:
            self.signum = int(signum)

    def is_set(self) -> bool:
        """Whether a stop was asked for.

        Returns
        -------
        bool
            True after SIGINT or SIGTERM.
        """
        return self.signum is not None


@contextlib.contextmanager
def stop_on_signals():
    """Within the block, SIGINT and SIGTERM set a :class:`StopRequest` and the process goes on.

    In the main thread the handlers are installed for the block and the previous ones put
    back after it; where a :class:`StopRequest` is installed already (``emorbit run`` installs
    one before it builds the scene), that one is used, so a signal that came earlier counts.
    Outside the main thread no handler can be installed and the request is never set.

    Yields
    ------
    StopRequest
        The request the handlers set.
    """
    if threading.current_thread() is not threading.main_thread():
        yield StopRequest()
        return
    current = signal.getsignal(signal.SIGINT)
    if isinstance(current, StopRequest) and signal.getsignal(signal.SIGTERM) is current:
        yield current
        return
    request = StopRequest()
    previous = {sig: signal.signal(sig, request) for sig in STOP_SIGNALS}
    try:
        yield request
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
