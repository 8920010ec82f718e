"""The official release, extracted and imported once for every test run, not once a run.

A cache entry is the release's data/ folder and its eight imported stores, in test-stores/<key>/ of
the user's cache folder ($XDG_CACHE_HOME/odms-data, else ~/.cache/odms-data; `ODMS_TEST_CACHE` names
another folder). The key is the store format's version, the archive's sha256 and a digest of the
code that decides the stores' content (odms_data/importers/, odms_data/store/,
odms_data/protocol.py: their syntax trees, not their comments or docstrings), so a change to that
code imports anew instead of testing stale stores. An entry is built in a `.partial` sibling and
renamed into place complete; its files are made read-only, so a test that writes into them fails
(unless run as root). A `files.json` lists every file's size and, for the stores, its sha256; an
entry that does not match it (a file lost, truncated, or a store changed) is rebuilt. Entries of
other keys unused for a week, and partial entries of runs that were killed, are removed. A run
builds under a lock on the cache's folder, so that a second run, or a second pytest-xdist worker,
asking meanwhile waits for that entry instead of importing the release again beside it."""

from __future__ import annotations

import ast
import fcntl
import hashlib
import json
import os
import shutil
import stat
import tarfile
import time
from collections.abc import Callable
from pathlib import Path

from odms_data.store.format import FORMAT_VERSION
from odms_data.user_cache import cache_home

PACKAGE = Path(__file__).resolve().parents[1] / "odms_data"
CONTENT_CODE = ("importers", "store", "protocol.py")
LISTING = "files.json"
UNUSED_DAYS = 7  # entries of other keys (older code, another archive) unused this long are removed


def cache_root() -> Path:
    given = os.environ.get("ODMS_TEST_CACHE")
    return Path(given) if given else cache_home() / "test-stores"


def sha256(path: Path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def _code(path: Path) -> str:
    """The module's syntax tree without its docstrings: comments and docstrings do not change a key."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
            node.body = body[1:] or [ast.Pass()]  # type: ignore[attr-defined]
    return ast.dump(tree)


def code_digest() -> str:
    h = hashlib.sha256()
    for name in CONTENT_CODE:
        root = PACKAGE / name
        for path in sorted(root.rglob("*.py")) if root.is_dir() else [root]:
            h.update(f"{path.relative_to(PACKAGE)}\0{_code(path)}\0".encode())
    return h.hexdigest()


def cache_key(archive: Path) -> str:
    return f"format{FORMAT_VERSION}-archive{sha256(archive)[:16]}-code{code_digest()[:16]}"


def _listing(entry: Path) -> dict[str, list]:
    """Every file's size; a store file's sha256 too (the PNGs are many, and their sizes suffice).
    Walked with os.scandir: pathlib's per-path objects cost seconds over the release's files."""
    files: dict[str, list] = {}

    def walk(folder: str, rel: str) -> None:
        with os.scandir(folder) as entries:
            for e in entries:
                name = f"{rel}{e.name}"
                if e.is_dir(follow_symlinks=False):  # as rglob: links to folders not followed
                    walk(e.path, f"{name}/")
                elif e.is_file() and name != LISTING:
                    digest = sha256(Path(e.path)) if name.startswith("stores/") else None
                    files[name] = [e.stat().st_size, digest]

    walk(str(entry), "")
    return files


def _intact(entry: Path) -> bool:
    listing = entry / LISTING
    if not listing.is_file():
        return False
    try:
        return json.loads(listing.read_text()) == _listing(entry)
    except (OSError, ValueError):
        return False


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _writable(root: Path) -> None:
    for path in [root, *root.rglob("*")]:
        if not path.is_symlink():
            path.chmod(path.stat().st_mode | stat.S_IWUSR)


def _remove(path: Path) -> None:
    if path.exists():
        _writable(path)
        shutil.rmtree(path)


def _read_only(root: Path) -> None:
    for path in [*root.rglob("*"), root]:
        if not path.is_symlink():
            path.chmod(path.stat().st_mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))


def official_entry(archive: Path, import_release: Callable[[Path, Path], object]) -> Path:
    """The cache entry for `archive`: `data/` (the release's folder) and `stores/` (the eight
    imported stores), built with `import_release(data_dir, out_dir)` when absent or damaged."""
    root = cache_root()
    entry = root / cache_key(archive)
    root.mkdir(parents=True, exist_ok=True)
    lock = os.open(root, os.O_RDONLY)
    try:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when closed, also by a run that is killed
        if _intact(entry):
            os.utime(entry)  # in use: not pruned
            return entry
        return _build(archive, root, entry, import_release)
    finally:
        os.close(lock)


def _build(archive: Path, root: Path, entry: Path, import_release: Callable[[Path, Path], object]) -> Path:
    for stale in root.glob("*.partial-*"):  # left by a run that was killed
        if not _alive(int(stale.name.rsplit("-", 1)[1])):
            _remove(stale)
    partial = root / f"{entry.name}.partial-{os.getpid()}"
    _remove(partial)
    partial.mkdir()
    try:
        with tarfile.open(archive) as tar:
            tar.extractall(partial, filter="data")
        import_release(partial / "data", partial / "stores")
        (partial / LISTING).write_text(json.dumps(_listing(partial)))
        _read_only(partial)
        _remove(entry)  # damaged, or left by a run that stopped while it was replaced
        try:
            partial.rename(entry)
        except OSError:  # another run put an entry in place first: use it
            if not _intact(entry):
                raise
    finally:
        _remove(partial)
    for other in root.iterdir():
        if other != entry and other.is_dir() and time.time() - other.stat().st_mtime > UNUSED_DAYS * 86400:
            _remove(other)
    return entry
