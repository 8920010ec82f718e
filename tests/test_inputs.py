"""Confining data paths (odms_data/inputs.py): a folder's listing, links resolved only where they are."""

from __future__ import annotations

import ast
import os
from pathlib import Path

import pytest
from owner_ast import nodes_outside

from odms_data.errors import InputError
from odms_data.inputs import listed_inside


def _png(p: Path) -> bool:
    return p.suffix == ".png"


def test_a_listing_keeps_files_and_links_that_stay_inside(tmp_path):
    (tmp_path / "1.png").write_bytes(b"a")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "2.png").write_bytes(b"b")
    os.symlink(tmp_path / "sub" / "2.png", tmp_path / "2.png")  # a link, but to a file inside
    (tmp_path / "notes.txt").write_text("c")
    got = sorted(listed_inside(tmp_path, _png))
    assert got == [tmp_path / "1.png", tmp_path / "2.png"]


def test_a_link_out_of_the_folder_is_refused_naming_it(tmp_path):
    folder = tmp_path / "folder"
    folder.mkdir()
    (tmp_path / "private.png").write_bytes(b"secret")
    os.symlink(tmp_path / "private.png", folder / "3.png")
    with pytest.raises(InputError, match=r"'3\.png' lies outside"):
        listed_inside(folder, _png)


def test_a_link_out_that_is_not_asked_for_is_left_alone(tmp_path):
    folder = tmp_path / "folder"
    folder.mkdir()
    (tmp_path / "private.txt").write_text("secret")
    os.symlink(tmp_path / "private.txt", folder / "notes.txt")
    (folder / "1.png").write_bytes(b"a")
    assert listed_inside(folder, _png) == [folder / "1.png"]


def test_a_link_loop_is_refused_naming_it(tmp_path):
    os.symlink(tmp_path / "b.png", tmp_path / "a.png")
    os.symlink(tmp_path / "a.png", tmp_path / "b.png")
    with pytest.raises(InputError, match="cannot be resolved"):
        listed_inside(tmp_path, _png)


# modules that open a file for reading outside inputs.py, and why that file is not a stranger's
OWN_FILES = {
    "writer.py": "eight bytes of an existing output, to know whether it is a store it may replace",
    "choose.py": "eight bytes of a path `is_file` found regular, for the HDF5 signature",
    "hub_export.py": "the Parquet files and card this export has just written, to check them",
    "leaderboard.py": "the package's own entry schema",
    "format.py": "the package's own store-attributes schema",
    "leaderboard_site.py": "an earlier site's index.html, found regular, to know it may be replaced",
}


def _reads(node: ast.AST) -> bool:
    """Whether `node` reads a file: a path's .read_text() or .read_bytes(), or open(..), a path's
    .open(..) or os.fdopen(..) whose mode (its argument or mode=) is absent or holds no w, x or a."""
    if not isinstance(node, ast.Call):
        return False
    func = node.func
    if isinstance(func, ast.Attribute) and func.attr in ("read_text", "read_bytes"):
        return True
    name = func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""
    receiver = func.value.id if isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name) else ""
    if name not in ("open", "fdopen") or (name == "open" and (receiver in ("os", "zarr", "h5py")
                                                              or receiver[:1].isupper())):
        return False  # os.open, a library's or a class's own open
    position = 0 if isinstance(func, ast.Attribute) and name == "open" else 1
    modes = [k.value for k in node.keywords if k.arg == "mode"] + node.args[position:position + 1]
    mode = modes[0].value if modes and isinstance(modes[0], ast.Constant) else "r"
    return isinstance(mode, str) and not set(mode) & set("wxa")


def test_no_module_but_inputs_opens_a_file_to_read_unless_it_is_its_own():
    """A file a stranger names is opened only by inputs.py (a FIFO or device refused before it is
    read); the few modules that read a file the project itself just wrote are named with why."""
    found = sorted({name for name, node in nodes_outside("inputs.py") if _reads(node)})
    assert found == sorted(OWN_FILES)
