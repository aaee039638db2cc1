"""What a run says on stderr while something slow happens: kernels compiling on a first run.

:func:`announce` prints a line once per message and process. :func:`compile_notice` watches
Numba's compile events (``numba:compile``) while a run lasts: when one compilation has gone
on for :data:`DELAY` seconds (a kernel compiling from scratch, not loaded from the disk
cache: a warm run's compiles of small helpers end within milliseconds), it says once that
kernels compile and that later runs load them from the cache. A line already announced in
the process (an effect set's compile says which effects) stands for it.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time

__all__ = ["announce", "compile_notice", "DELAY", "COMPILING"]

#: how long one compilation lasts before the notice, s
DELAY = 1.0
#: the notice
COMPILING = "compiling kernels (first run only: later runs load them from the disk cache)"

_SAID: set = set()


def announce(message: str) -> None:
    """Say on stderr, once per message and process, that something slow happens now."""
    if message not in _SAID:
        _SAID.add(message)
        print(f"emorbit: {message}", file=sys.stderr, flush=True)


class _Watch:
    """Counts the compilations in progress and when the outermost began."""

    def __init__(self, first=None):
        self.active = 0
        self.since = 0.0
        self.lock = threading.Lock()
        self.first = first  # called when the first compilation starts

    def listener(self):
        from numba.core import event

        watch = self

        class Listener(event.Listener):
            def on_start(self, ev):
                with watch.lock:
                    if watch.active == 0:
                        watch.since = time.monotonic()
                    watch.active += 1
                    first, watch.first = watch.first, None
                if first is not None:
                    first()

            def on_end(self, ev):
                with watch.lock:
                    watch.active = max(0, watch.active - 1)

        return Listener()

    def long(self) -> bool:
        with self.lock:
            return self.active > 0 and time.monotonic() - self.since >= DELAY


@contextlib.contextmanager
def compile_notice(enabled: bool = True):
    """While the block runs, say once (:data:`COMPILING`) when a compilation lasts
    :data:`DELAY` seconds; nothing where ``enabled`` is false or a notice was said already."""
    if not enabled or _SAID:
        yield
        return
    from numba.core import event

    done = threading.Event()
    threads = []

    def wait():
        while not done.wait(0.1):
            if _SAID:
                return
            if watch.long():
                announce(COMPILING)
                return

    def first():  # a warm run compiles nothing and starts no thread
        threads.append(threading.Thread(target=wait, name="emorbit-compile-notice", daemon=True))
        threads[0].start()

    watch = _Watch(first)
    with event.install_listener("numba:compile", watch.listener()):
        try:
            yield
        finally:
            done.set()
            for thread in threads:
                thread.join()
