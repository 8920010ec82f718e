"""The hostile catalogue (hostile.py): every case keeps every promise, by class."""

from __future__ import annotations

import gc
import warnings

import pytest
from hostile import CASES, CLASSES, prepare, run_case, run_inprocess


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


def test_the_inprocess_runner_judges_only_its_own_commands_output(tmp_path, monkeypatch):
    """A file an earlier test left open, in a cycle, is finalised whenever the collector runs, which
    may be while the next command runs: its ResourceWarning is not that command's stderr."""

    class Cycle:
        pass

    simplefilter = warnings.simplefilter

    def collecting(*args, **kwargs):  # the collector runs as the runner starts recording warnings
        simplefilter(*args, **kwargs)
        gc.collect()

    gc.disable()  # no collection but those asked for
    try:
        left = Cycle()
        left.me, left.file = left, open(tmp_path / "left-open", "w")  # left open on purpose
        del left
        with warnings.catch_warnings():
            simplefilter("ignore", ResourceWarning)  # the left file's warning, outside the command
            monkeypatch.setattr(warnings, "simplefilter", collecting)
            r = run_inprocess(["--version"], tmp_path)
    finally:
        gc.enable()
    assert r.rc == 0 and r.err == ""
