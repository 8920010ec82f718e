"""Metrics against hand-computed values, reports, leaderboard entries and rendering, plots."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _stores import make_store
from broken_stores import opened
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.errors import InputError
from odms_data.evaluation.leaderboard import (
    LeaderboardEntry,
    entry_from_report,
    entry_problems,
    family_all,
    load_entries,
    render_markdown,
)
from odms_data.evaluation.metrics import SplitScore, percent_errors, score_split
from odms_data.evaluation.metrics import all_by_family as report_all
from odms_data.evaluation.predictions import HEADER
from odms_data.resources import resource_dir

OFFICIAL = [f"{d}-{f}" for f in ("val", "test") for d in ("robot", "driving", "normal", "perturb")]


def test_metrics_against_hand_computed_values():
    truth, pred = np.array([1.0, 2.0, 4.0, 0.5]), np.array([1.1, 1.5, 4.0, -0.5])
    assert percent_errors(pred, truth) == pytest.approx([10.0, 25.0, 0.0, 200.0])
    s = score_split("normal-val", "normal", pred, truth, total=4)
    assert s.mean_percent_error == pytest.approx(58.75)
    assert s.median_percent_error == pytest.approx(17.5)
    assert s.mean_abs_error_m == pytest.approx((0.1 + 0.5 + 0.0 + 1.0) / 4)
    assert (s.abs_unit, s.mean_abs_error) == ("cm", pytest.approx(40.0))
    d = score_split("driving-val", "driving", pred, truth, total=5)
    assert (d.abs_unit, d.mean_abs_error, d.partial) == ("m", pytest.approx(0.4), True)


def _score(split, pct, partial=False):
    return SplitScore(split, split.split("-")[0], 9 if partial else 10, 10, pct, pct, 0.1)


def test_all_is_the_unweighted_mean_of_four_complete_splits():
    scores = [_score(s, p) for s, p in zip(OFFICIAL, [10, 20, 30, 40, 1, 2, 3, 4], strict=True)]
    assert report_all(scores) == {"val": 25.0, "test": 2.5}
    assert report_all(scores[:3] + scores[4:]) == {"test": 2.5}
    assert report_all([*scores[:3], _score("perturb-val", 40, partial=True)]) == {}
    fake = SplitScore("robot-val", "generated", 10, 10, 1.0, 1.0, 0.1)  # a generated store named robot-val
    assert report_all([fake, *scores[1:4]]) == {}


@pytest.fixture(scope="module")
def official_like(tmp_path_factory):
    """Eight tiny stores named and labelled like the official splits."""
    root = tmp_path_factory.mktemp("official-like")
    for split in OFFICIAL:
        domain = split.split("-")[0]
        ex = [{"z": [d, d + 0.1], "areas": [100, 64], "d1": d} for d in (0.5, 1.0)]
        make_store(root / f"{split}.zarr", split, ex, domain=domain)
    return root


def _preds(tmp_path, factor=1.1):
    rows = [f"{s},{s}/{i:03d},{d * factor!r}" for s in OFFICIAL for i, d in enumerate((0.5, 1.0))]
    p = tmp_path / "preds.csv"
    p.write_text("\n".join([HEADER, *rows]) + "\n")
    return p


def test_score_outputs_table_markdown_and_json(tmp_path, official_like):
    p = _preds(tmp_path)
    run = CliRunner().invoke
    text = run(main, ["score", str(p), "--data", str(official_like)])
    assert text.exit_code == 0, text.output
    assert "All (val) = 10.00" in text.stdout and "All (test) = 10.00" in text.stdout
    assert "7.50 cm" in text.stdout  # mean of 5 and 10 cm
    md = run(main, ["score", str(p), "--data", str(official_like), "--markdown"])
    assert "| **All (test)** | | **10.00** | | |" in md.stdout
    js = json.loads(run(main, ["score", str(p), "--data", str(official_like), "--json"]).stdout)
    assert [s["split"] for s in js["splits"]] == OFFICIAL
    assert [s["abs_unit"] for s in js["splits"]][:4] == ["cm", "m", "cm", "cm"]
    assert js["all"] == {"val": pytest.approx(10.0), "test": pytest.approx(10.0)}
    both = run(main, ["score", str(p), "--data", str(official_like), "--json", "--markdown"])
    assert both.exit_code == 2


def test_entry_is_schema_valid_and_joins_the_leaderboard(tmp_path, official_like):
    """An entry records the digests of the stores it was scored against, and joins the board only
    when they are the split manifests' (here the tiny stores' are not: the official ones are put in)."""
    from dataclasses import replace

    from odms_data.evaluation.ground_truth import find_stores, load_truth
    from odms_data.evaluation.predictions import read_predictions
    from odms_data.evaluation.scoring import score
    from odms_data.store.manifests import load_manifest

    truths = {s: load_truth(p) for s, p in find_stores([official_like]).items()}
    report = score(read_predictions(_preds(tmp_path, 1.05)), truths)
    with pytest.raises(InputError, match="scored/stores/driving-test: sha256:.* is not the digest of split"):
        entry_from_report(report, "Mine")
    report = replace(report, digests={s: load_manifest(s).digest for s in report.digests})
    entry = entry_from_report(report, "Mine", link="https://example.org/mine").to_json()
    assert entry_problems(entry) == []
    assert entry["figures"] == "computed" and entry["results"]["test"]["all"] == pytest.approx(5.0)
    assert set(entry["scored"]["stores"]) == set(OFFICIAL)
    out = tmp_path / "board" / "mine.json"
    out.parent.mkdir()
    out.write_text(json.dumps(entry))
    board = CliRunner().invoke(main, ["leaderboard", "--dir", str(out.parent)])  # ranked among the shipped
    assert board.exit_code == 0, board.output
    rows = [line for line in board.stdout.splitlines() if line.startswith("| ") and line[2].isdigit()]
    assert len(rows) == 27 and rows[1].startswith("| 2 | [DBox]")
    assert rows[0] == ("| 1 | [Mine](https://example.org/mine) | – | – | 5.0 | 5.0 | 5.0 | 5.0 | 5.0 "
                       "| computed here |")
    assert board.stdout.endswith("Object Depth Estimation on a Mobile Robot, WACV 2020.\n")
    assert "Sources: ." not in board.stdout  # an entry without a citation adds none


def test_score_entry_refuses_a_store_named_robot_val_with_other_content(tmp_path):
    """A store named robot-val, consistent with its own digest, but not the official content: no
    entry, whose digests would pass for the official ones."""
    data = tmp_path / "data"
    ids = _valid_store(data / "robot-val.zarr", "robot-val")
    preds = tmp_path / "p.csv"
    preds.write_text("\n".join([HEADER, *(f"robot-val,{i},1.0" for i in ids)]) + "\n")
    out = tmp_path / "mine.json"
    r = CliRunner().invoke(main, ["score", str(preds), "--data", str(data), "--name", "Mine",
                                  "--entry", str(out)])
    assert r.exit_code == 2 and "does not match split 'robot-val'" in r.stderr, r.output
    assert "official content only" in r.stderr and not out.exists()


def _valid_store(path, split):
    from broken_stores import make_valid

    from odms_data.store.reader import open_store

    make_valid(path, 4, split=split)
    with open_store(str(path)) as s:
        return s.example_ids


def test_score_entry_refuses_labels_doubled_after_the_digest(tmp_path):
    """A store whose labels were doubled after it was written (its recorded digest kept)."""
    data = tmp_path / "data"
    ids = _valid_store(data / "mine.zarr", "mine")
    with opened(data / "mine.zarr") as root:
        root["d1"][:] = 2 * root["d1"][:]
    preds = tmp_path / "p.csv"
    preds.write_text("\n".join([HEADER, *(f"mine,{i},1.0" for i in ids)]) + "\n")
    plain = CliRunner().invoke(main, ["score", str(preds), "--data", str(data)])
    assert plain.exit_code == 0, plain.output  # scoring alone reads the labels only
    r = CliRunner().invoke(main, ["score", str(preds), "--data", str(data), "--name", "M",
                                  "--entry", str(tmp_path / "e.json")])
    assert r.exit_code == 2 and "differs from the recorded" in r.stderr, r.output


def test_entry_needs_a_name_and_a_complete_score(tmp_path, official_like):
    p = _preds(tmp_path)
    run = CliRunner().invoke
    r = run(main, ["score", str(p), "--data", str(official_like), "--entry", str(tmp_path / "e.json")])
    assert r.exit_code == 2 and "--entry and --name go together" in r.stderr
    lines = p.read_text().splitlines()
    p.write_text("\n".join(lines[:-1]) + "\n")
    r = run(main, ["score", str(p), "--data", str(official_like), "--allow-partial", "--name", "X",
                   "--entry", str(tmp_path / "e.json")])
    assert r.exit_code == 2 and "drop --allow-partial" in r.stderr
    assert not (tmp_path / "e.json").exists()


def test_shipped_entries_are_valid_and_match_the_published_all():
    entries = {e.name: e for e in load_entries()}
    assert len(entries) == 26
    assert family_all(entries["DBox"], "test") == 17.1
    assert family_all(entries["Box_LS (paper)"], "test") == 25.3
    assert family_all(entries["ODN_l"], "test") == pytest.approx((19.3 + 30.1 + 8.3 + 18.2) / 4)
    assert entries["VOS-DE (paper)"].results["test"]["driving"]["percent"] == 36.0
    computed = entries["VOS-DE"]
    assert computed.figures == "computed" and computed.n_obs == 10
    assert round(computed.results["test"]["driving"]["percent"], 2) == 35.76
    box_ls = entries["Box_LS"]  # --odmd-conversion: the published driving, normal and perturb figures
    assert box_ls.figures == "computed" and box_ls.n_obs == 10
    assert [round(box_ls.results["test"][d]["percent"], 1) for d in ("driving", "normal", "perturb")] == [
        33.3, 13.7, 36.6]


def test_odmds_table_holds_the_published_figures_and_box_ls_computed_here():
    entries = {e.name: e for e in load_entries(benchmark="odmd")}
    assert {e.name for e in load_entries()}.isdisjoint(entries)  # the ODMS table shows none of them
    published = ("DBox (ODMD)", "DBox_Abs (ODMD)", "Box_LS (ODMD, paper)")
    assert [family_all(entries[n], "test") for n in published] == [4.47, 4.55, 11.83]
    computed = entries["Box_LS (ODMD)"].results["test"]
    paper = entries["Box_LS (ODMD, paper)"].results["test"]
    assert computed.keys() == paper.keys()
    sets = [d for d in paper if d != "all"]
    assert {d: round(computed[d]["percent"], 2) for d in sets} == {d: paper[d]["percent"] for d in sets}
    # ODMD's All is the mean of its rounded figures (11.825 -> 11.83); ours of the exact ones, 11.8246
    assert computed["all"] == pytest.approx(paper["all"], abs=0.006)
    board = render_markdown(list(entries.values()), benchmark="odmd")
    assert "| Normal | Perturb motion | Perturb detection | Robot | All |" in board
    page = (resource_dir("schemas").parent / "docs" / "LEADERBOARD.md").read_text()
    assert board in page, "docs/LEADERBOARD.md is stale: paste `leaderboard --benchmark odmd` into it"


def test_leaderboard_is_sorted_by_all_and_its_page_shows_it():
    board = render_markdown(load_entries())
    rows = [line for line in board.splitlines() if line.startswith("| ") and line[2].isdigit()]
    alls = [float(r.split("|")[-3]) for r in rows if r.split("|")[-3].strip() != "–"]
    assert alls == sorted(alls) and rows[0].startswith("| 1 | [DBox]")
    page = (resource_dir("schemas").parent / "docs" / "LEADERBOARD.md").read_text()
    assert board in page, "docs/LEADERBOARD.md is stale: paste `odms-data leaderboard` into it"


def test_an_entry_is_checked_when_made():
    entry = load_entries()[0]
    assert LeaderboardEntry.from_json(entry.to_json(), "again") == entry
    with pytest.raises(InputError, match="entry 'x': not a valid leaderboard entry"):
        LeaderboardEntry(name="x", method="x", figures="guessed", citation=None, link=None, results={})


def test_leaderboard_rejects_an_invalid_entry(tmp_path):
    (tmp_path / "bad.json").write_text(json.dumps({"name": "x", "results": {}}))
    with pytest.raises(InputError, match=r"bad.json: not a valid leaderboard entry: at \(root\)"):
        load_entries(tmp_path)
    r = CliRunner().invoke(main, ["leaderboard", "--dir", str(tmp_path)])
    assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1


def test_plot_is_written(tmp_path, official_like):
    png = tmp_path / "errors.png"
    r = CliRunner().invoke(main, ["score", str(_preds(tmp_path)), "--data", str(official_like),
                                  "--plot", str(png)])
    assert r.exit_code == 0, r.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_without_matplotlib_says_how_to_get_it(tmp_path, official_like):
    """A child interpreter where `import matplotlib` fails, as on an install without the extra."""
    import subprocess
    import sys

    code = ("import sys; sys.modules['matplotlib'] = None; from odms_data.cli import main; "
            "main(sys.argv[1:], prog_name='odms-data')")
    args = ["score", str(_preds(tmp_path)), "--data", str(official_like), "--plot", str(tmp_path / "e.png")]
    r = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True)
    assert (r.returncode, r.stdout) == (2, "")
    assert r.stderr.strip() == ("odms-data: error: odms-data score --plot needs matplotlib, which is not "
                                "installed: pip install 'odms-data[plot]' (in a clone of odms-data: pip "
                                "install '.[plot]')")
