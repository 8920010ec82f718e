"""Reading JSON that may come from a stranger: its size and nesting depth are bounded before it is
parsed, so a file of 100,000 nested brackets is a one-line error, not a RecursionError; its numbers
are finite and its integers at most MAX_DIGITS long (10^400 overflowed the floats it meets later).

Every JSON read of odms-data (arguments, store attributes, zarr.json, run configs, manifests,
leaderboard entries) goes through `loads` or `load_file`; the caller names the error type.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError, OdmsError
from .inputs import read_input

MAX_DEPTH = 64  # the deepest JSON odms-data writes is 4 levels
MAX_BYTES = 64 * 2**20  # store attributes with a long oddity list stay far below
MAX_DIGITS = 20  # of an integer: 2^64 - 1, the largest seed, has 20
_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.S)
_OPEN, _CLOSE = np.frombuffer(b"[{", np.uint8), np.frombuffer(b"]}", np.uint8)


def depth(raw: bytes) -> int:
    """The deepest nesting of brackets in the JSON text `raw`, outside strings."""
    skeleton = np.frombuffer(_STRING.sub(b"", raw), np.uint8)
    steps = np.isin(skeleton, _OPEN).astype(np.int64) - np.isin(skeleton, _CLOSE)
    return int(np.cumsum(steps).max(initial=0))


def loads(text: str | bytes, where: str, error: type[OdmsError] = InputError,
          max_bytes: int = MAX_BYTES) -> Any:
    """The JSON value of `text`; `error` naming `where` when it is too large, too deep or not JSON."""
    raw = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else bytes(text)
    if len(raw) > max_bytes:
        raise error(f"{where}: JSON of {len(raw)} bytes, more than the {max_bytes} odms-data reads")
    if depth(raw) > MAX_DEPTH:
        raise error(f"{where}: JSON nested deeper than {MAX_DEPTH} levels")
    try:
        return json.loads(raw, parse_int=_integer, parse_float=_finite, parse_constant=_no_constant)
    except ValueError as e:  # UnicodeDecodeError and the three above's included
        raise error(f"{where}: not valid JSON ({e})") from None


def _integer(text: str) -> int:
    digits = len(text) - text.startswith("-")
    if digits > MAX_DIGITS:
        raise ValueError(f"an integer of {digits} digits, more than {MAX_DIGITS}")
    return int(text)


def _finite(text: str) -> float:
    x = float(text)
    if not math.isfinite(x):
        raise ValueError(f"the number {text[:24]} is too large")
    return x


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number")


def load_file(path: str | Path, error: type[OdmsError] = InputError, max_bytes: int = MAX_BYTES) -> Any:
    """The JSON value of the regular file at `path` (inputs.py), refused past `max_bytes`."""
    return loads(read_input(path, "a JSON file", max_bytes, error), str(path), error, max_bytes)
