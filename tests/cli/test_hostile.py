"""The hostile catalogue (hostile.py): every case keeps every promise, by class."""

from __future__ import annotations

import pytest
from hostile import CASES, CLASSES, prepare, run_case


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory):
    return prepare(tmp_path_factory.mktemp("hostile"))


def test_every_class_has_cases():
    counts = {cls: sum(c.cls == cls for c in CASES) for cls in CLASSES}
    assert min(counts.values()) >= 10, counts
    assert len({c.name for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=[f"{c.cls}: {c.name}" for c in CASES])
def test_hostile_case_keeps_its_promises(case, fixtures, tmp_path):
    assert run_case(case, fixtures, tmp_path) == []
