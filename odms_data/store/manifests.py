"""Named splits: the manifests in splits/ (count, how to make or import it, content digest)."""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import Any

from .. import safe_json
from ..errors import DigestMismatchError, InputError
from ..resources import resource_dir
from .format import StoreAttrs


@dataclass(frozen=True)
class SplitManifest:
    """One file of splits/: what a named split holds and the digest it must have."""

    name: str
    origin: str  # "generated" or "imported" (the key "kind" in the file)
    count: int
    digest: str
    generator: dict[str, Any] | None = None  # preset, seed, params overrides (generated)
    source: str | None = None  # what it is imported from (imported)

    @property
    def generator_version(self) -> int | None:
        """The generator version whose content the digest is (generated splits)."""
        return None if self.generator is None else self.generator.get("version", 1)

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> SplitManifest:
        return cls(**{("origin" if k == "kind" else k): v for k, v in d.items()})


def split_names() -> list[str]:
    return sorted(p.stem for p in resource_dir("splits").glob("*.json"))


def load_manifest(name: str) -> SplitManifest:
    """The manifest of split `name`; an unknown name raises InputError listing the known ones."""
    path = resource_dir("splits") / f"{name}.json"
    if not path.is_file():
        close = difflib.get_close_matches(name, split_names(), n=1)
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise InputError(f"unknown split '{name}'{hint}; known splits: {', '.join(split_names())}")
    return SplitManifest.from_json(safe_json.load_file(path))


def check_against_manifest(attrs: StoreAttrs, manifest: SplitManifest, where: str) -> None:
    """Raise DigestMismatchError saying exactly what differs between a store and its manifest."""
    diffs = []
    if attrs.counts["examples"] != manifest.count:
        diffs.append(f"{attrs.counts['examples']} examples, manifest says {manifest.count}")
    if attrs.digest != manifest.digest:
        diffs.append(f"digest {attrs.digest}, manifest says {manifest.digest}")
    if diffs:
        raise DigestMismatchError(f"{where}: does not match split '{manifest.name}': " + "; ".join(diffs))
