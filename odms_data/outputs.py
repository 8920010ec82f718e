"""The one owner of every write of every output: stores, files, exports, training runs, entries.

- what may be replaced (`check_replaceable`): an existing path is refused unless `overwrite`, and
  even then when the output's `OutputType` says it is not odms-data's own (a folder where a file goes,
  a folder that is not a store, a symbolic link where a folder goes);
- the content goes to the sibling folder `<path>.partial` under the lock `<path>.lock` (flock,
  one writer at a time), is flushed to disk and renamed into place, so the old output survives
  any failure and a half-written one is never left at the path;
- a sibling is never reused blindly: the lock and the folders are created with O_EXCL and
  O_NOFOLLOW (mkdir never follows a link); an existing one is taken over only when it is provably
  odms-data's own (a lock: a regular file holding nothing or a process id; a folder: empty, or
  holding the marker file odms-data writes into each one it makes), else refused in one line,
  never deleted;
- a sibling whose name would pass NAME_MAX is shortened, with a hash of the output's name;
- a failed write (a full disk, say) removes the sibling and is one line naming the path;
- an output that has a reader is checked by it (`check`) before it is renamed into place: what its
  reader refuses replaces nothing (a `WriteError`);
- a path that names no file or folder ('', '.', '..', a trailing '/.') is refused;
- nothing is written inside a Zarr store (a folder holding zarr.json).
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import os
import re
import shutil
import stat
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from .errors import InputError, OdmsError, OutputExistsError, OutputLockedError, WriteError
from .interrupts import uninterrupted
from .urls import refuse_url

DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
NAME_MAX = 255  # bytes of one file name on Linux, macOS and Windows file systems alike
MARKER = ".odms-data-partial"  # in every sibling folder odms-data makes: what proves it is ours
_LOCK_CONTENT = re.compile(rb"\s*\d{0,20}\s*")  # what a lock file of ours holds: a process id, or nothing


def _is_a_folder(path: Path) -> str | None:
    return "is a folder; give a file name" if path.is_dir() else None


@dataclass(frozen=True)
class OutputType:
    """What an output is, for the rule of what may be replaced: its noun (for messages), what
    makes an existing path something odms-data does not replace even with `overwrite` (None: it
    may be replaced), and the errors to raise."""

    noun: str
    foreign: Callable[[Path], str | None] = _is_a_folder
    exists_error: type[OdmsError] = OutputExistsError
    locked_error: type[OdmsError] = OutputLockedError


FILE = OutputType("file")


def write_error(path: str | os.PathLike, e: OSError) -> WriteError:
    """One line naming the output `path` for an OSError met while writing it."""
    if e.errno in DISK_FULL:
        why = "no space left on the device" if e.errno != errno.EFBIG else "the file size limit was reached"
    else:
        why = e.strerror or str(e)
    return WriteError(f"{path}: cannot be written: {why}; nothing was left behind")


Check = Callable[[Path], object]  # a reader's checks of a finished output: OdmsError when it refuses it


def sibling(path: str | os.PathLike, suffix: str) -> Path:
    """`<path><suffix>`, its name shortened (keeping a hash of the whole) where it would pass NAME_MAX;
    InputError when `path` names no file or folder (its siblings would have no name)."""
    p = Path(str(path).rstrip("/") or "/")
    if p.name in ("", ".", ".."):
        raise InputError(f"{os.fspath(path)!r}: names no file or folder for the output; give it a name")
    name, tail = os.fsencode(p.name), os.fsencode(suffix)
    if len(name) + len(tail) <= NAME_MAX:
        return p.with_name(p.name + suffix)
    digest = hashlib.sha256(name).hexdigest()[:16].encode()
    short = name[: NAME_MAX - len(tail) - len(digest) - 1] + b"~" + digest + tail
    return p.with_name(os.fsdecode(short))


def check_replaceable(
    path: str | os.PathLike, overwrite: bool, output_type: OutputType = FILE, option: str = "",
    suffixes: tuple[str, ...] = (),
) -> None:
    """Refuse an output path that exists (unless `overwrite`), or that `output_type` says odms-data does
    not replace, or whose name does not end with one of `suffixes` (when given: a CSV named
    x.zarr would pass for a store). `option`, the name of the input that gave the path, starts the
    message and is the error's `option` (errors.OdmsError). A URL is refused: what is checked here
    is written locally."""
    refuse_url(path, f"this {output_type.noun}")
    p = Path(path)

    def foreign() -> str | None:
        return "is a symbolic link" if output_type is not FILE and p.is_symlink() else output_type.foreign(p)

    refuse_existing(f"{option} {path}" if option else str(path), p.exists() or p.is_symlink(), overwrite,
                    foreign, output_type, option)
    if suffixes and p.suffix.lower() not in suffixes:
        raise InputError(f"{option + ' ' if option else ''}{path}: name the file *{' or *'.join(suffixes)}",
                         option=option)


def refuse_existing(where: str, exists: bool, overwrite: bool, foreign: Callable[[], str | None],
                    output_type: OutputType, option: str = "") -> None:
    """The rule itself, for a local path or a URL: `foreign()` says what makes what is there
    something odms-data does not replace (None: it may be replaced with `overwrite`); `option`
    names the input `where` starts with, if any."""
    if not exists:
        return
    what = foreign()
    if what and output_type is FILE:  # a folder where a file goes: no overwriting would help
        raise output_type.exists_error(f"{where}: {what}", option=option)
    if not overwrite:
        raise output_type.exists_error(f"{where}: already exists", fix="overwrite", option=option)
    if what:
        raise output_type.exists_error(f"{where}: {what}", fix="overwrite-ours", option=option)


def _make_parents(path: Path) -> list[Path]:
    """Create the missing folders above `path`; returns them, outermost first."""
    missing = [p for p in path.absolute().parents if not p.exists()][::-1]
    path.parent.mkdir(parents=True, exist_ok=True)
    return missing


def _open_lock(lock: Path, path: str | os.PathLike, output_type: OutputType) -> int:
    """Open the lock file, creating it, or taking over one that is provably a stale lock of ours;
    never through a link, never a file that is something else."""
    try:
        return os.open(lock, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
    except FileExistsError:
        pass
    foreign = output_type.exists_error(f"{lock}: exists and is not an odms-data lock; odms-data locks "
                                       f"{path} with this name, so move it away")
    try:
        fd = os.open(lock, os.O_RDWR | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError as e:
        if e.errno in (errno.ELOOP, errno.EMLINK, errno.ENXIO, errno.EISDIR):  # a link, a fifo, a folder
            raise foreign from None
        raise
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1 or st.st_size > 64 \
            or not _LOCK_CONTENT.fullmatch(os.pread(fd, 64, 0)):
        os.close(fd)
        raise foreign
    return fd


@contextmanager
def output_lock(path: str | os.PathLike, output_type: OutputType = FILE) -> Iterator[None]:
    """Hold `<path>.lock` (flock, holding this process's id) while `path` is written. Folders made
    for it are removed again when they are left empty (the write failed). A path inside a Zarr
    store is refused."""
    lock = sibling(path, ".lock")
    store = next((p for p in lock.absolute().parents if (p / "zarr.json").is_file()), None)
    if store is not None:  # it would become part of the store (an input, most often)
        raise InputError(f"{path}: is inside the Zarr store {store}; choose an output outside it")
    made: list[Path] = []
    fd: int | None = None
    locked = False
    try:
        with uninterrupted():  # a stop waits until what is made here is set to be removed
            try:
                made = _make_parents(lock)
                fd = _open_lock(lock, path, output_type)
            except OSError as e:
                raise write_error(path, e) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                mine = os.fstat(fd)
                there = os.lstat(lock)
                if (mine.st_dev, mine.st_ino) != (there.st_dev, there.st_ino):
                    raise BlockingIOError  # the holder removed it as we opened it: it was busy
            except (BlockingIOError, FileNotFoundError):
                holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "unknown"
                raise output_type.locked_error(f"{path}: another odms-data process (pid {holder}) is writing "
                                               f"this {output_type.noun}") from None
            locked = True
            try:
                os.ftruncate(fd, 0)
                os.pwrite(fd, str(os.getpid()).encode(), 0)  # for the message of a second writer
            except OSError:
                pass  # a full disk: the lock holds without it, and the write itself will say so
            _put_back_set_aside(Path(path))
        yield
    finally:
        if locked:
            lock.unlink(missing_ok=True)
        if fd is not None:
            os.close(fd)
        for folder in reversed(made):
            try:
                folder.rmdir()
            except OSError:
                break  # not empty: it holds the output


def _ours(folder: Path, output_type: OutputType) -> bool:
    """Whether `folder` is a sibling folder odms-data made: a real folder, empty, with the marker,
    or (for a folder output) an output of this type that `output_type` recognises as odms-data's, as a
    run killed between the marker's removal and the rename leaves it."""
    try:
        if not stat.S_ISDIR(os.lstat(folder).st_mode):
            return False
        names = os.listdir(folder)
        if not names or (MARKER in names and stat.S_ISREG(os.lstat(folder / MARKER).st_mode)):
            return True
    except FileNotFoundError:
        return False
    return output_type is not FILE and output_type.foreign(folder) is None


def _refuse_foreign(folder: Path, target: Path, output_type: OutputType) -> None:
    """Refuse a sibling `folder` of `target` that is there and not odms-data's own."""
    if os.path.lexists(folder) and not _ours(folder, output_type):
        what = "a symbolic link" if folder.is_symlink() else "a folder" if folder.is_dir() else "a file"
        raise output_type.exists_error(f"{folder}: is {what} odms-data did not make; odms-data writes "
                                       f"{target} through this name, so move it away")


def _make_sibling_folder(folder: Path, target: Path, output_type: OutputType) -> None:
    """Make the sibling folder `folder` of `target` with the marker in it; a stale one of ours (an
    interrupted run's) is removed first, anything else there is refused."""
    if os.path.lexists(folder):
        _refuse_foreign(folder, target, output_type)
        _remove_sibling_folder(folder)
    folder.mkdir()
    try:
        fd = os.open(folder / MARKER, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        try:
            os.write(fd, f"odms-data {os.getpid()} {uuid.uuid4()}\n".encode())
        finally:
            os.close(fd)
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)  # just made: a full disk, say
        raise


def _put_back_set_aside(target: Path) -> None:
    """Move back an old output that a commit killed between its two renames left set aside in
    `<target>.replaced` (the new output never reached `target`): it is the user's, not debris.
    Only from a `.replaced` with odms-data's marker, which a commit writes before the rename."""
    aside = sibling(target, ".replaced")
    old = aside / target.name
    if not os.path.lexists(target) and os.path.lexists(old) and _ours(aside, FILE):
        old.rename(target)
        _remove_sibling_folder(aside)


def _remove_sibling_folder(folder: Path) -> None:
    """Remove a sibling folder of ours, its marker last: one whose removal a stop cut short is
    still provably ours, and the next run takes it over instead of refusing it. What cannot be
    removed stays (the folder made next in its place then fails in one line)."""
    with os.scandir(folder) as entries:
        for entry in entries:
            if entry.name != MARKER:
                if entry.is_dir(follow_symlinks=False):
                    shutil.rmtree(entry.path, ignore_errors=True)
                else:
                    Path(entry.path).unlink(missing_ok=True)
    shutil.rmtree(folder, ignore_errors=True)


class Partial:
    """Where an output is written before it is renamed into place: the sibling folder
    `<path>.partial` (odms-data's, marked), which is the output itself when the output is a
    folder, and holds it under its own name when it is a file."""

    def __init__(self, path: str | os.PathLike, folder: bool, output_type: OutputType = FILE) -> None:
        refuse_url(path, f"this {output_type.noun}")
        self.target, self.output_type, self.is_folder = Path(path), output_type, folder
        self.folder = sibling(path, ".partial")
        self.path = self.folder if folder else self.folder / self.target.name
        self._made = False

    def make(self) -> Path:
        """Make the (empty) partial output's place; returns its path. A foreign `.replaced`
        sibling is refused now, before the work, rather than when the output is moved into place."""
        if self.is_folder or self.target.is_dir():  # the two cases that move the old output aside
            _refuse_foreign(sibling(self.target, ".replaced"), self.target, self.output_type)
        self._made = True  # before: `discard` removes what a stop leaves of it, which is provably ours
        _make_sibling_folder(self.folder, self.target, self.output_type)
        return self.path

    def commit(self, check: Check | None = None) -> None:
        """Flush the finished output and rename it onto the target, replacing what is there, once
        `check` (its reader's checks) accepts it. A stop waits for the end: between the renames of a
        replaced folder, no output is at the path."""
        if check is not None:
            try:
                check(self.path)
            except OdmsError as e:
                raise WriteError(f"{self.target}: what was written does not read back ({e}); "
                                            "nothing was replaced") from None
        with uninterrupted():
            fsync_tree(self.path)
            if self.is_folder:  # only now: a stale partial without the marker is refused, not removed
                (self.folder / MARKER).unlink()
            _move_into_place(self.path, self.target, self.output_type)
            if not self.is_folder:
                (self.folder / MARKER).unlink()
                self.folder.rmdir()
            self._made = False

    def discard(self) -> None:
        """Remove what was written, if this made it: the sibling folder, if it is odms-data's own
        (`_ours`: empty or marked), as a stop in the middle of its making leaves it."""
        if self._made and _ours(self.folder, self.output_type):  # made under our lock
            _remove_sibling_folder(self.folder)
        self._made = False


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
    fd = os.open(path, flags | os.O_NOFOLLOW)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def sync_parent(path: str | os.PathLike) -> None:
    """Flush the folder holding `path`, so that a rename into it is on the disk; the folder may be
    a link to one (a folder of outputs the user linked elsewhere), which is followed."""
    _fsync(Path(os.path.realpath(Path(path).absolute().parent)), os.O_RDONLY | os.O_DIRECTORY)


def _move_into_place(new: Path, target: Path, output_type: OutputType) -> None:
    """Rename the finished `new` onto `target`. A file replaces a file in one rename; anything
    else there is first moved aside into the sibling folder `<target>.replaced` and removed after."""
    if not (new.is_dir() or target.is_dir()) or not os.path.lexists(target):
        os.replace(new, target)
    else:
        aside = sibling(target, ".replaced")
        _make_sibling_folder(aside, target, output_type)
        target.rename(aside / target.name)
        try:
            new.rename(target)
        except BaseException:
            _put_back_set_aside(target)
            raise
        _remove_sibling_folder(aside)
    sync_parent(target)


def _failed(e: BaseException, path: str | os.PathLike, partial: Partial) -> BaseException | None:
    """The one-line error for an OSError met while writing `path`, if it is one."""
    if isinstance(e, OSError) and (e.errno in DISK_FULL or _inside(e.filename, partial.folder)):
        return write_error(path, e)
    return None


def _inside(filename: object, folder: Path) -> bool:
    name = os.fspath(filename) if isinstance(filename, str | os.PathLike) else None
    return name is not None and (name == str(folder) or name.startswith(str(folder) + os.sep))


@contextmanager
def atomic_file(path: str | os.PathLike, *, overwrite: bool = False, option: str = "",
                check: Check | None = None) -> Iterator[Path]:
    """Yields the temporary path to write `path` at; on leaving normally it is checked (`check`),
    flushed and renamed onto `path`; on an error it is removed and `path` is as it was."""
    with output_lock(path):
        check_replaceable(path, overwrite, FILE, option)
        with replaced_via_partial(path, check=check) as partial:
            yield partial


@contextmanager
def replaced_via_partial(path: str | os.PathLike, output_type: OutputType = FILE,
                         folder: bool = False, check: Check | None = None) -> Iterator[Path]:
    """`atomic_file` without the lock and the existence check, for a file that its owner
    replaces as it goes (a training run's checkpoints, under the run's lock): yields the path to
    write, checked (`check`), flushed and renamed onto `path` when the block ends normally, removed
    (and a full disk one line naming `path`) when it does not."""
    partial = Partial(path, folder=folder, output_type=output_type)
    try:
        yield partial.make()
        partial.commit(check)
    except BaseException as e:
        partial.discard()
        failed = _failed(e, path, partial)
        if failed is not None:
            raise failed from e
        raise


def write_bytes(path: str | os.PathLike, data: bytes, *, overwrite: bool = False, option: str = "") -> None:
    """Write `data` to `path` atomically (see `atomic_file`)."""
    with atomic_file(path, overwrite=overwrite, option=option) as partial, open(partial, "xb") as f:
        f.write(data)


def write_text(path: str | os.PathLike, text: str, *, overwrite: bool = False, option: str = "") -> None:
    """Write `text` as UTF-8 to `path` atomically (see `atomic_file`)."""
    write_bytes(path, text.encode("utf-8"), overwrite=overwrite, option=option)


@contextmanager
def atomic_folder(path: str | os.PathLike, output_type: OutputType, *,
                  overwrite: bool = False, check: Check | None = None) -> Iterator[Path]:
    """`atomic_file` for an output that is a folder: yields the empty folder to write, checked
    (`check`) and renamed onto `path` (replacing what was there, if `output_type` allows it) when
    the block ends normally."""
    with output_lock(path, output_type):
        check_replaceable(path, overwrite, output_type)
        with replaced_via_partial(path, output_type, folder=True, check=check) as partial:
            yield partial
