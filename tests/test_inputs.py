"""Confining data paths (odms_data/inputs.py): a folder's listing, links resolved only where they are."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

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
