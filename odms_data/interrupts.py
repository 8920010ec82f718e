"""Stop signals (SIGINT, SIGTERM, SIGHUP): the one owner of how odms-data handles them.

- `stops_interrupt()`, around every command: a stop raises `Interrupted` in the main thread
  (`stop_requested`), as Ctrl-C raises KeyboardInterrupt; once one came, later ones are ignored,
  so the clean-up it starts is not cut short; one that a finalizer swallowed is raised again
  (`_SwallowedStops`).
- `uninterrupted()`: a step that a stop must not cut in two waits for it.
- `held(signals)`: signals held on this thread while a child process starts, which inherits them
  held (parallel.py's fork server); `left_to_the_parent()`: a worker ignores Ctrl-C.
- `stop_signal(error)`: the signal of the stop an error is or carries (a C extension may have
  turned it into another error), None for a failure.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

from .errors import Interrupted

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
RESEND_S = 0.01  # how often a stop that a finalizer swallowed is sent again

_deferring = 0  # depth of `uninterrupted` blocks
_deferred: int | None = None  # the signal that came during one


def stop_signal(error: BaseException) -> int | None:
    """The signal of the stop `error` is, or carries as its cause or context (SIGINT for Python's own
    KeyboardInterrupt); None when it is a failure. A stop whose handler ran inside a C extension can
    come back as another error (Numba's dispatcher then returns a SystemError caused by it), and is
    still a stop."""
    seen: set[int] = set()
    e: BaseException | None = error
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return e.signum if isinstance(e, Interrupted) else signal.SIGINT
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def stop_requested(signum: int) -> None:
    """Stop for signal `signum` (the command line's handler calls this): raise Interrupted now, or
    at the end of the `uninterrupted` block in progress."""
    global _deferred
    if _deferring:
        _deferred = signum
        return
    raise Interrupted(signum)


@contextmanager
def held(signals: Iterable[int]) -> Iterator[None]:
    """`signals` blocked on this thread (and in a process it starts meanwhile); one that came is
    handled when the block ends."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, set(signals))
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextmanager
def uninterrupted() -> Iterator[None]:
    """A step that a stop signal must not cut in two: a sibling made and its removal set (outputs),
    the renames that put an output in place, a write of an HDF5 store (libhdf5 cannot recover from
    an exception raised in the file it writes through). A stop that comes meanwhile is raised when
    the block ends. The command line's handler waits for it even when the signal reaches another
    thread (zarr's, a pool's), which a signal mask cannot prevent; the mask holds Python's default
    handlers (a library's Ctrl-C) where this is the only thread."""
    global _deferring, _deferred
    _deferring += 1
    try:
        with held(STOP_SIGNALS):
            yield
    finally:
        _deferring -= 1
    if not _deferring and _deferred is not None:
        signum, _deferred = _deferred, None
        raise Interrupted(signum)


def left_to_the_parent() -> None:
    """In a worker process: Ctrl-C, which a terminal sends to the whole process group, is left to
    the parent, which stops its workers itself."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class _SwallowedStops:
    """Python swallows an exception raised while a finalizer runs (`__del__`, a weakref callback):
    it prints "Exception ignored" with a traceback and goes on, so a stop that came then was lost
    and the command ran to its end. As `sys.unraisablehook`, this takes such a stop back, and a
    helper thread sends its signal again until it is raised in the code the finalizer interrupted."""

    def __init__(self, handler: Any, hook: Any) -> None:
        self.handler, self.hook = handler, hook
        self.lost: list[int] = []  # the swallowed stop's signal, until it is raised again
        self.in_hook = threading.Event()  # a stop raised in the hook would be swallowed too

    def __call__(self, u: Any) -> None:
        main = threading.current_thread() is threading.main_thread()
        if not (main and isinstance(u.exc_value, Interrupted)):
            self.hook(u)
            return
        self.in_hook.set()
        try:
            signal.signal(u.exc_value.signum, self.handler)
            if not self.lost:
                self.lost.append(u.exc_value.signum)
                threading.Thread(target=self._resend, daemon=True, name="resend-stop").start()
        finally:
            self.in_hook.clear()

    def _resend(self) -> None:
        while self.lost:
            time.sleep(RESEND_S)
            if self.lost and not self.in_hook.is_set():
                os.kill(os.getpid(), self.lost[0])


@contextmanager
def stops_interrupt() -> Iterator[None]:
    """Turn the stop signals into `Interrupted` (`stop_requested`) while the block runs in the main
    thread; once one came, later ones are ignored, so the clean-up it starts is not cut short. One
    a finalizer swallowed is raised again (`_SwallowedStops`)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum: int, frame: object) -> None:
        if swallowed.in_hook.is_set():  # the helper sends it again
            return
        swallowed.lost.clear()
        for s in STOP_SIGNALS:
            signal.signal(s, signal.SIG_IGN)
        stop_requested(signum)

    swallowed = _SwallowedStops(stop, sys.unraisablehook)
    previous = {s: signal.signal(s, stop) for s in STOP_SIGNALS}
    sys.unraisablehook = swallowed
    try:
        yield
    finally:
        sys.unraisablehook = swallowed.hook
        for s, handler in previous.items():
            signal.signal(s, handler)
