"""`Evaluation`: what `odms-data score` and `odms-data baseline` run, over the ground-truth stores
of some data folders (ground_truth.py): score a predictions file, or run a baseline
(VOS-DE, Box_LS) over stores named by path or by split."""

from __future__ import annotations

import difflib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from ..protocol import observation_indices, split_order
from ..store.build import Progress
from ..store.reader import Store, open_store
from .baseline_result import BaselineCounts, BaselineResult
from .compare import Comparison, compare
from .ground_truth import (
    Location,
    SplitTruth,
    data_locations,
    find_stores,
    load_truth,
    location,
    stores_by_split,
    verify_truth,
)
from .predictions import Predictions, read_predictions, write_predictions
from .scoring import ScoreReport, score


@dataclass(frozen=True)
class Evaluation:
    """The benchmark's evaluation over the stores in `data` (folders or stores; none: $ODMS_DATA,
    else the default folder)."""

    data: Sequence[str] = ()

    def stores(self, names: Sequence[str] = ()) -> list[Location]:
        """The stores `names` gives (paths, or splits looked up in the data folders; a store named
        twice counts once), or every store of the data folders in split order."""
        if not names:
            every = find_stores(data_locations(self.data))
            return [every[s] for s in sorted(every, key=split_order)]
        paths = []
        found: dict[str, Location] | None = None
        for s in names:
            if isinstance(location(s), str) or Path(s).exists():
                paths.append(location(s))
                continue
            found = found if found is not None else find_stores(data_locations(self.data))
            if s not in found:
                close = difflib.get_close_matches(s, list(found), n=1)
                hint = f"; did you mean {close[0]}?" if close else ""
                raise InputError(f"{s}: neither a store path nor a split in the data folders{hint} "
                                 f"(they hold: {', '.join(sorted(found))})")
            paths.append(found[s])
        return list(stores_by_split(paths).values())

    def score(
        self, predictions: str | Path, *, allow_partial: bool = False, verify: bool = False,
        progress: Progress | None = None, intervals: bool = True, n_obs: int | None = None,
    ) -> tuple[Predictions, ScoreReport]:
        """The predictions file as read, and its score against the stores of the data folders.
        With `verify` (what a leaderboard entry needs) a complete score's stores are checked
        against their digests and manifests first (verify_truth), with `progress(split, frames
        done, frames total)`. `intervals`: each mean's and All's 95 % interval (scoring.score).
        `n_obs`, the observations the predictions used, is refused beyond a scored example's own
        (protocol.observation_indices, as every command refuses it)."""
        stores = find_stores(data_locations(self.data))
        truths = {split: load_truth(path) for split, path in stores.items()}
        preds = read_predictions(predictions, max_rows=sum(len(t.example_ids) for t in truths.values()))
        report = score(preds, truths, allow_partial=allow_partial, intervals=intervals)
        if n_obs is not None:
            _check_observations([truths[split] for split in sorted(report.digests)], n_obs)
        if verify and not report.partial:
            for split in sorted(report.digests):
                verify_truth(truths[split], progress)
        return preds, report

    def compare(self, a: str | Path, b: str | Path) -> Comparison:
        """The paired comparison of two predictions files on the same stores (compare.py)."""
        stores = find_stores(data_locations(self.data))
        truths = {split: load_truth(path) for split, path in stores.items()}
        limit = sum(len(t.example_ids) for t in truths.values())
        reports = [score(read_predictions(p, max_rows=limit), truths, intervals=False) for p in (a, b)]
        return compare(*reports)

    def baseline(
        self, stores: Sequence[Location], output: str | Path, method: Callable[[Store], BaselineResult], *,
        overwrite: bool = False, progress: Callable[[int], None] = lambda n: None,
    ) -> tuple[int, list[BaselineCounts]]:
        """Write the predictions file of `method` (a baseline over one open store: vosde, box_ls)
        for `stores` (as `stores()` gives them); the number of predictions and each store's
        counts. `progress(1)` after each store."""
        rows, counts = [], []
        for p in stores:
            with open_store(str(p)) as s:
                r = method(s)
            progress(1)
            rows += r.rows()
            counts.append(r.counts())
        write_predictions(output, rows, overwrite=overwrite)
        return len(rows), counts


def _check_observations(truths: Sequence[SplitTruth], n_obs: int) -> None:
    """InputError naming the store when an example of `truths` has fewer than `n_obs` observations,
    as every command refuses it (protocol.observation_indices)."""
    for t in truths:
        try:
            observation_indices(int(t.n_obs.min()) if len(t.n_obs) else n_obs, n_obs)
        except InputError as e:
            raise InputError(f"{t.path}: {e}") from None
