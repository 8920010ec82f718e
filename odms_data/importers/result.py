"""What an import wrote: `ImportResult` (one per store, every importer's answer), with the
SYNTHIA importer's `SynthiaSummary` of its sequences."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..errors import InputError
from ..store.format import StoreAttrs
from ..store.oddity import skipped_details


@dataclass(frozen=True)
class SequenceCounts:
    """One SYNTHIA sequence: its frames, and its tracks and examples of each class."""

    name: str
    frames: int
    tracks: dict[str, int]
    examples: dict[str, int]

    def __post_init__(self) -> None:
        counts = [self.frames, *self.tracks.values(), *self.examples.values()]
        if any(not isinstance(n, int) or n < 0 for n in counts):
            raise InputError(f"sequence {self.name}: counts must be whole numbers >= 0")

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "frames": self.frames, "tracks": dict(self.tracks),
                "examples": dict(self.examples)}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> SequenceCounts:
        return cls(d["name"], d["frames"], dict(d["tracks"]), dict(d["examples"]))


@dataclass(frozen=True)
class SynthiaSummary:
    """A SYNTHIA import: the store written and, per sequence, what it gave."""

    store: str
    split: str
    camera: str
    examples: int
    frames: int
    digest: str
    skipped: tuple[str, ...]
    oddities: int
    sequences: tuple[SequenceCounts, ...]

    def __post_init__(self) -> None:
        if min(self.examples, self.frames, self.oddities) < 0:
            raise InputError(f"{self.store}: counts must be >= 0")

    def to_json(self) -> dict[str, Any]:
        return {
            "store": self.store, "split": self.split, "camera": self.camera, "examples": self.examples,
            "frames": self.frames, "digest": self.digest, "skipped": list(self.skipped),
            "oddities": self.oddities, "sequences": [s.to_json() for s in self.sequences],
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> SynthiaSummary:
        return cls(d["store"], d["split"], d["camera"], d["examples"], d["frames"], d["digest"],
                   tuple(d["skipped"]), d["oddities"], tuple(map(SequenceCounts.from_json, d["sequences"])))


@dataclass(frozen=True)
class ImportResult:
    """One store an importer wrote, or kept: its path, the split name asked for, its attributes and
    (SYNTHIA) the summary of its sequences."""

    path: str
    name: str
    attrs: StoreAttrs
    summary: SynthiaSummary | None = None
    kept: bool = False  # the store was there already, complete and matching its manifest (a resumed import)

    @property
    def skipped(self) -> list[str]:
        """What was left out as bad (skip_bad), one line each."""
        return skipped_details(self.attrs.oddities)

    @property
    def matches_manifest(self) -> bool:
        """False when the store was renamed because its content differs from its split's manifest."""
        return self.attrs.split == self.name
