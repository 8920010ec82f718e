"""benchmarks/RESULTS.md is what benchmarks/render_results.py makes of the JSON in
benchmarks/results/, and every JSON says where, when and at which commit it was measured, and
against which baseline."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
ASV = Path(__file__).resolve().parents[1] / "asv_bench" / "benchmarks"
MOVED_TO_ASV = {
    "generate.py": "generate.py", "write_rule.py": "generate.py", "stream.py": "loaders.py",
    "validate.py": "stores.py", "startup.py": "startup.py", "store_builder.py": "boxes.py",
    "untrusted_bounds.py": "odmd.py", "untrusted_checks.py": "imports.py", "untrusted_reads.py": "stores.py",
}
"""Scripts whose measurement asv_bench/ now makes; their last JSON stays as the published record."""


def _renderer():
    spec = importlib.util.spec_from_file_location("render_results", BENCHMARKS / "render_results.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_results_md_is_rendered_from_the_json():
    text = _renderer().render(BENCHMARKS / "results")
    assert (BENCHMARKS / "RESULTS.md").read_text() == text, "run python benchmarks/render_results.py"


def test_every_result_names_its_machine_date_commit_and_baseline():
    files = sorted((BENCHMARKS / "results").glob("*.json"))
    assert files
    for path in files:
        r = json.loads(path.read_text())
        script = Path(r["script"]).name
        assert (BENCHMARKS / script).is_file() or (ASV / MOVED_TO_ASV[script]).is_file(), path
        assert r["machine"]["cores"] >= 1 and r["machine"]["cpu_model"], path
        assert r["date"][:2] == "20" and r["commit"], path
        assert {"what", "value", "unit"} <= set(r["baseline"]), path
        assert r["rows"] and all(list(row) == list(r["rows"][0]) for row in r["rows"]), path


def test_no_result_holds_a_path_of_the_machine_it_ran_on():
    """_results.py cuts the clone's, the home folder's and any other absolute path out of what it writes."""
    import re

    machine_path = re.compile(r"(?<![\w.~:/])/(?:work|root|home|tmp|Users|private)/")
    for path in [*sorted((BENCHMARKS / "results").glob("*.json")), BENCHMARKS / "RESULTS.md"]:
        found = machine_path.search(path.read_text())
        assert found is None, (path.name, found)
