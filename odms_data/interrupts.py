"""Stop signals (SIGINT, SIGTERM, SIGHUP) as the command line handles them: an `Interrupted`
raised in the main thread, except inside an `uninterrupted` block, which it waits for."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager

from .errors import Interrupted

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

_deferring = 0  # depth of `uninterrupted` blocks
_deferred: int | None = None  # the signal that came during one


def stop_requested(signum: int) -> None:
    """Stop for signal `signum` (the command line's handler calls this): raise Interrupted now, or
    at the end of the `uninterrupted` block in progress."""
    global _deferred
    if _deferring:
        _deferred = signum
        return
    raise Interrupted(signum)


@contextmanager
def uninterrupted() -> Iterator[None]:
    """A step that a stop signal must not cut in two: a write zarr finishes on its own I/O thread
    after the main thread is interrupted, a sibling made and its removal set (outputs), the renames
    that put an output in place. A stop that comes meanwhile is raised when the block ends. The
    command line's handler waits for it even when the signal reaches another thread (zarr's, a
    pool's), which a signal mask cannot prevent; the mask holds Python's default handlers (a
    library's Ctrl-C) where this is the only thread."""
    global _deferring, _deferred
    _deferring += 1
    held = None
    try:
        held = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
        yield
    finally:
        _deferring -= 1
        if held is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, held)  # a signal held meanwhile is handled here
    if not _deferring and _deferred is not None:
        signum, _deferred = _deferred, None
        raise Interrupted(signum)
