"""What an importer decides about a store before any mask is decoded: the `Plan`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

DEFAULT_THRESHOLD = 128  # grey masks (JPEG, anti-aliased): pixels >= this are object, on the 8-bit scale


@dataclass
class Plan:
    """Everything an importer decided about a store, before any mask is decoded."""

    split: str
    domain: str
    source: str
    files: list[Path]  # (F,) mask file of each frame row
    z: np.ndarray  # (F,) m
    depth: np.ndarray  # (F,) m, NaN where unknown
    frame_index: np.ndarray  # (E, N) frame rows, padded with -1
    d1: np.ndarray  # (E,) m, NaN when unlabelled
    ids: list[str]
    sources: list[str]
    frames_per_chunk: int
    frames_per_shard: int
    oddities: list[dict[str, str]] = field(default_factory=list)
    threshold: int = DEFAULT_THRESHOLD
