"""Confining a path taken from data (a CSV cell, a folder listing) to the folder it belongs to.

A name read from a file a stranger may have written must not reach outside its folder: not by
`..`, not by being absolute, not by a symbolic link (or a link in a parent) that resolves
elsewhere. `inside` is the one place that rule is written.
"""

from __future__ import annotations

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
