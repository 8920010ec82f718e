"""Progress on stderr that appears only once work is flowing (not before an early error).

On a terminal: a bar with the rate and ETA. Elsewhere (a log file, CI, a pipe), where a bar would
print nothing useful: one line when work starts, one every PERIOD seconds with the count, elapsed
time and ETA, and one when it is done. The ETA is the rate since the first report's: the time
before the first item (workers starting, kernels loading) is no measure of the rest.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import Any

import click

PERIOD = 10.0  # seconds between lines when stderr is not a terminal


def duration(seconds: float) -> str:
    """h:mm:ss, or m:ss under an hour."""
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


class _Lines:
    """Periodic one-line updates: `label: done/total (pct), elapsed, ETA`."""

    def __init__(self, total: int, label: str, clock: Callable[[], float] = time.monotonic) -> None:
        self.total, self.label, self.done, self.clock = total, label, 0, clock
        self.start = clock()
        self.last = -PERIOD
        self.first: tuple[float, int] | None = None  # (time, done) at the first update

    def line(self) -> str:
        now = self.clock()
        pct = 100 * self.done / self.total if self.total else 100.0
        text = f"{self.label}: {self.done}/{self.total} ({pct:.0f}%), {duration(now - self.start)} elapsed"
        if self.first is not None and self.first[1] < self.done < self.total and now > self.first[0]:
            rate = (self.done - self.first[1]) / (now - self.first[0])
            text += f", about {duration((self.total - self.done) / rate)} left"
        return text

    def update(self, n: int) -> None:
        self.done += n
        now = self.clock()
        if self.first is None:
            self.first = (now, self.done)
        if now - self.last >= PERIOD and self.done < self.total:
            click.echo(self.line(), err=True)
            self.last = now

    def close(self) -> None:
        click.echo(self.line(), err=True)


NOTICE_AFTER = 1.0  # seconds without progress before a notice says what is going on


@contextmanager
def progress(total: int, label: str, notice: str | None = None) -> Iterator[Callable[[int], None]]:
    """Yields `update(n)`; nothing is shown before the first update, and no closing line after an
    error (its one line is the last thing on stderr). `notice`, when given, is printed once if no
    update came within NOTICE_AFTER seconds (work that cannot be counted, such as compiling): an
    early error comes before it."""
    shown: Any = None  # click's bar or _Lines
    timer = threading.Timer(NOTICE_AFTER, click.echo, (f"odms-data: {notice}",), {"err": True})
    timer.daemon = True
    if notice:
        timer.start()

    def update(n: int) -> None:
        nonlocal shown
        if shown is None:
            timer.cancel()
            if sys.stderr.isatty():
                shown = click.progressbar(length=total, label=label, file=sys.stderr, show_eta=True)
                shown.__enter__()
            else:
                shown = _Lines(total, label)
        shown.update(n)

    try:
        yield update
    except BaseException:
        if shown is not None and not isinstance(shown, _Lines):
            shown.__exit__(None, None, None)
        raise
    finally:
        timer.cancel()
    if isinstance(shown, _Lines):
        shown.close()
    elif shown is not None:
        shown.__exit__(None, None, None)


class Bars:
    """`progress(label, done, total)` as one bar per label, titled `template.format(label)`, and
    restarted when the count goes back (an import's re-run after skipping)."""

    def __init__(self, template: str) -> None:
        self.template = template
        self.cm: AbstractContextManager[Callable[[int], None]] | None = None
        self.label: str | None = None
        self.last = 0

    def __call__(self, label: str, done: int, total: int) -> None:
        if label != self.label or done < self.last:
            self.close()
            cm = progress(total, self.template.format(label))
            self.update = cm.__enter__()
            self.cm, self.label, self.last = cm, label, 0
        self.update(done - self.last)
        self.last = done

    def close(self) -> None:
        if self.cm is not None:
            self.cm.__exit__(None, None, None)
            self.cm = None

    def __enter__(self) -> Bars:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
