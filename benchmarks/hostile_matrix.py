"""The hostile matrix (tests/cli/matrix.py, issue 37 §2) run whole, and the sample CI runs.

Run by hand: `python benchmarks/hostile_matrix.py [--only TEXT] [--sample N] [--before OLD.json]`.
- The matrix: every parameter of every command (click's tree) with every hostile value of its
  kind, each case in its own process forked from one server, judged by matrix.judge.
- The sample: what tests/cli/test_matrix.py runs (matrix.sample, its fixed seed), timed apart,
  as CI runs it (a fresh server and fixtures).
Writes benchmarks/results/hostile_matrix.json (_results.py): the cases and those kept by kind,
the sample's time as the baseline, the matrix (command, parameter, kind, values) and every broken
case with what it broke.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / "benchmarks"), str(REPO / "tests" / "cli")]
import _results  # noqa: E402
import matrix  # noqa: E402


def run(cases: list[matrix.MatrixCase], root: Path, verbose: bool) -> tuple[float, dict[str, list[str]]]:
    """Seconds (fixtures and server start included) and the broken promises of each case."""
    t = time.perf_counter()
    matrix.prepare(root / "fixtures")
    work = root / "work"
    work.mkdir()
    server = matrix.Server(matrix.FIXTURES)
    broken = {}
    try:
        for case in cases:
            try:
                broken[case.id], _ = matrix.run_case(case, server, work)
            except Exception as e:  # the case's own set-up failed: count it, go on
                broken[case.id] = [f"the case could not be set up: {type(e).__name__}: {e}"]
            if verbose and broken[case.id]:
                print(f"BROKEN {case.id!r}: {'; '.join(broken[case.id])[:300]}", flush=True)
    finally:
        server.close()
    return time.perf_counter() - t, broken


def _beside(rows: list[dict], before: dict) -> list[dict]:
    """This run's rows by kind with the earlier run's cases and kept (0 where it had no such kind)."""
    old = {r["kind"]: r for r in before["rows"]}
    return [{"kind": r["kind"], "cases before": old.get(r["kind"], {}).get("cases", 0),
             "kept before": old.get(r["kind"], {}).get("kept", 0),
             **{k: v for k, v in r.items() if k != "kind"}} for r in rows]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="run only the cases whose id holds this")
    ap.add_argument("--sample", type=float, default=matrix.SAMPLE, help="share of the cases CI samples")
    ap.add_argument("-v", action="store_true", help="print every broken case as it is found")
    ap.add_argument("--before", type=Path, help="an earlier run's results JSON: its cases and kept by kind "
                                                "go beside this run's (before/after)")
    _results.add_options(ap)
    args = ap.parse_args()
    cases = [c for c in matrix.all_cases() if args.only in c.id]
    with tempfile.TemporaryDirectory() as tmp:
        sampled_s, _ = run(matrix.sample(cases, args.sample), Path(tmp) / "sample", False)
        full_s, broken = run(cases, Path(tmp) / "full", args.v)
    total: Counter[str] = Counter(c.kind for c in cases)
    kept: Counter[str] = Counter(c.kind for c in cases if not broken[c.id])
    rows = [{"kind": k, "cases": total[k], "kept": kept[k], "broken": total[k] - kept[k]}
            for k in sorted(total)]
    rows.append({"kind": "all", "cases": len(cases), "kept": sum(kept.values()),
                 "broken": len(cases) - sum(kept.values())})
    if args.before:
        rows = _beside(rows, json.loads(args.before.read_text()))
    table = [{"command": c, "parameter": p, "kind": k, "values": n} for c, p, k, n in matrix.table()]
    sampled = len(matrix.sample(cases, args.sample))
    extra = {"runs": len(cases), "full_seconds": full_s, "sampled_runs": sampled,
             "sampled_seconds": sampled_s, "sample_seed": matrix.SEED, "matrix": table,
             "broken": {i: b for i, b in broken.items() if b}}
    _results.save(args, "The hostile matrix: every command's parameters x hostile values, kept by kind",
                  {"what": "the CI sample (fixtures, server and cases)", "value": sampled_s, "unit": "s"},
                  rows, extra)
    print(f"{len(cases)} runs in {full_s:.0f} s; sample of {extra['sampled_runs']} in {sampled_s:.0f} s")
    for row in rows:
        print(" ".join(f"{v:>12}" for v in row.values()))


if __name__ == "__main__":
    main()
