"""Leaderboard entries are checked, not believed (issue 37): an entry written by hand that
disagrees with the split manifests, with its own sets, with another entry's name or with the
http(s) rule for links is refused with one line and exit code 2."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.errors import InputError
from odms_data.evaluation.leaderboard import entry_from_report, load_entries
from odms_data.evaluation.metrics import SplitScore
from odms_data.evaluation.scoring import ScoreReport
from odms_data.resources import resource_dir


def _shipped(name: str) -> dict:
    return json.loads((resource_dir("leaderboard") / name).read_text())


def _refused(tmp_path, *entries: dict, benchmark: str = "odms") -> str:
    """The one line `leaderboard --dir` answers for a folder of `entries`, which must be exit 2."""
    for i, e in enumerate(entries):
        (tmp_path / f"e{i}.json").write_text(json.dumps(e))
    r = CliRunner().invoke(main, ["leaderboard", "--dir", str(tmp_path), "--benchmark", benchmark])
    assert r.exit_code == 2 and r.stdout == "" and len(r.stderr.splitlines()) == 1, r.output
    return r.stderr


def test_store_digests_must_be_those_of_the_split_manifests(tmp_path):
    entry = _shipped("box_ls.json")
    entry["scored"]["stores"] = dict.fromkeys(entry["scored"]["stores"], "sha256:" + "0" * 64)
    assert "scored/stores/driving-test: sha256:000" in _refused(tmp_path, entry)
    assert "is not the digest of split driving-test" in _refused(tmp_path, entry)


def test_store_digests_cover_exactly_the_scored_sets(tmp_path):
    entry = _shipped("box_ls.json")
    del entry["scored"]["stores"]["robot-val"]
    assert "scored/stores/robot-val: of a scored set is missing" in _refused(tmp_path, entry)
    entry = _shipped("box_ls.json")
    entry["scored"]["stores"]["odmd-normal-test"] = entry["scored"]["stores"]["normal-test"]
    assert "scored/stores/odmd-normal-test: is not a split of its sets" in _refused(tmp_path, entry)


def test_an_all_that_is_not_the_mean_of_its_sets_is_refused(tmp_path):
    entry = _shipped("odmd-box_ls.json")  # sets averaging 11.82
    entry["results"]["test"]["all"] = 0.01
    line = _refused(tmp_path, entry, benchmark="odmd")
    assert "results/test/all: 0.01 is not the mean of its sets (11.8250)" in line


def test_an_all_without_every_set_is_refused(tmp_path):
    entry = _shipped("dbox.json")
    del entry["results"]["test"]["robot"]
    assert "results/test/all: an All needs every set of ODMS" in _refused(tmp_path, entry)


def test_the_printed_all_of_the_papers_is_kept():
    """ODMD prints the mean of its rounded figures (11.83 for 11.825): within the last digit."""
    odmd = {e.name: e for e in load_entries(benchmark="odmd")}
    assert odmd["Box_LS (ODMD, paper)"].results["test"]["all"] == 11.83


@pytest.mark.parametrize("name", ["Box_LS ", " Box_LS", "box_ls", "Box_LS\u00a0"])
def test_names_are_normalised_and_unique(tmp_path, name):
    other = _shipped("box_ls-paper.json")  # beside the shipped Box_LS
    other["name"] = name
    line = _refused(tmp_path, other)
    assert "white space" in line if name != "box_ls" else "also used by" in line


def test_a_name_that_differs_only_in_case_is_the_same_name(tmp_path):
    other = _shipped("box_ls-paper.json")
    other["name"] = "BOX_LS"
    assert "entry name 'BOX_LS' is also used by" in _refused(tmp_path, other)


def test_an_entry_spans_one_benchmark(tmp_path):
    entry = _shipped("dbox.json")
    entry["results"]["test"]["perturb_motion"] = {"percent": 1.0}
    line = _refused(tmp_path, entry)
    assert "results/test/perturb_motion: not a set of ODMS; an entry spans one benchmark" in line


def test_score_entry_over_odms_and_odmd_sets_is_refused():
    scores = [SplitScore("robot-test", "robot", 10, 10, 5.0, 5.0, 0.1),
              SplitScore("odmd-normal-test", "odmd", 10, 10, 1.0, 1.0, 0.1)]
    digests = {"robot-test": "sha256:" + "1" * 64, "odmd-normal-test": "sha256:" + "2" * 64}
    report = ScoreReport("p.csv", 20, scores, {}, False, digests=digests)
    with pytest.raises(InputError, match=r"p.csv: scores the sets of 2 benchmarks \(ODMS: robot-test; ODMD: "
                                         r"odmd-normal-test\); a leaderboard entry spans one benchmark"):
        entry_from_report(report, "Mixed")


@pytest.mark.parametrize("link", ["https://[::1", "https://", "javascript:alert(1)", "https://e.org:99999/",
                                  "http://exa mple.org\n"])
def test_links_are_parsed_not_pattern_matched(tmp_path, link):
    entry = _shipped("dbox.json")
    entry["link"] = link
    assert "link " in _refused(tmp_path, entry) and "not an http(s) address" in _refused(tmp_path, entry)


def _test_report(intervals: bool) -> ScoreReport:
    """A complete score of ODMS's four test sets, with the split manifests' digests."""
    from odms_data.evaluation.metrics import all_scores
    from odms_data.store.manifests import load_manifest

    scores = [SplitScore(f"{d}-test", d, 10, 10, 10.0 + i, 9.0, 0.1)
              for i, d in enumerate(("robot", "driving", "normal", "perturb"))]
    for s in scores if intervals else ():
        s.ci95 = {"mean_percent_error": (s.mean_percent_error - 1.23456, s.mean_percent_error + 2.0)}
    alls = all_scores(scores)
    for a in alls if intervals else ():
        a.ci95 = {"mean_percent_error": (10.0, 13.5)}
    return ScoreReport("p.csv", 40, scores, alls, False,
                       digests={s.split: load_manifest(s.split).digest for s in scores})


def test_score_entry_records_each_interval_beside_its_mean():
    test = entry_from_report(_test_report(True), "Mine").results["test"]
    assert test["robot"]["ci95"] == [8.7654, 12.0] and test["perturb"]["ci95"] == [11.7654, 15.0]
    assert test["all"] == 11.5 and test["all_ci95"] == [10.0, 13.5]
    bare = entry_from_report(_test_report(False), "Mine").results["test"]
    assert "ci95" not in bare["robot"] and "all_ci95" not in bare


@pytest.mark.parametrize(("where", "interval", "why"), [
    ("robot", [20.0, 21.0], "results/test/robot/ci95: [20.0, 21.0] does not hold its mean"),
    ("robot", [19.0, 18.0], "results/test/robot/ci95: [19.0, 18.0] is not an interval"),
    ("all_ci95", [1.0, 2.0], "results/test/all_ci95: [1.0, 2.0] does not hold its mean"),
])
def test_a_computed_interval_must_hold_its_mean(tmp_path, where, interval, why):
    entry = _shipped("box_ls.json")
    if where == "all_ci95":
        entry["results"]["test"]["all_ci95"] = interval
    else:
        entry["results"]["test"][where]["ci95"] = interval
    assert why in _refused(tmp_path, entry)


def test_a_published_interval_need_not_hold_the_rounded_mean_but_must_be_one(tmp_path):
    entry = _shipped("dbox.json")
    entry["results"]["test"]["robot"]["ci95"] = [11.6, 13.0]  # a paper's interval of unrounded means
    (tmp_path / "e.json").write_text(json.dumps(entry))
    assert load_entries(tmp_path)[0].results["test"]["robot"]["ci95"] == [11.6, 13.0]
    entry["results"]["test"]["robot"]["ci95"] = [13.0, 11.6]
    assert "is not an interval (lo > hi)" in _refused(tmp_path, entry)
