"""What the tests of the owners share (one module per class of work, nothing around it): every
AST node of every odms_data module but the owner, and the modules a node imports."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import odms_data

PACKAGE = Path(odms_data.__file__).parent


def nodes_outside(owner: str) -> Iterator[tuple[str, ast.AST]]:
    """(module file name, node) for every node of every odms_data module but `owner` (a path
    under odms_data/)."""
    for path in sorted(PACKAGE.rglob("*.py")):
        if path != PACKAGE / owner:
            for node in ast.walk(ast.parse(path.read_text())):
                yield path.name, node


def imported(node: ast.AST) -> list[str]:
    """The modules `node` imports (`import a.b` and `from a.b import c` both give 'a.b')."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if isinstance(node, ast.ImportFrom):
        return [node.module or ""]
    return []
