"""Confining a path taken from data (a CSV cell, a folder listing) to the folder it belongs to.

A name read from a file a stranger may have written must not reach outside its folder: not by
`..`, not by being absolute, not by a symbolic link (or a link in a parent) that resolves
elsewhere. `inside` is the one place that rule is written.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from .errors import InputError


def inside(root: Path, name: str | Path, where: str) -> Path:
    """`root / name`, once it is sure to lie inside `root` with every link resolved; InputError
    starting with `where` (the file, row and column the name comes from) otherwise."""
    if Path(name).is_absolute():
        raise InputError(f"{where}: '{name}' is an absolute path; give a path inside {root}")
    path = root / name
    try:
        outside = not path.resolve().is_relative_to(root.resolve())
    except (OSError, RuntimeError) as e:  # a link loop
        raise InputError(f"{where}: '{name}' cannot be resolved ({e})") from None
    if outside:
        raise InputError(f"{where}: '{name}' lies outside {root} (through '..' or a link); "
                         f"give a path inside it")
    return path


def listed_inside(folder: Path, keep: Callable[[Path], bool]) -> list[Path]:
    """The entries of `folder` that `keep` accepts, each sure to lie inside it (as `inside` makes
    sure): a name from the folder's own listing holds no separator, so only a link is resolved;
    one lookup for a folder of thousands of files, not one for every component of every path."""
    with os.scandir(folder) as entries:
        listed = [(folder / e.name, e.is_symlink()) for e in entries]
    return [inside(folder, p.name, str(folder)) if link else p for p, link in listed if keep(p)]
