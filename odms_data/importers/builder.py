"""The front door of every importer: an `Importer` plans its store, and the base has the store
builder (store/build.py) write it (a store of masks from mask_store.py's source, a store of boxes
from store/box_store.py's), drops bad sources and retries, and answers with one `ImportResult`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from pathlib import Path

from ..store.box_store import BoxRowsSource
from ..store.build import BadFiles, Progress, Source, build
from ..store.format import StoreAttrs
from .decoding import Workers
from .mask_store import ImportedMasks
from .plan import BoxPlan, MaskPlan
from .result import ImportResult


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
            source: Source
            if isinstance(plan, BoxPlan):
                attrs = StoreAttrs(split=plan.split, domain=plan.domain, image_size=plan.image_size,
                                   counts={}, source=plan.source, oddities=list(plan.oddities))
                source = BoxRowsSource(str(out), plan.rows, attrs, self.check)
            else:
                source = ImportedMasks(plan, self.skip_bad, self.check)
            try:
                attrs = build(source, str(out), fmt, workers=workers or Workers(1), overwrite=overwrite,
                              label=label or plan.split, progress=progress)
                return ImportResult(str(out), plan.split, attrs)
            except BadFiles as e:
                if not self.skip_bad or not isinstance(plan, MaskPlan):
                    raise
                self.drop(plan, e.failures)
