"""`Checkpoint`: what a run keeps of its network (run_folder.py: best.pt and last.pt), as the
keys torch saves: the weights and the iteration, and for resuming (last.pt) the seconds spent,
Adam's state, the random states and the best so far."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..errors import InputError


@dataclass(frozen=True)
class Checkpoint:
    """One checkpoint; `percent_error` is the validation error of best.pt's weights."""

    iteration: int
    model: dict[str, Any]
    percent_error: float | None = None  # best.pt
    seconds: float | None = None  # last.pt: training seconds up to this iteration
    optimizer: dict[str, Any] | None = None
    rng: Any = None  # torch's CPU random state
    cuda_rng: Any = None  # and the GPU's, when trained on one
    best: float | None = None  # the lowest validation error so far, and its iteration
    best_iteration: int | None = None
    best_per_set: dict[str, tuple[float, int]] | None = None  # last.pt: {val split: (error, iteration)}

    def __post_init__(self) -> None:
        if isinstance(self.iteration, bool) or not isinstance(self.iteration, int) or self.iteration < 0:
            raise InputError(f"checkpoint iteration {self.iteration!r} is not a whole number >= 0")
        if not isinstance(self.model, dict):
            kind = type(self.model).__name__
            raise InputError(f"checkpoint holds no weights ('model' is {kind}, not dict)")
        import torch

        bad = [k for k, t in self.model.items() if not isinstance(k, str) or not isinstance(t, torch.Tensor)]
        if bad:
            raise InputError(f"checkpoint weight {bad[0]!r} is not a tensor")
        if self.seconds is not None and not (math.isfinite(self.seconds) and self.seconds >= 0):
            raise InputError(f"checkpoint seconds {self.seconds!r} is not a time")
        if self.best_per_set is not None and not (
            isinstance(self.best_per_set, dict)
            and all(isinstance(k, str) and isinstance(v, tuple | list) and len(v) == 2
                    for k, v in self.best_per_set.items())):
            raise InputError("checkpoint best_per_set is not a table of (error, iteration) by val split")

    def resume_state(self, where: str) -> tuple[dict[str, Any], Any, float]:
        """Adam's state, the CPU random state and the seconds spent, which a resumed run needs."""
        if self.optimizer is None or self.rng is None or self.seconds is None:
            raise InputError(f"{where}: a run cannot resume from it (no optimizer state, random state or "
                             "time)")
        return self.optimizer, self.rng, self.seconds

    def to_json(self) -> dict[str, Any]:
        """The dict torch saves, keys in order, those not set left out."""
        keys = ("iteration", "seconds", "model", "optimizer", "rng", "cuda_rng", "best", "best_iteration",
                "best_per_set", "percent_error")
        return {k: getattr(self, k) for k in keys if getattr(self, k) is not None}

    @classmethod
    def from_json(cls, d: Any, where: str) -> Checkpoint:
        """From a loaded checkpoint; InputError naming `where` when it is not one."""
        if not isinstance(d, dict):
            raise InputError(f"{where}: not an odms-data checkpoint (it holds a {type(d).__name__}, "
                             "not a dict)")
        if "iteration" not in d or "model" not in d:
            raise InputError(f"{where}: not an odms-data checkpoint (no iteration and weights)")
        unknown = sorted(set(d) - set(cls.__dataclass_fields__))
        if unknown:
            raise InputError(f"{where}: not an odms-data checkpoint (unknown key {unknown[0]!r})")
        try:
            return cls(**d)
        except InputError as e:
            raise InputError(f"{where}: {e}") from None
