"""Reading pickles and PyTorch checkpoints that may come from a stranger, without running anything
they carry and within bounds. Every untrusted pickle odms-data reads goes through here: ODMD's sets
(`load_pickle`), checkpoints, a run's or one given with `--checkpoint` (`load_checkpoint`), and
NumPy `.npy` files of camera poses (`load_npy`: never unpickled, the header checked first).

A pickle can name any importable callable and have the reader call it, so `pickle.load` on a
stranger's file runs the stranger's code. Before anything is built, `_bound_structure` walks the
pickle's opcodes and refuses one that reaches more than MAX_REACHED elements from its root (an
element shared through the memo counts each time it is reached: a few hundred bytes of shared
lists stand for billions), nests deeper than MAX_DEPTH (a dict key nested a million deep overflowed
the C stack when hashed) or loops back on itself; the walk keeps its own stack, never Python's.

ODMD (Griffin & Corso, CVPR 2021) ships its val/test sets as Python pickles (protocol 3) of
dicts holding strings, numbers, lists and NumPy arrays. Their reader resolves exactly three names,
and to stand-ins of its own, never to the real callables:

- `numpy.core.multiarray._reconstruct` (or `numpy._core...`), called only as NumPy pickles an
  array: `(numpy.ndarray, (0,), b'b')`;
- `numpy.ndarray`, only as that call's first argument;
- `numpy.dtype`, only for a plain numeric or boolean code (`f8`, `i4`, `u1`, `b1`, ...).

An array is built from its state only after its declared shape, dtype and byte count agree and
stay within bounds. A checkpoint (torch's zip, or the legacy stream ODMD's pretrained DBox is) is
read in full once its size is bounded; every zip record must be stored uncompressed, as torch
writes them (a deflated record declares its own, unbounded size), and its pickles are read first
with stand-ins for what they name: dicts, dense tensors of plain dtypes and their storages, nothing
else (no sparse, quantised or other layout the models never hold); every tensor must lie within
its storage and every storage match the bytes the file holds. Only then does torch build it
(`weights_only`). Anything else is refused with a one-line InputError naming the file.
"""

from __future__ import annotations

import io
import math
import os
import pickle
import pickletools
import zipfile
from pathlib import Path
from typing import IO, Any

import numpy as np

from .errors import InputError
from .inputs import open_input, read_input

MAX_FILE_BYTES = 256 * 2**20  # ODMD's largest set is 2.6 MB
MAX_ELEMENTS = 32 * 2**20  # per array
MAX_DIMS = 8
MAX_DEPTH = 32  # nesting of containers and calls: ODMD's sets nest 7, a DBox run's last.pt 8
MAX_REACHED = 1 << 20  # elements reached from a pickle's root: ODMD's sets 176, a DBox run's last.pt 1627
MAX_CHECKPOINT_BYTES = 64 << 20  # an ODN run's last.pt at n_obs 100 is 26 MiB, DBox's pretrained 2.4 MB
MAX_RECORDS = 4096  # in a checkpoint's zip: one per tensor storage, and five more
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


_MARK = object()  # a MARK on the walk's stack
_LEAVES = frozenset({
    "INT", "BININT", "BININT1", "BININT2", "LONG", "LONG1", "LONG4", "STRING", "BINSTRING", "SHORT_BINSTRING",
    "BINBYTES", "SHORT_BINBYTES", "BINBYTES8", "BYTEARRAY8", "NONE", "NEWTRUE", "NEWFALSE", "UNICODE",
    "SHORT_BINUNICODE", "BINUNICODE", "BINUNICODE8", "FLOAT", "BINFLOAT", "GLOBAL", "PERSID"})
_EMPTY = frozenset({"EMPTY_LIST", "EMPTY_DICT", "EMPTY_SET", "EMPTY_TUPLE"})
_FROM_MARK = frozenset({"TUPLE", "LIST", "DICT", "FROZENSET", "INST", "OBJ"})
_ADD_FROM_MARK = frozenset({"APPENDS", "SETITEMS", "ADDITEMS"})
_POPS_INTO_NEW = {"TUPLE1": 1, "TUPLE2": 2, "TUPLE3": 3, "REDUCE": 2, "NEWOBJ": 2, "NEWOBJ_EX": 3,
                  "BINPERSID": 1}
_POPS_INTO_TOP = {"APPEND": 1, "SETITEM": 2, "BUILD": 1}
_PUT = frozenset({"PUT", "BINPUT", "LONG_BINPUT"})
_GET = frozenset({"GET", "BINGET", "LONG_BINGET"})


