"""`leaderboard --html`: the site in a real browser (headless Chromium from Debian's packages,
driven by selenium through Debian's chromium-driver). The tests read the table from the DOM, sort
it by clicking a column heading, take screenshots, and load entries whose text is an HTML/script
injection to check nothing of it runs."""

from __future__ import annotations

import json
import os
import shutil

import pytest
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.evaluation.leaderboard import family_all, load_entries, ranked
from odms_data.evaluation.leaderboard_site import entry_page
from odms_data.resources import resource_dir

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
INJECTION = ('<img src=x onerror="window.pwned=1"><script>window.pwned=1</script>'
             '"><svg onload="window.pwned=1">')


@pytest.fixture(scope="module")
def browser():
    if not (CHROMIUM and DRIVER):
        pytest.skip("no Chromium here: apt-get install chromium chromium-driver (Debian) runs these tests")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--disable-gpu", "--window-size=1100,760"):
        options.add_argument(arg)
    if os.geteuid() == 0:  # Chromium's sandbox refuses to run as root (a CI container)
        options.add_argument("--no-sandbox")
    driver = webdriver.Chrome(service=Service(DRIVER), options=options)
    yield driver
    driver.quit()


def _site(tmp_path, *folders) -> str:
    out = tmp_path / "site"
    dirs = [a for f in folders for a in ("--dir", str(f))]
    r = CliRunner().invoke(main, ["leaderboard", "--html", str(out), *dirs])
    assert r.exit_code == 0, r.output
    return out.as_uri()


def _column(driver, col: int, table: str = "board-test") -> list[str]:
    return [td.text for td in driver.find_elements("css selector", f"#{table} tbody tr td:nth-child({col})")]


def test_the_odms_page_shows_the_ranked_table_and_sorts_by_a_column(browser, tmp_path):
    browser.get(_site(tmp_path) + "/odms.html")
    assert browser.title == "ODMS leaderboard"
    expected = ranked(load_entries())
    assert _column(browser, 2) == [e.name for e in expected]
    assert _column(browser, 9) == [f"{family_all(e, 'test'):.1f}" for e in expected]
    assert _column(browser, 10).count("computed here") == 2
    assert "=" in _column(browser, 1)[4]  # ODN_l and ODN_dbar: All 19.0 both, a tie
    heads = browser.find_elements("css selector", "#board-test thead th button")
    robot = [h for h in heads if h.text == "Robot"][0]
    robot.click()
    values = [float(v) for v in _column(browser, 5)]
    before = [e.results["test"]["robot"]["percent"] for e in expected]
    assert values == sorted(values) and values != before
    robot.click()
    assert [float(v) for v in _column(browser, 5)] == sorted(values, reverse=True)
    shot = tmp_path / "odms.png"
    assert browser.save_screenshot(str(shot)) and shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_odmd_page_and_an_entry_page(browser, tmp_path):
    url = _site(tmp_path)
    browser.get(url + "/odmd.html")
    assert _column(browser, 2) == ["DBox (ODMD)", "DBox_Abs (ODMD)", "Box_LS (ODMD)", "Box_LS (ODMD, paper)"]
    assert _column(browser, 11)[2] == "8 stores"  # the computed entry's digests, folded
    shot = tmp_path / "odmd.png"
    assert browser.save_screenshot(str(shot)) and shot.stat().st_size > 1000
    browser.find_element("link text", "Box_LS (ODMD)").click()
    assert browser.title == "Box_LS (ODMD)"
    link = browser.find_element("css selector", "a[rel~=noopener]")
    assert link.get_attribute("href") == "https://github.com/griffbr/ODMD"
    digests = json.loads((resource_dir("leaderboard") / "odmd-box_ls.json").read_text())["scored"]["stores"]
    assert digests["odmd-robot-test"] in browser.page_source


