"""Where the project's shipped files live: schemas/, splits/ and leaderboard/.

A built package carries them in odms_data/_shipped/ (setup.py copies them there); a source
checkout, and an editable install of it, has them at the top of the tree, beside the package.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def resource_dir(name: str) -> Path:
    """The folder `name` (`schemas`, `splits` or `leaderboard`) shipped with odms-data."""
    built, source = _PACKAGE / "_shipped" / name, _PACKAGE.parent / name
    if built.is_dir():
        return built
    if source.is_dir() and (_PACKAGE.parent / "setup.cfg").is_file():
        return source
    raise FileNotFoundError(f"odms-data's {name}/ folder is missing from this installation ({built})")
