"""The interrupt promises under load: the 8 cases of tests/cli/test_interrupt.py (SIGINT and SIGTERM
to the process group of a real `generate` with 2 workers, at 4 moments), run in loops outside
pytest with --busy processes spinning beside them.

Run by hand: `python benchmarks/interrupt_loops.py [--rounds 25] [--busy 3] [--base main --base-rounds 3]`.
Each round runs the 8 cases once with this checkout; a case passes when the test's own assertions
hold (one line, exit code 128 + the signal, nothing left in the output's folder). The baseline is
the same loops with the code of --base (git archive of it), --base-rounds rounds of them, in the
same run. Failures are counted per case and their first lines kept; written to
benchmarks/results/interrupt_loops.json (_results.py). Not a speed figure: a timing-sensitive
promise checked many times with the CPUs contended.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests" / "cli"))
import _results  # noqa: E402
import test_interrupt  # noqa: E402  # the cases themselves, run as they are

MOMENTS = ["store begun", "fork server starts", "kernels load", "mid-run"]
SIGNALS = [signal.SIGINT, signal.SIGTERM]
SPIN = "while True: pass"


def base_source(base: str, into: Path) -> str:
    """The package and its data files at commit `base`, unpacked into `into`; its full hash."""
    commit = subprocess.run(["git", "rev-parse", base], cwd=ROOT, check=True, capture_output=True,
                            text=True).stdout.strip()
    archive = subprocess.run(["git", "archive", commit, "odms_data", "schemas", "splits", "leaderboard",
                              "setup.cfg"], cwd=ROOT, check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return commit


def run_case(moment: str, signum: signal.Signals, src: Path) -> str | None:
    """None if the case passes with the code at `src`, else the first line of why not."""
    os.environ["PYTHONPATH"] = str(src)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            test_interrupt.test_stop_signal_prints_one_line(Path(tmp), moment, signum)
        except (AssertionError, subprocess.TimeoutExpired) as e:
            return (str(e).strip().splitlines() or [type(e).__name__])[0][:300]
    return None


def loops(src: Path, rounds: int) -> dict[str, dict]:
    """Per case: runs, failures and the first failures' reasons."""
    out: dict[str, dict] = {}
    for r in range(rounds):
        for moment in MOMENTS:
            for signum in SIGNALS:
                case = out.setdefault(f"{moment} {signum.name}", {"runs": 0, "failures": 0, "why": []})
                why = run_case(moment, signum, src)
                case["runs"] += 1
                if why is not None:
                    case["failures"] += 1
                    case["why"] = (case["why"] + [why])[:3]
        done = sum(c["runs"] for c in out.values())
        failed = sum(c["failures"] for c in out.values())
        print(f"{src}: round {r + 1}/{rounds}: {done} runs, {failed} failures", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=25, help="rounds of the 8 cases with this checkout")
    ap.add_argument("--busy", type=int, default=3, help="processes spinning beside the cases")
    ap.add_argument("--base", default="main")
    ap.add_argument("--base-rounds", type=int, default=3)
    _results.add_options(ap)
    args = ap.parse_args()

    busy = [subprocess.Popen([sys.executable, "-c", SPIN]) for _ in range(args.busy)]
    started = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            base_commit = base_source(args.base, Path(tmp))
            base = loops(Path(tmp), args.base_rounds) if args.base_rounds else {}
            new = loops(ROOT, args.rounds)
    finally:
        for p in busy:
            p.kill()
            p.wait()
    rows = [{"case": case, "runs": c["runs"], "failures": c["failures"],
             "base_runs": base.get(case, {}).get("runs", 0),
             "base_failures": base.get(case, {}).get("failures", 0),
             "first_failures": "; ".join(c["why"])} for case, c in new.items()]
    total = sum(r["runs"] for r in rows)
    failures = sum(r["failures"] for r in rows)
    print(f"{total} loaded runs, {failures} failures")
    _results.save(args, f"Interrupt promises under load: {total} runs of the 8 stop cases beside "
                  f"{args.busy} busy processes",
                  {"what": f"failures of the code at {args.base} ({base_commit[:12]}) in "
                           f"{sum(r['base_runs'] for r in rows)} runs of the same loops",
                   "value": sum(r["base_failures"] for r in rows), "unit": "failures"},
                  rows, {"base_commit": base_commit, "runs": total, "failures": failures,
                         "busy": args.busy, "seconds": round(time.perf_counter() - started)})


if __name__ == "__main__":
    main()
