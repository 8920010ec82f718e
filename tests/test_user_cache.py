"""The user's cache folder (odms_data/user_cache.py): $XDG_CACHE_HOME/odms-data where it is set,
~/.cache/odms-data otherwise, a relative XDG_CACHE_HOME refused in one line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from _stores import make_store
from click.testing import CliRunner
from official_cache import cache_root

from odms_data.cli import main
from odms_data.evaluation.predictions import HEADER

REPO = Path(__file__).resolve().parents[1]


def test_score_finds_its_ground_truth_under_xdg_cache_home(tmp_path, monkeypatch):
    monkeypatch.delenv("ODMS_DATA", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    make_store(tmp_path / "xdg" / "odms-data" / "tiny-val.zarr", "tiny-val",
               [{"z": [1.0, 1.1], "areas": [100, 64], "d1": 1.0}])
    (tmp_path / "p.csv").write_text(f"{HEADER}\ntiny-val,tiny-val/000,1.0\n")
    r = CliRunner().invoke(main, ["score", str(tmp_path / "p.csv"), "--json"])
    assert r.exit_code == 0, r.output
    assert '"tiny-val"' in r.stdout


def test_the_official_store_cache_lives_under_xdg_cache_home(tmp_path, monkeypatch):
    monkeypatch.delenv("ODMS_TEST_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_root() == tmp_path / "odms-data" / "test-stores"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache_root() == Path.home() / ".cache" / "odms-data" / "test-stores"


def test_a_relative_xdg_cache_home_is_refused_in_one_line_and_nothing_is_written(tmp_path):
    """generate compiles its kernels into the cache folder: with XDG_CACHE_HOME=cache it would have
    made ./cache in the working folder; it stops before writing anything."""
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path / "home"), "PYTHONPATH": str(REPO),
           "XDG_CACHE_HOME": "cache"}
    for args in (["generate", "-n", "2", "-o", "g.zarr"], ["score", "p.csv"]):
        r = subprocess.run([sys.executable, "-m", "odms_data.cli", *args], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 2, r.stderr
        assert r.stderr.splitlines() == [
            "odms-data: error: XDG_CACHE_HOME 'cache' is a relative path; the XDG Base Directory "
            "specification allows only an absolute one: set it to an absolute path or unset it"]
        assert sorted(p.name for p in tmp_path.iterdir()) == [], args
