"""How the drawing kernels are compiled: Numba, in nopython mode, releasing the GIL, the machine
code cached in the user's cache folder (user_cache.py: `$XDG_CACHE_HOME/odms-data/numba`, by
default `~/.cache/odms-data/numba`) unless NUMBA_CACHE_DIR names one.

Not in the package's own `__pycache__`, Numba's default: pip does not know of those files, so
they would outlive an uninstall, and the folder left behind would shadow a later (editable)
install of the package as an empty namespace package. Where the folder cannot be written,
Numba falls back to its other places; where none can, the kernels are compiled without a cache.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..user_cache import cache_home


def cache_dir() -> str:
    """The kernels' cache folder when NUMBA_CACHE_DIR names none."""
    return str(cache_home() / "numba")


def kernel(function: Callable[..., Any]) -> Any:
    """`numba.njit(cache=True, nogil=True)(function)`, cached as the module says."""
    import numba

    config: Any = numba.config  # its settings are made at run time, from NUMBA_* variables
    chosen = config.CACHE_DIR
    config.CACHE_DIR = chosen or cache_dir()  # read when the function's cache is set up
    try:
        return numba.njit(cache=True, nogil=True)(function)
    except RuntimeError as e:  # no folder Numba may cache in is writable (a read-only home and install)
        if "no locator available" not in str(e):
            raise
        return numba.njit(nogil=True)(function)  # compiled anew in every process
    finally:
        config.CACHE_DIR = chosen


def will_compile() -> bool:
    """Whether the kernels' cache folder holds no compiled kernel yet, so that their first calls
    compile them (several seconds, where loading them takes milliseconds); cheap, no Numba import."""
    folder = Path(os.environ.get("NUMBA_CACHE_DIR") or cache_dir())
    return not folder.is_dir() or next(folder.rglob("*.nbi"), None) is None