class _Walk:
    """The graph a pickle builds, walked from its opcodes: node i (a container or a call) has the
    children `children[i]`, each a node or None (a number, a string, a name)."""

    def __init__(self) -> None:
        self.children: list[list[int | None]] = []
        self.stack: list[Any] = []
        self.memo: dict[int, Any] = {}

    def new(self, items: list[Any]) -> None:
        self.children.append(items)
        self.stack.append(len(self.children) - 1)

    def pop(self, n: int) -> list[Any]:
        items = self.stack[len(self.stack) - n:]
        if len(items) < n or any(x is _MARK for x in items):
            raise _Refused("its stack runs short")
        del self.stack[len(self.stack) - n:]
        return items

    def pop_mark(self) -> list[Any]:
        for i in range(len(self.stack) - 1, -1, -1):
            if self.stack[i] is _MARK:
                items = self.stack[i + 1:]
                del self.stack[i:]
                return items
        raise _Refused("it has no mark where one is needed")

    def top(self) -> Any:
        if not self.stack or self.stack[-1] is _MARK:
            raise _Refused("its stack runs short")
        return self.stack[-1]

    def into_top(self, items: list[Any]) -> None:
        top = self.top()
        if top is None:
            raise _Refused("it adds to a number or string")
        self.children[top].extend(items)

    def step(self, name: str, arg: Any) -> None:  # noqa: C901 - one branch per kind of opcode
        if name in _LEAVES:
            self.stack.append(None)
        elif name in _EMPTY:
            self.new([])
        elif name in _FROM_MARK:
            self.new(self.pop_mark())
        elif name in _POPS_INTO_NEW:
            self.new(self.pop(_POPS_INTO_NEW[name]))
        elif name in _POPS_INTO_TOP:
            self.into_top(self.pop(_POPS_INTO_TOP[name]))
        elif name in _ADD_FROM_MARK:
            self.into_top(self.pop_mark())
        elif name == "MARK":
            self.stack.append(_MARK)
        elif name == "STACK_GLOBAL":
            self.pop(2)
            self.stack.append(None)
        elif name == "POP":
            if not self.stack:
                raise _Refused("its stack runs short")
            self.stack.pop()
        elif name == "POP_MARK":
            self.pop_mark()
        elif name == "DUP":
            self.stack.append(self.top())
        elif name in _PUT:
            self.memo[arg] = self.top()
        elif name == "MEMOIZE":
            self.memo[len(self.memo)] = self.top()
        elif name in _GET:
            if arg not in self.memo:
                raise _Refused(f"it gets memo entry {arg}, never put")
            self.stack.append(self.memo[arg])
        elif name not in ("PROTO", "FRAME", "STOP"):
            raise _Refused(f"it uses the opcode {name}, which plain data does not need")

    def bound(self) -> None:
        """Refuse a root reaching more than MAX_REACHED elements (a node counted each time it is
        reached) or nesting deeper than MAX_DEPTH, or a node that reaches itself: depth first,
        on a stack of its own."""
        if len(self.stack) != 1:
            raise _Refused("it does not end with one value")
        if self.stack[0] is None:
            return
        reached: dict[int, int] = {}
        depth: dict[int, int] = {}
        open_: set[int] = set()
        todo: list[tuple[int, bool]] = [(self.stack[0], False)]
        while todo:
            node, done = todo.pop()
            if done:
                open_.discard(node)
                kids = [k for k in self.children[node] if k is not None]
                reached[node] = min(MAX_REACHED + 1, 1 + len(self.children[node]) - len(kids)
                                    + sum(reached[k] for k in kids))
                depth[node] = 1 + max((depth[k] for k in kids), default=0)
                if depth[node] > MAX_DEPTH:
                    raise _Refused(f"it nests deeper than {MAX_DEPTH} levels")
                if reached[node] > MAX_REACHED:
                    raise _Refused(f"it reaches more than {MAX_REACHED} elements (a shared one counted each "
                                   "time it is reached)")
            elif node in open_:
                raise _Refused("it holds a value that contains itself")
            elif node not in reached:
                open_.add(node)
                todo.append((node, True))
                todo.extend((k, False) for k in self.children[node] if k is not None and k not in reached)


def _bound_structure(stream: IO[bytes]) -> None:
    """Walk one pickle of `stream`, up to its STOP, building nothing; _Refused when it is not
    bounded (`_Walk.bound`). The stream is left after the STOP."""
    walk = _Walk()
    for op, arg, _ in pickletools.genops(stream):
        walk.step(op.name, arg)
    walk.bound()


def _resolved(obj: Any, depth: int = 0) -> Any:
    """`obj` with every array recipe replaced by its array; anything else foreign refused. Its
    recursion is bounded: `_bound_structure` has refused deeper nesting."""
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


