"""The front door of every importer: `Importer` plans the store, drops bad sources and retries,
and writes it (a store of masks with mask_store.py), reporting one progress signature.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from pathlib import Path

from ..store.format import StoreAttrs
from .decoding import Workers
from .mask_store import BadFiles, write_mask_store
from .plan import MaskPlan

Progress = Callable[[str, int, int], None]  # (label, done, total): every importer's progress


def _counter(label: str, total: int, progress: Progress | None) -> Callable[[int], None] | None:
    """A step function that adds up the frames written and reports them under `label`."""
    if progress is None:
        return None
    done = 0

    def step(k: int) -> None:
        nonlocal done
        done += k
        progress(label, done, total)

    return step


class Importer(ABC):
    """One store's source, as every importer has it: a plan of the store, a way to leave out the
    sources of bad frames, and a check before the commit. The base (`write`) owns the progress,
    the writing and the retries that leave bad frames out."""

    skip_bad: bool = False  # leave out what `drop` names and retry, rather than fail

    @abstractmethod
    def plan(self) -> MaskPlan:
        """The store as it stands, skipped sources left out and recorded in its oddities."""

    def drop(self, plan: MaskPlan, failures: list[tuple[int, str]]) -> None:
        """Leave out the sources of these bad frames (frame row, message) of `plan`, recording
        each as a skipped oddity; a source that cannot leave frames out raises BadFiles."""
        raise BadFiles(failures)

    def check(self, attrs: StoreAttrs) -> None:
        """Runs before the commit; may amend the attributes (rename the split) or raise to abort.
        By default there is nothing to check."""
        return None

    def write(self, out: str | Path, fmt: str | None, workers: Workers, *, label: str,
              overwrite: bool = False, progress: Progress | None = None) -> StoreAttrs:
        """Write the store at `out`, reporting `progress(label, frames done, frames total)`; with
        skip_bad a bad frame's source is dropped and the store planned and written again."""
        while True:
            plan = self.plan()
            try:
                return write_mask_store(plan, out, fmt, workers, overwrite=overwrite,
                                        collect_all=self.skip_bad,
                                        progress=_counter(label, len(plan.masks), progress), check=self.check)
            except BadFiles as e:
                if not self.skip_bad:
                    raise
                self.drop(plan, e.failures)
