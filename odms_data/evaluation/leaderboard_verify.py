"""`leaderboard verify`: re-score every computed entry that ships its predictions, and say which of
its figures no longer match.

An entry ships its predictions as the CSV beside it with its name (`mynet.json`, `mynet.csv`);
the file must be the one it was scored from (its sha256 is the entry's `predictions_sha256`). It
is scored again as `score --entry` scores it, its stores checked against the split manifests.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import OdmsError
from ..inputs import open_input
from .evaluate import Evaluation
from .leaderboard import ALL_KEYS, LeaderboardEntry, entry_from_report

ALL_LABELS = {"all": "All", "all_ci95": "All ci95"}


@dataclass(frozen=True)
class Verdict:
    """What re-scoring one entry found: `differences`, one line each (none: every figure matches)."""

    name: str
    predictions: Path
    differences: list[str]
    figures: int  # how many figures were compared


def predictions_of(entry_file: Path) -> Path | None:
    """The predictions file an entry ships (the CSV beside it with its name), or None."""
    csv = entry_file.with_suffix(".csv")
    return csv if csv.is_file() else None


def _compare(entry: LeaderboardEntry, again: LeaderboardEntry) -> tuple[list[str], int]:
    """Each figure of `entry` (means, intervals, store digests) that `again` does not repeat."""
    out, count = [], 0
    for family, sets in entry.results.items():
        now_sets = again.results.get(family, {})
        for d, figures in sets.items():
            pairs = [(d, figures, now_sets.get(d))] if d in ALL_KEYS else [
                (k, v, (now_sets.get(d) or {}).get(k)) for k, v in figures.items()]
            for what, was, now in pairs:
                count += 1
                if was != now:
                    label = f"{family} {ALL_LABELS[d]}" if d in ALL_KEYS else f"{family} {d} {what}"
                    out.append(f"{label}: the entry says {was}, its predictions now give {now}")
    stores, now_stores = (entry.scored or {}).get("stores", {}), (again.scored or {}).get("stores", {})
    out += [f"store {s}: the entry was scored against {stores.get(s)}, now {now_stores.get(s)}"
            for s in sorted(set(stores) | set(now_stores)) if stores.get(s) != now_stores.get(s)]
    return out, count + len(stores)


def verify_entry(entry_file: Path, entry: LeaderboardEntry, data: Sequence[str],
                 progress: Callable[[str, int, int], None] | None = None) -> Verdict:
    """Re-score `entry` (read from `entry_file`) from the predictions it ships."""
    predictions = predictions_of(entry_file)
    assert predictions is not None and entry.scored is not None
    with open_input(predictions, "a predictions file") as f:
        sha = hashlib.file_digest(f, "sha256").hexdigest()
    if sha != entry.scored["predictions_sha256"]:
        return Verdict(entry.name, predictions, [f"{predictions.name} is not the file the entry was scored "
                                                 f"from (sha256 {sha})"], 0)
    try:
        _, report = Evaluation(data).score(predictions, verify=True, progress=progress)
        again = entry_from_report(report, entry.name, predictions_sha256=sha)
    except OdmsError as e:
        return Verdict(entry.name, predictions, [f"cannot be scored again: {e}"], 0)
    differences, count = _compare(entry, again)
    return Verdict(entry.name, predictions, differences, count)
