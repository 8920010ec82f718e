"""Shell completion of the values click cannot know: split names and store paths.

Enabled by the user's shell (`eval "$(_ODMS_DATA_COMPLETE=bash_source odms-data)"`, see
`odms-data --help`); click completes commands and options itself.
"""

from __future__ import annotations

import os
from pathlib import Path

import click
from click.shell_completion import CompletionItem

from ..store.format import format_of_name


def splits(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    """The named splits of splits/ that start with what was typed."""
    from ..store.manifests import split_names

    return [CompletionItem(name) for name in split_names() if name.startswith(incomplete)]


def stores(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    """The stores (`*.zarr`, `*.h5`, ...) and folders in the folder typed so far whose names start
    with the rest; a folder ends with '/', so that completion goes on inside it."""
    folder, sep, prefix = incomplete.rpartition("/")
    shown = folder + sep
    try:
        entries = sorted(Path(os.path.expanduser(shown) if sep else ".").iterdir())
    except OSError:
        return []
    items = []
    for entry in entries:
        name = entry.name
        if not name.startswith(prefix) or (name.startswith(".") and not prefix.startswith(".")):
            continue
        if format_of_name(entry) is not None and not name.endswith(".partial"):
            items.append(CompletionItem(shown + name))
        elif entry.is_dir():
            items.append(CompletionItem(f"{shown}{name}/"))
    return items


def stores_or_splits(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    """Store paths and split names (arguments that take either)."""
    return stores(ctx, param, incomplete) + splits(ctx, param, incomplete)
