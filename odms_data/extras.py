"""Optional dependencies, the extras of setup.cfg: imported only by what needs them, and, where one
is missing, a one-line error naming the extra that installs it (`MissingExtraError`)."""

from __future__ import annotations

from importlib import import_module
from types import ModuleType

from .errors import MissingExtraError

EXTRAS = {  # top-level module -> the extra that installs it
    "torch": "torch",
    "tensorflow": "tf",
    "jax": "jax", "grain": "jax", "optax": "jax", "absl": "jax",
    "pyarrow": "hub",
    "matplotlib": "plot",
    "yaml": "yaml",
    "dask": "dask", "distributed": "dask", "fsspec": "dask",
    "s3fs": "s3", "gcsfs": "gcs", "adlfs": "azure",
}


def install_line(extra: str) -> str:
    return f"pip install 'odms-data[{extra}]' (in a clone of odms-data: pip install '.[{extra}]')"


def missing(error: ModuleNotFoundError, needed_by: str) -> ImportError:
    """The error to raise for `error`: a MissingExtraError when the module it names comes with an
    extra, else `error` itself (a broken installation is not a missing extra)."""
    top = (error.name or "").split(".")[0]
    if top not in EXTRAS:
        return error
    return MissingExtraError(f"{needed_by} needs {top}, which is not installed: {install_line(EXTRAS[top])}",
                             name=top)


def optional(module: str, needed_by: str) -> ModuleType:
    """`import module`, for `needed_by` (a command or feature, as the user names it)."""
    try:
        return import_module(module)
    except ModuleNotFoundError as e:
        raise missing(e, needed_by) from None


def pyplot(needed_by: str) -> ModuleType:
    """matplotlib.pyplot on the Agg backend (files, no display)."""
    optional("matplotlib", needed_by).use("Agg")
    return import_module("matplotlib.pyplot")
