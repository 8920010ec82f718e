"""Where the project reads a file a stranger may have written: the one place an input file is
opened, and the one rule confining a path taken from data to its folder.

An input file may be a FIFO (which blocks a reader forever), a device (/dev/zero never ends) or a
socket; only a regular file is read, and it is opened without waiting on a writer (O_NONBLOCK,
cleared once it is known to be a file). A name read from data (a CSV cell, a folder listing) must
not reach outside its folder: not by `..`, not by being absolute, not by a symbolic link (or a link
in a parent) that resolves elsewhere; `inside` is the one place that rule is written.
"""

from __future__ import annotations

import fcntl
import io
import os
import stat
from collections.abc import Callable
from pathlib import Path

from .errors import InputError, OdmsError


def open_input(path: str | os.PathLike[str], what: str, error: type[OdmsError] = InputError) -> io.FileIO:
    """The regular file at `path` opened for reading (binary, unbuffered); `error` naming `path`
    and `what` it should be when it is missing, a folder, not a regular file or unreadable."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        noun = what.removeprefix("a ").removeprefix("an ")
        raise error(f"{os.fspath(path)}: no such {noun}") from None
    except IsADirectoryError:
        raise error(f"{os.fspath(path)}: is a folder, not {what}") from None
    except OSError as e:
        raise error(f"{os.fspath(path)}: cannot be read ({e.strerror or e})") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        kind = "a folder" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode) else \
            "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "not a regular file"
        raise error(f"{os.fspath(path)}: is {kind}, not {what}")
    fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_NONBLOCK)
    return io.FileIO(fd, "rb")


def read_input(path: str | os.PathLike[str], what: str, max_bytes: int,
               error: type[OdmsError] = InputError) -> bytes:
    """The bytes of the regular file at `path` (`open_input`): `error` when it declares or holds more
    than `max_bytes` (read no further than `max_bytes` + 1)."""
    size = f"{max_bytes // 2**20} MiB" if max_bytes >= 2**20 else f"{max_bytes} bytes"
    too_big = error(f"{os.fspath(path)}: larger than {size}, not {what}")
    with open_input(path, what, error) as f:
        if os.fstat(f.fileno()).st_size > max_bytes:  # refused by what it declares, before reading
            raise too_big
        try:
            data = _read_upto(f, max_bytes + 1)  # + 1: a file that grew meanwhile is caught too
        except OSError as e:
            raise error(f"{os.fspath(path)}: cannot be read ({e.strerror or e})") from None
    if len(data) > max_bytes:
        raise too_big
    return data


def _read_upto(f: io.FileIO, n: int) -> bytes:
    parts, left = [], n
    while left > 0:
        chunk = f.read(min(left, 1 << 24))
        if not chunk:
            break
        parts.append(chunk)
        left -= len(chunk)
    return b"".join(parts)


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
