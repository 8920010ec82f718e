"""Which URLs odms-data reads and writes, and where: the one module that decides, and the one that
opens their fsspec filesystems.

A path holding `://` is a URL (`is_url`), never the name of a local file or folder: an output that
is written locally refuses it (`refuse_url`) rather than writing `./s3:/bucket/x`. Stores are read
and written at `file://` and at the object stores of SCHEMES (s3, gs, az), each through its fsspec
package; one not installed is one line naming the extra that installs it. `memory://` lives in one
process: the library reads and writes it (its tests, an in-process Dask cluster), the command line
refuses it (`refuse_transient`), since a store written there vanishes when the command ends. Any
other scheme (http, ssh, ...) is refused in one line. An object store its client cannot reach (no
credentials, no connection) is one line naming the URL (`reaching`).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from .errors import InputError
from .extras import optional

# scheme -> (the fsspec package that reads it, the extra that installs it)
SCHEMES = {
    "file": ("fsspec", "dask"), "s3": ("s3fs", "s3"), "gs": ("gcsfs", "gcs"), "gcs": ("gcsfs", "gcs"),
    "az": ("adlfs", "azure"), "abfs": ("adlfs", "azure"), "abfss": ("adlfs", "azure"),
}
TRANSIENT = {"memory": ("fsspec", "dask")}  # within one process only
_URL_LIKE = re.compile(r"[A-Za-z][A-Za-z0-9+.-]+:/")  # also as pathlib leaves one: s3://b -> s3:/b


def is_url(path: str | os.PathLike[str]) -> bool:
    return "://" in os.fspath(path)


def scheme(url: str) -> str:
    return url.split("://", 1)[0].lower()


def refuse_url(path: str | os.PathLike[str], what: str) -> None:
    """InputError when `path`, the name of `what` (a local file or folder), is or looks like a URL
    (`s3:/b/x`: a URL made a Path)."""
    if _URL_LIKE.match(os.fspath(path)):
        raise InputError(f"{os.fspath(path)}: a URL, but {what} is written to a local path; odms-data "
                         "writes only stores to URLs")


def is_transient(url: str) -> bool:
    """A store at `url` lives only in the process that makes it."""
    return is_url(url) and scheme(url) in TRANSIENT


def refuse_transient(value: str) -> None:
    """InputError when `value` (a command-line argument) names a store that lives in one process."""
    if is_transient(value):
        raise InputError(f"{value}: a {scheme(value)}:// store lives only in the process that makes it; a "
                         "command would read nothing there and write what vanishes when it ends: use a path, "
                         "file:// or s3://")


def storage_options(path: str) -> dict[str, Any] | None:
    """fsspec options for a Zarr store at `path`: a `file://` store makes its folders as it writes."""
    return {"auto_mkdir": True} if is_url(path) and scheme(path) == "file" else None


def url_filesystem(url: str) -> tuple[Any, str]:
    """The fsspec filesystem of the store at `url` and the store's path in it, its listings of that
    path forgotten: fsspec shares one filesystem per process and caches what it lists, so a store
    replaced since (by zarr, through another instance) read as the old one's files, and on S3 an
    object whose ETag changed could not be opened. InputError for a scheme odms-data does not
    accept, MissingExtraError when the scheme's package is not installed."""
    name = scheme(url)
    if name not in SCHEMES and name not in TRANSIENT:
        raise InputError(f"{url}: odms-data reads and writes stores at a path, file://, "
                         f"{', '.join(f'{s}://' for s in SCHEMES if s != 'file')}; not at {name}://")
    package, _ = {**SCHEMES, **TRANSIENT}[name]
    optional("fsspec", f"a {name}:// store")
    optional(package, f"a {name}:// store")
    from fsspec.core import url_to_fs

    try:
        fs, root = url_to_fs(url)
    except (ValueError, TypeError) as e:
        raise InputError(f"{url}: not a store URL odms-data can open ({e})") from None
    fs.invalidate_cache(root)
    return fs, root


# the packages whose exceptions say an object store's client could not reach it: credentials it
# could not find or that were refused, an endpoint it could not connect to
_CLIENTS = ("botocore", "aiobotocore", "aiohttp", "google.auth", "google.api_core", "azure.core",
            "azure.identity")


def _from_client(e: BaseException) -> bool:
    modules = {c.__module__ for c in type(e).__mro__}
    return any(n == m or n.startswith(m + ".") for n in modules for m in _CLIENTS)


@contextmanager
def reaching(url: str) -> Iterator[None]:
    """Where a store at `url` is first reached: its client's failure to reach it (no credentials, no
    connection) becomes one line naming the URL (InputError), not an internal error."""
    try:
        yield
    except Exception as e:
        if not _from_client(e):
            raise
        why = " ".join(str(e).split())[:200] or type(e).__name__
        raise InputError(f"{url}: the object store cannot be reached ({why}); check its credentials and "
                         "endpoint (docs/DISTRIBUTED.md)") from None
