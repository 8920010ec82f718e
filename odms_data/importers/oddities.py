"""Oddities an imported store's data shows (z not increasing, tiny z steps, missing depths, empty
masks), recorded per example in the store's attributes rather than refused."""

from __future__ import annotations

import numpy as np

from ..store.format import Z_ODDITY
from ..store.oddity import Oddity
from .plan import MaskPlan

TINY_Z_STEP = 1e-4  # m; steps below this (but above 0) are recorded as an oddity


def example_oddities(plan: MaskPlan, area: np.ndarray) -> list[Oddity]:
    """Per-example oddities the data shows, in example order."""
    out: list[Oddity] = []
    for e, row in enumerate(plan.frame_index):
        frames = row[row >= 0]
        names = [plan.masks[f].name for f in frames]
        steps = np.diff(plan.z[frames])
        if np.any(steps <= 0):
            j = int(np.argmax(steps <= 0))
            out.append(Oddity(Z_ODDITY, plan.ids[e], (
                f"z goes from {plan.z[frames[j]]!r} m ({names[j]}) to {plan.z[frames[j + 1]]!r} m "
                f"({names[j + 1]}); kept as released")))
        elif np.any(steps < TINY_Z_STEP):
            j = int(np.argmax(steps < TINY_Z_STEP))
            out.append(Oddity("z-step-tiny", plan.ids[e], (
                f"{names[j]} and {names[j + 1]} are {steps[j] * 1e6:.3g} micrometres apart")))
        finite = np.isfinite(plan.depth[frames])
        if finite.any() and not finite.all():
            bad = [n for n, ok in zip(names, finite, strict=True) if not ok]
            out.append(Oddity("depth-not-finite", plan.ids[e], f"no finite depth at {', '.join(bad)}"))
        empty = [n for n, f in zip(names, frames, strict=True) if area[f] == 0]
        if empty:
            out.append(Oddity("empty-mask", plan.ids[e], f"empty mask at {', '.join(empty)}"))
    return out
