"""Where the project's shipped files live: schemas/, splits/ and leaderboard/.

In a source checkout (and an editable install) they sit beside the package; a wheel installs
them under `<prefix>/share/odms-data/`.
"""

from __future__ import annotations

import sys
from pathlib import Path


def resource_dir(name: str) -> Path:
    """The folder `name` (`schemas`, `splits` or `leaderboard`) shipped with odms-data."""
    for root in (Path(__file__).resolve().parents[1], Path(sys.prefix) / "share" / "odms-data"):
        if (root / name).is_dir():
            return root / name
    raise FileNotFoundError(f"odms-data's {name}/ folder is missing from this installation")