def test_an_injected_name_citation_and_note_run_nothing(browser, tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    entry = json.loads((resource_dir("leaderboard") / "dbox.json").read_text())
    entry.update(name=INJECTION, method=INJECTION, citation=INJECTION, note="</td></tr></table>" + INJECTION,
                 link='https://e.org/"><script>window.pwned=1</script>', training_data=INJECTION)
    (mine / "evil.json").write_text(json.dumps(entry))
    url = _site(tmp_path, mine)
    browser.get(url + "/odms.html")
    assert INJECTION in _column(browser, 2)  # shown as text, whole
    assert browser.execute_script("return window.pwned === undefined && document.images.length === 0")
    page = load_entries(mine)[0]
    browser.get(f"{url}/entries/{entry_page(page)}")
    assert browser.find_element("css selector", "h1").text == INJECTION
    assert browser.execute_script("return window.pwned === undefined && document.images.length === 0 && "
                                  "document.querySelectorAll('script').length === 1")
    href = browser.find_element("css selector", "a[rel~=noopener]").get_attribute("href")
    assert href == "https://e.org/%22%3E%3Cscript%3Ewindow.pwned=1%3C/script%3E"


def test_the_site_replaces_only_an_earlier_site(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    run = CliRunner().invoke
    for args in (["--html", str(mine)], ["--html", str(mine), "--overwrite"], ["--html", "s", "--json"]):
        r = run(main, ["leaderboard", *args])
        assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1, r.output
    assert (mine / "notes.txt").read_text() == "keep me" and not (tmp_path / "s").exists()
    site = tmp_path / "site"
    assert run(main, ["leaderboard", "--html", str(site)]).exit_code == 0
    assert run(main, ["leaderboard", "--html", str(site)]).exit_code == 2
    assert run(main, ["leaderboard", "--html", str(site), "--overwrite"]).exit_code == 0
    pages = {p.relative_to(site).as_posix() for p in site.rglob("*.html")}
    entries = [e for b in ("odms", "odmd") for e in load_entries(benchmark=b)]
    assert pages == {"index.html", "odms.html", "odms-detection.html", "odmd.html",
                     *(f"entries/{entry_page(e)}" for e in entries)} and len(pages) == 4 + 30
    for page in site.rglob("*.html"):  # self-contained: nothing loaded from elsewhere
        text = page.read_text()
        assert " src=" not in text and "<link" not in text and "@import" not in text and "url(" not in text


@pytest.fixture(scope="module")
def scored(official_entry, tmp_path_factory):
    """VOS-DE's predictions over the imported official stores (mine.csv) and its entry (mine.json,
    as `score --entry` writes it), in a folder of their own; the stores."""
    from odms_data.evaluation.evaluate import Evaluation
    from odms_data.evaluation.leaderboard import entry_from_report

    stores, board = official_entry / "stores", tmp_path_factory.mktemp("scored")
    r = CliRunner().invoke(main, ["baseline", "vosde", "--data", str(stores), "-o", str(board / "mine.csv")])
    assert r.exit_code == 0, r.output
    preds, report = Evaluation([str(stores)]).score(board / "mine.csv")
    entry = entry_from_report(report, "Mine", predictions_sha256=preds.sha256).to_json()
    (board / "mine.json").write_text(json.dumps(entry))
    return board, stores, report


def _board(scored, tmp_path):
    board = tmp_path / "board"
    shutil.copytree(scored[0], board)
    return board, json.loads((board / "mine.json").read_text())


def test_an_entry_with_intervals_shows_mean_lo_hi(browser, scored, tmp_path):
    board, entry = _board(scored, tmp_path)
    test = entry["results"]["test"]
    url = _site(tmp_path, board)
    browser.get(url + "/odms.html")
    row = _column(browser, 2).index("Mine")
    robot, total = test["robot"], test["all"]
    (rlo, rhi), (alo, ahi) = robot["ci95"], test["all_ci95"]
    assert _column(browser, 5)[row] == f"{robot['percent']:.1f} [{rlo:.1f}, {rhi:.1f}]"
    assert _column(browser, 9)[row] == f"{total:.1f} [{alo:.1f}, {ahi:.1f}]"
    assert test["all_ci95"][0] < total < test["all_ci95"][1]
    assert "[" not in _column(browser, 9)[0]  # DBox: published, no interval
    browser.get(f"{url}/entries/{entry_page(load_entries(board)[0])}")
    assert f"[{robot['ci95'][0]}, {robot['ci95'][1]}]" in browser.find_element("css selector", "body").text


def _one_approach_exact(board, report) -> None:
    """mine2.csv: mine.csv with one robot approach predicted exactly, the one whose summed percent
    error is nearest 8000 (All drops by about 8000 / 2640 / 4 = 0.76 points, in one recorded
    sequence of 48): an entry `compare` cannot separate from mine.csv, with a different printed
    All, still above Box_LS's."""
    import numpy as np
    import pandas as pd

    from odms_data.evaluation.leaderboard import entry_from_report
    from odms_data.evaluation.predictions import read_predictions
    from odms_data.evaluation.scoring import score, sequence_codes

    truth = report.truths["robot-test"]
    idx, pred = report.scored["robot-test"]
    codes = sequence_codes(truth, idx)
    errors = np.bincount(codes, np.abs(pred - truth.d1[idx]) / truth.d1[idx] * 100)
    worst = idx[codes == int(np.argmin(np.abs(errors - 8000)))]
    frame = pd.read_csv(board / "mine.csv", dtype={"example_id": str})
    exact = dict(zip([truth.example_ids[i] for i in worst], truth.d1[worst], strict=True))
    hit = (frame["split"] == "robot-test") & frame["example_id"].isin(exact)
    frame.loc[hit, "d1"] = frame.loc[hit, "example_id"].map(exact)
    frame.to_csv(board / "mine2.csv", index=False)
    preds = read_predictions(board / "mine2.csv")
    again = score(preds, report.truths)
    entry = entry_from_report(again, "Mine, one approach exact", predictions_sha256=preds.sha256)
    (board / "mine2.json").write_text(json.dumps(entry.to_json()))


def test_neighbours_that_compare_cannot_separate_are_marked_tied(browser, scored, tmp_path):
    board, entry = _board(scored, tmp_path)
    _one_approach_exact(board, scored[2])
    alls = [
        json.loads((board / f).read_text())["results"]["test"]["all"] for f in ("mine2.json", "mine.json")]
    assert f"{alls[0]:.1f}" != f"{alls[1]:.1f}"  # not a tie at the printed precision
    for data, tied in (([], False), (["--data", str(scored[1])], True)):
        out = tmp_path / f"site{tied}"
        r = CliRunner().invoke(main, ["leaderboard", "--html", str(out), "--dir", str(board), *data])
        assert r.exit_code == 0, r.output
        browser.get(out.as_uri() + "/odms.html")
        names = _column(browser, 2)
        row = names.index("Mine, one approach exact")
        assert names[row + 1] == "Mine"
        ranks = _column(browser, 1)[row:row + 2]
        assert [rank.startswith("=c") for rank in ranks] == [tied, tied], ranks
        assert tied or "=" not in ranks[0]  # without --data: 27.0 and 27.5 are no tie
        notes = browser.find_elements("css selector", "#tie-compare-test")
        assert [n.text.startswith("c Tied by `odms-data compare`") for n in notes] == [True] * tied
        page = entry_page(load_entries(board)[0])
        browser.get(f"{out.as_uri()}/entries/{page}")  # breakdown plots with --data only
        images = browser.find_elements("css selector", "img")
        assert len(images) == tied and (out / "entries" / page.replace(".html", ".png")).exists() is tied
        for img in images:
            assert img.get_attribute("src") == f"{out.as_uri()}/entries/{page.replace('.html', '.png')}"
            shown = "return arguments[0].complete && arguments[0].naturalWidth"
            assert browser.execute_script(shown, img) > 500  # loaded under the page's policy
    assert "is for --html" in CliRunner().invoke(main, ["leaderboard", "--data", str(scored[1])]).stderr


def test_verify_rescores_entries_that_ship_predictions_and_names_what_changed(scored, tmp_path):
    """VOS-DE's entry with its CSV beside it, and a copy whose robot figure (and All with it) and
    All interval were edited: verify keeps the first and names the edited figures of the second."""
    board, entry = _board(scored, tmp_path)
    stores = scored[1]
    run = CliRunner().invoke
    edited = json.loads(json.dumps(entry))
    edited["name"] = "Mine, edited"
    edited["results"]["test"]["robot"]["percent"] += 0.4
    edited["results"]["test"]["all"] += 0.1
    lo, hi = entry["results"]["test"]["all_ci95"]
    edited["results"]["test"]["all_ci95"] = [lo - 0.5, hi]
    (board / "edited.json").write_text(json.dumps(edited))
    (board / "edited.csv").write_bytes((board / "mine.csv").read_bytes())
    r = run(main, ["leaderboard", "verify", "--dir", str(board), "--data", str(stores)])
    assert r.exit_code == 1, r.output
    lines = r.stdout.splitlines()
    robot, total = entry["results"]["test"]["robot"]["percent"], entry["results"]["test"]["all"]
    assert lines[0] == f"Mine, edited ({board / 'edited.json'}): 3 figures no longer match"
    assert lines[1:4] == [
        f"  test robot percent: the entry says {robot + 0.4}, its predictions now give {robot}",
        f"  test All: the entry says {total + 0.1}, its predictions now give {total}",
        f"  test All ci95: the entry says {[lo - 0.5, hi]}, its predictions now give {[lo, hi]}"]
    assert lines[4].startswith(f"Mine ({board / 'mine.json'}): all ") and lines[4].endswith(" figures match")
    assert lines[5].startswith("2 entries ship their predictions, 1 no longer match; 30 ship none")
    (board / "edited.csv").write_text("split,example_id,d1\n")
    r = run(main, ["leaderboard", "verify", "--dir", str(board), "--data", str(stores)])
    assert "edited.csv is not the file the entry was scored from" in r.stdout, r.output
