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
    """A write that a stop signal must not cut in two (zarr finishes a write on its own I/O thread
    after the main thread is interrupted, which would leave files behind the clean-up)."""
    global _deferring, _deferred
    _deferring += 1
    try:
        yield
    finally:
        _deferring -= 1
    if not _deferring and _deferred is not None:
        signum, _deferred = _deferred, None
        raise Interrupted(signum)