def _bounded_load(stream: IO[bytes], unpickler: pickle._Unpickler, p: Path, what: str) -> Any:
    """The value of the next pickle of `stream`, read by `unpickler` once `_bound_structure` has
    walked it; the stream is left after it."""
    start = stream.tell()
    try:
        _bound_structure(stream)
        stream.seek(start)
        return unpickler.load()
    except _Refused as e:
        raise InputError(f"{p}: refused: {e}") from None
    except Exception as e:  # a malformed stream: pickle, struct, memory or type errors alike
        msg = str(e).splitlines()[0][:120] if str(e) else type(e).__name__
        raise InputError(f"{p}: not a readable {what} ({msg})") from None


def load_pickle(path: str | Path) -> Any:
    """The content of the pickle at `path`: dicts, lists, tuples, numbers, strings and arrays."""
    p = Path(path)
    stream = io.BytesIO(read_input(p, "an ODMD set", MAX_FILE_BYTES))
    obj = _bounded_load(stream, _Unpickler(stream), p, "ODMD pickle")
    try:
        return _resolved(obj)
    except _Refused as e:
        raise InputError(f"{p}: refused: {e}") from None


# -- checkpoints

_STORAGES = {f"{k}Storage": n for k, n in {"Float": 4, "Double": 8, "Half": 2, "BFloat16": 2, "Long": 8,
                                           "Int": 4, "Short": 2, "Char": 1, "Byte": 1, "Bool": 1}.items()}


class _StorageType:
    def __init__(self, name: str) -> None:
        self.name, self.itemsize = name, _STORAGES[name]


class _Storage:
    """A tensor storage as declared by a checkpoint's persistent id."""

    def __init__(self, kind: _StorageType, key: str, numel: int) -> None:
        self.kind, self.key, self.numel = kind, key, numel


class _TensorRecipe:
    """Stands for a dense tensor; the checks are its construction's."""


class _OrderedDict(dict):
    """Stands for collections.OrderedDict (a state dict carries its `_metadata` as an attribute)."""


def _rebuild_tensor(storage: Any, offset: Any, size: Any, stride: Any, requires_grad: Any, hooks: Any,
                    metadata: Any = None) -> _TensorRecipe:
    if not isinstance(storage, _Storage):
        raise _Refused("a tensor is not built on a storage")
    ints = (offset, *size, *stride) if isinstance(size, tuple) and isinstance(stride, tuple) else (None,)
    if not (all(type(n) is int and n >= 0 for n in ints) and len(size) == len(stride) <= MAX_DIMS
            and isinstance(requires_grad, bool) and not hooks and metadata is None):
        raise _Refused(f"a tensor declares the view {str((offset, size, stride))[:60]}")
    count = math.prod(size)
    end = offset + sum((n - 1) * k for n, k in zip(size, stride, strict=True)) + 1 if count else 0
    if count > storage.numel or end > storage.numel:
        raise _Refused(f"a tensor of shape {size} views beyond its storage of {storage.numel} elements")
    return _TensorRecipe()


class _CheckpointUnpickler(pickle._Unpickler):
    """Reads a checkpoint's pickle with stand-ins; `storages` collects what it declares, by key."""

    def __init__(self, file: IO[bytes]) -> None:
        super().__init__(file)
        self.storages: dict[str, _Storage] = {}

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) == ("collections", "OrderedDict"):
            return _OrderedDict
        if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
            return _rebuild_tensor
        if module == "torch" and name in _STORAGES:
            return _StorageType(name)
        raise _Refused(f"it names {module}.{name}, which a checkpoint of dense tensors does not")

    def persistent_load(self, pid: Any) -> Any:
        if not (isinstance(pid, tuple) and len(pid) in (5, 6) and pid[0] == "storage"
                and isinstance(pid[1], _StorageType) and isinstance(pid[2], str) and isinstance(pid[3], str)
                and type(pid[4]) is int and 0 <= pid[4] <= MAX_CHECKPOINT_BYTES and pid[5:] in ((), (None,))):
            raise _Refused(f"it holds the persistent reference {str(pid)[:60]}")
        kind, key, numel = pid[1], pid[2], pid[4]
        storage = self.storages.setdefault(key, _Storage(kind, key, numel))
        if (storage.kind.name, storage.numel) != (kind.name, numel):
            raise _Refused(f"storage {key[:20]} is declared twice, differently")
        return storage


