"""The cost of the bounds on untrusted pickles and checkpoints (issue 37), against the old code in
the same run.

Run by hand: `python benchmarks/untrusted_bounds.py [--old 4651d52] [--repeats 5]` (needs
shared/odmd: ODMD's 16 pickled sets and its pretrained DBox).
- `odms-data import odmd` of the 16 sets, and `odms-data predict --model dbox --checkpoint` with the
  pretrained DBox on the imported val_normal store, each in a subprocess with this checkout's code
  and with `--old` (a git revision, extracted with `git archive`), alternating; the median wall and
  CPU time (user + sys) of each.
- In this process: the opcode walk that bounds a pickle (`pickles._bound_structure`) over the 16
  sets, and the checks of the pretrained DBox before torch reads it, against reading them whole.
Writes benchmarks/results/untrusted_bounds.json (_results.py), the --old code's import CPU time as
the baseline.
"""

from __future__ import annotations

import argparse
import io
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from odms_data import pickles

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
import _results  # noqa: E402
from untrusted_checks import children_cpu, old_code  # noqa: E402

SHARED = Path(os.environ.get("ODMS_SHARED", REPO.parent / "shared")) / "odmd"


def timed(code: Path, args: list[str], cwd: Path) -> tuple[float, float]:
    cpu, t = children_cpu(), time.perf_counter()
    subprocess.run([sys.executable, "-m", "odms_data.cli", *args], check=True, cwd=cwd,
                   env={**os.environ, "PYTHONPATH": str(code)}, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - t, children_cpu() - cpu


def in_process() -> dict[str, float]:
    """Seconds of the bounding walk and of the whole read, over the 16 sets and the DBox file."""
    sets = sorted((SHARED / "data").rglob("*.pk"))
    data = [p.read_bytes() for p in sets]
    t = time.process_time()
    for d in data:
        pickles._bound_structure(io.BytesIO(d))
    walk = time.process_time() - t
    t = time.process_time()
    for p in sets:
        pickles.load_pickle(p)
    whole = time.process_time() - t
    dbox = SHARED / "model" / "DBox_pretrained_paper.pt"
    raw = dbox.read_bytes()
    pickles.load_checkpoint(dbox)  # torch imported and warm before either is timed
    t = time.process_time()
    pickles._check_legacy(raw, dbox)
    checks = time.process_time() - t
    t = time.process_time()
    pickles.load_checkpoint(dbox)
    load = time.process_time() - t
    return {"walk_s": walk, "load_pickle_s": whole, "dbox_checks_s": checks, "dbox_load_s": load}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default="4651d52", help="git revision of the old code")
    ap.add_argument("--repeats", type=int, default=5)
    _results.add_options(ap)
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    try:
        old = old_code(a.old, tmp)
        stores = tmp / "stores"
        imp = ["import", "odmd", str(SHARED / "data"), "-o", str(stores), "--overwrite"]
        subprocess.run([sys.executable, "-m", "odms_data.cli", *imp], check=True, capture_output=True)
        store = next(p for p in stores.iterdir() if "val" in p.name and "normal" in p.name)
        dbox = SHARED / "model" / "DBox_pretrained_paper.pt"
        pred = ["predict", "--model", "dbox", "--checkpoint", str(dbox), "--data", str(store),
                "-o", str(tmp / "p.csv"),
                "--overwrite", "--workers", "0"]
        runs: dict[str, dict[str, list[tuple[float, float]]]] = {
            c: {"old": [], "new": []} for c in ("import", "predict")}
        for _ in range(a.repeats):
            for name, code in (("old", old), ("new", REPO)):
                runs["import"][name].append(timed(code, [*imp[:4], str(tmp / f"{name}-stores"),
                                                         "--overwrite"], tmp))
                runs["predict"][name].append(timed(code, pred, tmp))
        med = {c: {n: (statistics.median(w for w, _ in r), statistics.median(u for _, u in r))
                   for n, r in by.items()} for c, by in runs.items()}
        walk = in_process()
        rows = []
        for c, what in (("import", "import odmd, 16 sets"), ("predict", f"predict DBox on {store.name}")):
            (ow, oc), (nw, nc) = med[c]["old"], med[c]["new"]
            rows += [{"measurement": f"{what}, old code, CPU", "seconds": oc, "against": "itself",
                      "ratio": 1.0},
                     {"measurement": f"{what}, this code, CPU", "seconds": nc, "against": "old code",
                      "ratio": nc / oc},
                     {"measurement": f"{what}, old code, wall", "seconds": ow, "against": "itself",
                      "ratio": 1.0},
                     {"measurement": f"{what}, this code, wall", "seconds": nw, "against": "old code",
                      "ratio": nw / ow}]
        rows += [{"measurement": "bounding walk of the 16 sets' opcodes", "seconds": walk["walk_s"],
                  "against": "load_pickle of the 16 sets", "ratio": walk["walk_s"] / walk["load_pickle_s"]},
                 {"measurement": "checks of the pretrained DBox before torch reads it",
                  "seconds": walk["dbox_checks_s"], "against": "load_checkpoint of it",
                  "ratio": walk["dbox_checks_s"] / walk["dbox_load_s"]}]
        for row in rows:
            print(row)
        _results.save(a, "Untrusted pickles and checkpoints: the cost of the bounds against the old code",
                      {"what": f"the code at {a.old} importing ODMD's 16 sets, CPU",
                       "value": med["import"]["old"][1], "unit": "CPU-s"}, rows,
                      {"old_revision": a.old, "repeats": a.repeats, "in_process": walk})
    finally:
        shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
