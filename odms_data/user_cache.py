"""The user's cache folder, where the project keeps what it can make again: Numba's compiled
kernels, the default data folder of ground-truth stores (and the tests' imported official stores).

It is `$XDG_CACHE_HOME/odms-data`, else `~/.cache/odms-data`. The XDG Base Directory
specification holds a relative XDG_CACHE_HOME invalid; it is refused here rather than read
against the working folder, where it would scatter cache folders.
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import InputError

VARIABLE = "XDG_CACHE_HOME"
SHOWN = f"${VARIABLE}/odms-data, else ~/.cache/odms-data"  # the folder, as help texts name it


def cache_home() -> Path:
    """The project's cache folder; InputError when XDG_CACHE_HOME is set to a relative path."""
    base = os.environ.get(VARIABLE, "")
    if not base:
        return Path.home() / ".cache" / "odms-data"
    if not os.path.isabs(base):
        raise InputError(f"{VARIABLE} '{base}' is a relative path; the XDG Base Directory specification "
                         "allows only an absolute one: set it to an absolute path or unset it")
    return Path(base) / "odms-data"
