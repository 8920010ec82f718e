"""Reading ODMD's pickled sets without running anything a pickle may carry.

ODMD (Griffin & Corso, CVPR 2021) ships its val/test sets as Python pickles (protocol 3) of
dicts holding strings, numbers, lists and NumPy arrays. A pickle can name any importable
callable and have the reader call it, so `pickle.load` on a stranger's file runs the stranger's
code. This reader resolves exactly three names, and to stand-ins of its own, never to the real
callables:

- `numpy.core.multiarray._reconstruct` (or `numpy._core...`), called only as NumPy pickles an
  array: `(numpy.ndarray, (0,), b'b')`;
- `numpy.ndarray`, only as that call's first argument;
- `numpy.dtype`, only for a plain numeric or boolean code (`f8`, `i4`, `u1`, `b1`, ...).

An array is built from its state only after its declared shape, dtype and byte count agree and
stay within bounds. The file itself is bounded before any byte is unpickled. Anything else is
refused with a one-line InputError naming the file.
"""

from __future__ import annotations

import io
import math
import pickle
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError

MAX_FILE_BYTES = 256 * 2**20  # ODMD's largest set is 2.6 MB
MAX_ELEMENTS = 32 * 2**20  # per array
MAX_DIMS = 8
MAX_DEPTH = 32  # nesting of dicts, lists and tuples
DTYPE_CODES = frozenset(f"{k}{n}" for k, ns in {"f": (2, 4, 8), "i": (1, 2, 4, 8), "u": (1, 2, 4, 8)}.items()
                        for n in ns) | {"b1"}
BYTE_ORDERS = frozenset("<>|=")


class _Refused(Exception):
    """Raised inside the unpickler; reported as one InputError line naming the file."""


class _NdarrayMark:
    """Stands for `numpy.ndarray` as the first argument of `_reconstruct`."""


class _DtypeRecipe:
    """A dtype as declared: its code, then its byte order (set by BUILD)."""

    def __init__(self, code: Any, align: Any = False, copy: Any = True) -> None:
        if not isinstance(code, str) or code not in DTYPE_CODES:
            raise _Refused(f"dtype {code!r} is not a plain numeric type")
        self.code, self.order = code, "|"

    def __setstate__(self, state: Any) -> None:
        if not (isinstance(state, tuple) and len(state) == 8 and state[0] == 3 and state[1] in BYTE_ORDERS
                and state[2:5] == (None, None, None)):
            raise _Refused(f"dtype state {str(state)[:60]!r} is not that of a plain numeric type")
        self.order = state[1]

    def dtype(self) -> np.dtype:
        return np.dtype(("<" if self.order == "<" else ">" if self.order == ">" else "=") + self.code)


class _ArrayRecipe:
    """An array as declared; `array()` builds it once BUILD has given its state."""

    def __init__(self) -> None:
        self.value: np.ndarray | None = None

    def __setstate__(self, state: Any) -> None:
        if not (isinstance(state, tuple) and len(state) == 5 and state[0] == 1):
            raise _Refused("an array's state is not (1, shape, dtype, fortran, bytes)")
        _, shape, dtype, fortran, data = state
        if not (isinstance(shape, tuple) and len(shape) <= MAX_DIMS
                and all(type(n) is int and n >= 0 for n in shape)):
            raise _Refused(f"an array declares the shape {str(shape)[:60]}")
        count = math.prod(shape)
        if count > MAX_ELEMENTS:
            raise _Refused(f"an array declares {count} elements (at most {MAX_ELEMENTS} are read)")
        if not isinstance(dtype, _DtypeRecipe) or not isinstance(fortran, bool):
            raise _Refused("an array's dtype or order is not a plain one")
        dt = dtype.dtype()
        if not isinstance(data, bytes) or len(data) != count * dt.itemsize:
            size = len(data) if isinstance(data, bytes) else type(data).__name__
            raise _Refused(f"an array of shape {shape} and dtype {dt} carries {size} bytes, "
                           f"not {count * dt.itemsize}")
        flat = np.frombuffer(data, dt).astype(dt.newbyteorder("="))
        self.value = flat.reshape(shape, order="F" if fortran else "C")


def _reconstruct(cls: Any, shape: Any, typecode: Any) -> _ArrayRecipe:
    if cls is not _NdarrayMark or shape != (0,) or typecode != b"b":
        raise _Refused("_reconstruct is called otherwise than for a NumPy array")
    return _ArrayRecipe()


_ALLOWED: dict[tuple[str, str], Any] = {
    ("numpy.core.multiarray", "_reconstruct"): _reconstruct,
    ("numpy._core.multiarray", "_reconstruct"): _reconstruct,
    ("numpy", "ndarray"): _NdarrayMark,
    ("numpy", "dtype"): _DtypeRecipe,
}


class _Unpickler(pickle._Unpickler):
    """The pure-Python unpickler: its memo is a dict, so a declared memo index allocates nothing."""

    def find_class(self, module: str, name: str) -> Any:
        try:
            return _ALLOWED[(module, name)]
        except KeyError:
            raise _Refused(f"it names {module}.{name}, which is not a NumPy array part") from None

    def persistent_load(self, pid: Any) -> Any:
        raise _Refused("it holds a persistent reference")


def _resolved(obj: Any, depth: int = 0) -> Any:
    """`obj` with every array recipe replaced by its array; anything else foreign refused."""
    if depth > MAX_DEPTH:
        raise _Refused(f"it nests deeper than {MAX_DEPTH} levels")
    if isinstance(obj, _ArrayRecipe):
        if obj.value is None:
            raise _Refused("an array is declared but never given its data")
        return obj.value
    if isinstance(obj, dict):
        return {_resolved(k, depth + 1): _resolved(v, depth + 1) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return type(obj)(_resolved(v, depth + 1) for v in obj)
    if obj is None or isinstance(obj, bool | int | float | str | bytes):
        return obj
    raise _Refused(f"it holds a {type(obj).__name__}, which an ODMD set does not")


def load_pickle(path: str | Path) -> Any:
    """The content of the pickle at `path`: dicts, lists, tuples, numbers, strings and arrays."""
    p = Path(path)
    try:
        with open(p, "rb") as f:
            data = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise InputError(f"{p}: cannot read ({e.strerror or e})") from None
    if len(data) > MAX_FILE_BYTES:
        raise InputError(f"{p}: larger than {MAX_FILE_BYTES // 2**20} MiB, not an ODMD set")
    try:
        return _resolved(_Unpickler(io.BytesIO(data)).load())
    except _Refused as e:
        raise InputError(f"{p}: refused: {e}") from None
    except RecursionError:
        raise InputError(f"{p}: refused: it nests too deeply") from None
    except Exception as e:  # a malformed stream: pickle, struct, memory or type errors alike
        msg = str(e).splitlines()[0][:120] if str(e) else type(e).__name__
        raise InputError(f"{p}: not a readable ODMD pickle ({msg})") from None
