"""What a baseline method (VOS-DE, Box_LS) gives for one store: its estimates, and the counts
`odms-data baseline` prints."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError


@dataclass
class BaselineResult:
    """A baseline's estimates of one store's examples, in store order."""

    split: str
    example_ids: list[str]
    d1: np.ndarray  # (E,) estimated depth, m; 0 where unsolvable
    unsolvable: np.ndarray  # (E,) bool, A^T A singular
    flag: str  # what else the method marks: "empty_masks" (VOS-DE), "missing_detections" (Box_LS)
    flagged: np.ndarray  # (E,) bool, such an observation among the used ones
    ill_conditioned: np.ndarray  # (E,) bool, solved with A^T A's condition number past 1 / eps

    def rows(self) -> list[tuple[str, str, float]]:
        return [(self.split, e, float(d)) for e, d in zip(self.example_ids, self.d1, strict=True)]

    def counts(self) -> BaselineCounts:
        return BaselineCounts(self.split, len(self.d1), int(self.unsolvable.sum()), self.flag,
                              int(self.flagged.sum()), int(self.ill_conditioned.sum()))


@dataclass(frozen=True)
class BaselineCounts:
    """One store's baseline run: its examples, those unsolvable (predicted 0), those the method
    flags (`flag`: empty masks for VOS-DE, missing detections for Box_LS) and those solved but
    ill-conditioned (their estimate rounding noise, kept as the authors' code gives it)."""

    split: str
    examples: int
    unsolvable: int
    flag: str
    flagged: int
    ill_conditioned: int = 0

    def __post_init__(self) -> None:
        if not 0 <= max(self.unsolvable, self.flagged, self.ill_conditioned) <= self.examples:
            raise InputError(f"split {self.split}: counts must lie between 0 and its {self.examples} "
                             "examples")

    def to_json(self) -> dict[str, Any]:
        return {"split": self.split, "examples": self.examples, "unsolvable": self.unsolvable,
                "ill_conditioned": self.ill_conditioned, self.flag: self.flagged}
