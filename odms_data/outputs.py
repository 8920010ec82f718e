"""The rules every file odms-data writes follows (stores, in store/writer.py, share the lock and
the messages):

- an existing path is refused unless `overwrite`, and a folder is never replaced by a file;
- the content goes to the sibling `<path>.partial` under the lock `<path>.lock` (flock, one
  writer at a time), is flushed to disk and renamed into place, so the old file survives any
  failure and a half-written file is never left at the path;
- a failed write (a full disk, say) removes the sibling and is one line naming the path;
- nothing is written inside a Zarr store (a folder holding zarr.json).
"""

from __future__ import annotations

import errno
import fcntl
import os
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from .errors import InputError, OutputExistsError, OutputLockedError, StoreLockedError, WriteError

DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
def write_error(path: str | os.PathLike, e: OSError) -> WriteError:
    """One line naming the output `path` for an OSError met while writing it."""
    if e.errno in DISK_FULL:
        why = "no space left on the device" if e.errno != errno.EFBIG else "the file size limit was reached"
    else:
        why = e.strerror or str(e)
    return WriteError(f"{path}: cannot be written: {why}; nothing was left behind")


def remove(path: str | os.PathLike) -> None:
    """Remove a file, link or folder tree at `path`, if there is one."""
    p = Path(path)
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p)
    elif p.exists() or p.is_symlink():
        p.unlink()


def _make_parents(path: Path) -> list[Path]:
    """Create the missing folders above `path`; returns them, outermost first."""
    missing = [p for p in path.absolute().parents if not p.exists()][::-1]
    path.parent.mkdir(parents=True, exist_ok=True)
    return missing


@contextmanager
def output_lock(path: str | os.PathLike, noun: str = "file") -> Iterator[None]:
    """Hold `<path>.lock` (flock, holding this process's id) while `path` is written. Folders made
    for it are removed again when they are left empty (the write failed). A path inside a Zarr
    store is refused."""
    lock = Path(str(path).rstrip("/") + ".lock")
    store = next((p for p in lock.absolute().parents if (p / "zarr.json").is_file()), None)
    if store is not None:  # it would become part of the store (an input, most often)
        raise InputError(f"{path}: is inside the Zarr store {store}; choose an output outside it")
    try:
        made = _make_parents(lock)
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as e:
        raise write_error(path, e) from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 64).decode(errors="replace").strip() or "unknown"
            locked = StoreLockedError if noun == "store" else OutputLockedError
            raise locked(f"{path}: another odms-data process (pid {holder}) is writing this {noun}") from None
        try:
            os.ftruncate(fd, 0)
            os.write(fd, str(os.getpid()).encode())  # for the message of a second writer
        except OSError:
            pass  # a full disk: the lock holds without it, and the write itself will say so
        try:
            yield
        finally:
            lock.unlink(missing_ok=True)
    finally:
        os.close(fd)
        for folder in reversed(made):
            try:
                folder.rmdir()
            except OSError:
                break  # not empty: it holds the output


def check_new_file(
    path: str | os.PathLike, overwrite: bool, option: str = "", suffixes: tuple[str, ...] = ()
) -> None:
    """Refuse an output file path that exists (unless `overwrite`), that is a folder, or whose
    name does not end with one of `suffixes` (when given: a CSV named x.zarr would pass for a store).

    `option` names the command-line option that gave the path, for the message.
    """
    p = Path(path)
    what = f"{option} {path}" if option else str(path)
    if p.is_dir():
        raise OutputExistsError(f"{what}: is a folder; give a file name")
    if (p.exists() or p.is_symlink()) and not overwrite:
        raise OutputExistsError(f"{what}: already exists", fix="overwrite")
    if suffixes and p.suffix.lower() not in suffixes:
        raise InputError(f"{what}: name the file *{' or *'.join(suffixes)}")