def _check_zip(data: bytes, p: Path) -> None:
    """A zipped checkpoint: every record stored, as torch writes them, and its storages' bytes those
    its pickle declares."""
    try:
        records = zipfile.ZipFile(io.BytesIO(data)).infolist()
    except (zipfile.BadZipFile, ValueError, OSError) as e:
        raise InputError(f"{p}: not a readable checkpoint (zip: {e})") from None
    if len(records) > MAX_RECORDS:
        raise InputError(f"{p}: refused: {len(records)} records, more than a checkpoint's {MAX_RECORDS}")
    packed = [r.filename for r in records if r.compress_type != zipfile.ZIP_STORED]
    if packed or sum(r.file_size for r in records) > len(data):
        name = packed[0][:60] if packed else "its records"
        raise InputError(f"{p}: refused: {name} is compressed (torch stores every record as it is)")
    sizes = {r.filename: r.file_size for r in records}
    pickles = [name for name in sizes if name.endswith("/data.pkl") and name.count("/") == 1]
    if len(pickles) != 1:
        raise InputError(f"{p}: not a readable checkpoint (it holds {len(pickles)} data.pkl records)")
    root = pickles[0][: -len("data.pkl")]
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        storages = _storages(io.BytesIO(z.read(pickles[0])), p)
    for key, storage in storages.items():
        have = sizes.get(f"{root}data/{key}")
        if have != storage.numel * storage.kind.itemsize:
            raise InputError(f"{p}: refused: storage {key[:20]} declares {storage.numel} elements, its "
                             f"record holds {have} bytes")


def _storages(stream: IO[bytes], p: Path) -> dict[str, _Storage]:
    """The storages the next of a checkpoint's pickles in `stream` declares, by key, once it has
    been read with stand-ins."""
    unpickler = _CheckpointUnpickler(stream)
    _bounded_load(stream, unpickler, p, "checkpoint")
    return unpickler.storages


def _check_legacy(data: bytes, p: Path) -> None:
    """torch's legacy stream (ODMD's pretrained DBox): a magic number, a version and the system's
    description, the pickle of the checkpoint, the list of its storages' keys, then each storage's
    element count (8 bytes) and bytes, which must add up to the file's end."""
    stream = io.BytesIO(data)
    for _ in range(3):
        _storages(stream, p)
    storages = _storages(stream, p)
    _storages(stream, p)
    declared = sum(8 + s.numel * s.kind.itemsize for s in storages.values())
    if stream.tell() + declared != len(data):
        raise InputError(f"{p}: refused: its storages declare {declared} bytes, the file holds "
                         f"{len(data) - stream.tell()} after its pickles")


def load_checkpoint(path: str | os.PathLike[str]) -> Any:
    """The content of the PyTorch checkpoint at `path` (dicts, numbers, strings and dense tensors),
    on the CPU, once its size, its records and its pickles are checked (the module says how)."""
    p = Path(path)
    data = read_input(p, "a checkpoint", MAX_CHECKPOINT_BYTES)
    if data.startswith(b"PK\x03\x04"):
        _check_zip(data, p)
    else:
        _check_legacy(data, p)
    import torch

    try:
        return torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as e:  # torch raises pickle, zip and runtime errors alike for a bad file
        raise InputError(f"{p}: not a readable checkpoint ({type(e).__name__}: "
                         f"{str(e).splitlines()[0][:120] if str(e) else ''})") from None


def load_npy(path: str | os.PathLike[str], row_shape: tuple[int, ...], max_rows: int,
             what: str) -> np.ndarray:
    """A `.npy` file of floats shaped (n, *row_shape), 1 <= n <= max_rows, as float64: its header
    is checked and its length matched before the array is read, and it is never unpickled."""
    p = Path(path)
    with open_input(p, what) as f:
        try:
            version = np.lib.format.read_magic(f)
            fmt = np.lib.format
            header = (fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0)(f)
        except (ValueError, SyntaxError, OSError) as e:
            raise InputError(f"{p}: not a readable .npy file ({' '.join(str(e).split())[:200]})") from None
        shape, _, dtype = header
        if dtype.kind != "f" or len(shape) != 1 + len(row_shape) or tuple(shape[1:]) != row_shape:
            raise InputError(f"{p}: holds a {dtype} array of shape {shape}; expected floats of shape "
                             f"(n, {', '.join(map(str, row_shape))})")
        if not 1 <= shape[0] <= max_rows:
            raise InputError(f"{p}: {shape[0]} {what}; expected 1 to {max_rows}")
        if p.stat().st_size - f.tell() < shape[0] * int(np.prod(row_shape)) * dtype.itemsize:
            raise InputError(f"{p}: shorter than the {shape[0]} {what} its header declares")
    return np.load(p, allow_pickle=False).astype(np.float64)
