"""The front door of every importer: an `Importer` plans its store, and the base writes it (a
store of masks with mask_store.py, a store of boxes with store/box_store.py), drops bad sources
and retries, reports one progress signature and answers with one `ImportResult`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from pathlib import Path

from ..store.box_store import write_box_store
from ..store.format import StoreAttrs
from .decoding import Workers
from .mask_store import BadFiles, write_mask_store
from .plan import BoxPlan, MaskPlan
from .result import ImportResult

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


def _write_boxes(plan: BoxPlan, out: str | Path, fmt: str | None, overwrite: bool,
                 step: Callable[[int], None] | None, check: Callable[[StoreAttrs], None]) -> StoreAttrs:
    """Write a store of boxes: nothing to decode, so the format's rules and `check` run before
    anything is written, and the frames are counted once they are."""
    attrs = StoreAttrs(split=plan.split, domain=plan.domain, image_size=plan.image_size, counts={},
                       source=plan.source, oddities=list(plan.oddities))
    write_box_store(str(out), plan.rows, attrs, fmt, overwrite=overwrite, check=check)
    if step:
        step(plan.n_frames)
    return attrs


class Importer(ABC):
    """One store's source, as every importer has it: a plan of the store, a way to leave out the
    sources of bad frames, and a check before the commit. The base (`write`) owns the progress,
    the writing, the retries that leave bad frames out and the result."""

    skip_bad: bool = False  # leave out what `drop` names and retry, rather than fail

    @abstractmethod
    def plan(self) -> MaskPlan | BoxPlan:
        """The store as it stands, skipped sources left out and recorded in its oddities."""

    def drop(self, plan: MaskPlan, failures: list[tuple[int, str]]) -> None:
        """Leave out the sources of these bad frames (frame row, message) of `plan`, recording
        each as a skipped oddity; a source that cannot leave frames out raises BadFiles."""
        raise BadFiles(failures)

    def check(self, attrs: StoreAttrs) -> None:
        """Runs before the commit; may raise to abort, or (a store of masks) amend the attributes:
        rename the split. By default there is nothing to check."""
        return None

    def write(self, out: str | Path, fmt: str | None, workers: Workers | None = None, *,
              label: str | None = None, overwrite: bool = False,
              progress: Progress | None = None) -> ImportResult:
        """Write the store at `out`, masks decoded by `workers` (None: here), reporting
        `progress(label, frames done, frames total)` (label: the split); with skip_bad a bad
        frame's source is dropped and the store planned and written again."""
        while True:
            plan = self.plan()
            step = _counter(label or plan.split, plan.n_frames, progress)
            if isinstance(plan, BoxPlan):
                return ImportResult(str(out), plan.split, _write_boxes(plan, out, fmt, overwrite, step,
                                                                       self.check))
            try:
                attrs = write_mask_store(plan, out, fmt, workers or Workers(1), overwrite=overwrite,
                                         collect_all=self.skip_bad, progress=step, check=self.check)
                return ImportResult(str(out), plan.split, attrs)
            except BadFiles as e:
                if not self.skip_bad:
                    raise
                self.drop(plan, e.failures)