def fsync_tree(path: str | os.PathLike) -> None:
    """Flush a file, or every file and folder of a tree, to the disk."""
    p = Path(path)
    if p.is_dir():
        for root, _, files in os.walk(p):
            for name in files:
                _fsync(Path(root) / name, os.O_RDONLY)
        for root, _, _ in os.walk(p, topdown=False):
            _fsync(Path(root), os.O_RDONLY | os.O_DIRECTORY)
    else:
        _fsync(p, os.O_RDONLY)


def _fsync(path: Path, flags: int) -> None:
    fd = os.open(path, flags)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def sync_parent(path: str | os.PathLike) -> None:
    """Flush the folder holding `path`, so that a rename into it is on the disk."""
    _fsync(Path(path).absolute().parent, os.O_RDONLY | os.O_DIRECTORY)


def move_into_place(partial: Path, target: Path) -> None:
    """Rename the finished `partial` onto `target`, whose old content is moved aside first and
    removed after, and flush the folder holding it."""
    if target.exists() or target.is_symlink():
        old = Path(f"{target}.replaced")
        remove(old)
        target.rename(old)
        partial.rename(target)
        remove(old)
    else:
        partial.rename(target)
    sync_parent(target)


@contextmanager
def atomic_file(path: str | os.PathLike, *, overwrite: bool = False, option: str = "") -> Iterator[Path]:
    """Yields the temporary sibling to write `path` into; on leaving normally it is flushed and
    renamed onto `path`; on an error it is removed and `path` is as it was."""
    with output_lock(path):
        check_new_file(path, overwrite, option)
        with replaced_via_partial(path) as partial:
            yield partial


@contextmanager
def replaced_via_partial(path: str | os.PathLike) -> Iterator[Path]:
    """`atomic_file` without the lock and the existence check, for a file that its owner
    replaces as it goes (a training run's checkpoints): yields `<path>.partial`, flushed and
    renamed onto `path` when the block ends normally, removed (and a full disk one line naming
    `path`) when it does not."""
    partial = Path(f"{path}.partial")
    try:
        remove(partial)
        yield partial
        fsync_tree(partial)
        os.replace(partial, path)
        sync_parent(path)
    except BaseException as e:
        remove(partial)
        if isinstance(e, OSError) and (e.errno in DISK_FULL or e.filename in (str(partial), partial)):
            raise write_error(path, e) from e
        raise


def write_bytes(path: str | os.PathLike, data: bytes, *, overwrite: bool = False, option: str = "") -> None:
    """Write `data` to `path` atomically (see `atomic_file`)."""
    with atomic_file(path, overwrite=overwrite, option=option) as partial, open(partial, "xb") as f:
        f.write(data)


def write_text(path: str | os.PathLike, text: str, *, overwrite: bool = False, option: str = "") -> None:
    """Write `text` as UTF-8 to `path` atomically (see `atomic_file`)."""
    write_bytes(path, text.encode("utf-8"), overwrite=overwrite, option=option)


@contextmanager
def atomic_folder(
    path: str | os.PathLike, *, overwrite: bool = False, foreign: Callable[[Path], str | None]
) -> Iterator[Path]:
    """`atomic_file` for an output that is a folder: yields the empty folder `<path>.partial`,
    renamed onto `path` (replacing what was there) when the block ends normally.

    An existing `path` is refused unless `overwrite`, and even then when `foreign(path)` says what
    makes it something odms-data did not write (None: it may be replaced).
    """
    target = Path(path)
    with output_lock(path):
        if target.exists() or target.is_symlink():
            if not overwrite:
                raise OutputExistsError(f"{path}: already exists", fix="overwrite")
            what = "is a symbolic link" if target.is_symlink() else foreign(target)
            if what:
                raise OutputExistsError(f"{path}: {what}", fix="overwrite-ours")
        partial = Path(f"{path}.partial")
        try:
            remove(partial)
            partial.mkdir()
            yield partial
            fsync_tree(partial)
            move_into_place(partial, target)
        except BaseException as e:
            remove(partial)
            if isinstance(e, OSError) and (e.errno in DISK_FULL or str(e.filename).startswith(str(partial))):
                raise write_error(path, e) from e
            raise
