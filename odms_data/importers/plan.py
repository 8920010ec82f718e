"""What an importer decides about a store before writing it: a `Plan` of the kind of store it
imports (format.KINDS): a `MaskPlan`, with where each frame's mask comes from (a `MaskSource`: a
mask file, or one instance in a label image), or a `BoxPlan`, whose rows are all there is."""

from __future__ import annotations

import re
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

from ..errors import InputError
from ..store.box_store import BoxRows
from ..store.manifests import split_names
from ..store.oddity import SKIPPED, Oddity

DEFAULT_THRESHOLD = 128  # grey masks (JPEG, anti-aliased): pixels >= this are object, on the 8-bit scale


class MaskSource(Protocol):
    """Where one frame's mask comes from; sent to the decoding workers, so it must pickle.
    `str()` names it in error messages."""

    @property
    def name(self) -> str:
        """Short name for oddity details (a file name)."""
        ...

    def size(self) -> tuple[int, int]:
        """(height, width), without decoding where possible; InputError naming the source."""
        ...

    def read(self, threshold: int, expect: tuple[int, int] | None = None) -> np.ndarray:
        """(H, W) bool mask, True = object; InputError naming the source, also when its size is
        not `expect` (height, width), found before anything is decoded."""
        ...


@dataclass(kw_only=True)
class Plan(ABC):
    """What every importer decides about a store before writing it; a subclass per kind of store
    (format.KINDS) adds its frames and examples."""

    split: str
    domain: str
    source: str
    oddities: list[Oddity] = field(default_factory=list)

    @property
    @abstractmethod
    def n_frames(self) -> int:
        """The store's frames, which progress counts."""


@dataclass(kw_only=True)
class MaskPlan(Plan):
    """Everything an importer decided about a store of masks, before any mask is decoded."""

    masks: Sequence[MaskSource]  # (F,) where each frame row's mask comes from
    z: np.ndarray  # (F,) m
    depth: np.ndarray  # (F,) m, NaN where unknown
    frame_index: np.ndarray  # (E, N) frame rows, padded with -1
    d1: np.ndarray  # (E,) m, NaN when unlabelled
    ids: list[str]
    sources: list[str]
    frames_per_chunk: int
    frames_per_shard: int
    threshold: int = DEFAULT_THRESHOLD
    id_room: int = 0  # bytes kept free in the id array, for a split renamed before the commit

    @property
    def n_frames(self) -> int:
        return len(self.masks)


@dataclass(kw_only=True)
class BoxPlan(Plan):
    """A store of boxes: its rows (store/box_store.py) and image size; nothing is left to decode."""

    rows: BoxRows
    image_size: tuple[int, int]  # (height, width) of the images the boxes were found in

    @property
    def n_frames(self) -> int:
        return int(self.rows.boxes.shape[0] * self.rows.boxes.shape[1])


@dataclass
class Skips:
    """The sources an import leaves out: with `skip_bad` each is recorded as an oddity of kind
    "skipped", otherwise its problem is raised."""

    skip_bad: bool
    oddities: list[Oddity] = field(default_factory=list)

    def add(self, subject: str, problem: str | InputError) -> None:
        """Leave out `subject` for `problem`, or raise it (an InputError) without skip_bad."""
        if not self.skip_bad:
            raise problem if isinstance(problem, InputError) else InputError(problem)
        self.oddities.append(Oddity(SKIPPED, subject, str(problem)))


def store_name(name: str | None, out: Path, fallback: str, kind: str) -> str:
    """The split name of an imported store: `name`, else the output's name up to its first dot
    (else `fallback`, else `kind`, the kind of store) with other characters than letters, digits,
    '.', '_' and '-' replaced; never an official split's name."""
    if name is None:
        name = re.sub(r"[^A-Za-z0-9._-]", "-", out.name.split(".")[0] or fallback).lstrip("._-")
        name = name or kind
    if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*", name):
        raise InputError(f"name '{name}': use letters, digits, '.', '_' and '-', starting with a letter "
                         "or digit")
    if name in split_names():
        raise InputError(f"name '{name}' is an official split; choose another name for the {kind} store")
    return name
