"""The Oddity record: what the store's `oddities` attribute holds, as written and read back."""

from __future__ import annotations

import pytest

from odms_data.errors import InputError
from odms_data.store.format import StoreAttrs
from odms_data.store.oddity import Oddity, skipped_details


def test_the_attribute_keeps_its_keys_and_reads_back_as_records():
    odd = [Oddity("z-not-increasing", "x/0", "z goes back"), Oddity("skipped", "line 3", "bad row")]
    attrs = StoreAttrs(split="x", domain="recording", image_size=(4, 5),
                       counts={"examples": 1, "frames": 2, "labelled": 1}, oddities=odd,
                       digest="sha256:" + "0" * 64, complete=True)
    written = attrs.to_json()
    assert written["oddities"] == [{"example": "x/0", "kind": "z-not-increasing", "detail": "z goes back"},
                                   {"example": "line 3", "kind": "skipped", "detail": "bad row"}]
    assert StoreAttrs.from_json(written, "here").oddities == odd
    assert skipped_details(odd) == ["bad row"]


def test_an_oddity_is_made_of_strings():
    with pytest.raises(InputError, match="oddity subject 3 is not a string"):
        Oddity("skipped", 3, "bad")  # type: ignore[arg-type]
