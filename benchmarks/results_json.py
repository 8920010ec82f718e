"""Writing a benchmark's figures as JSON into benchmarks/results/, with what they were measured on:
the machine (processor, cores, load average before and after), the date and the commit."""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results"


def _commit() -> str:
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=RESULTS.parent,
                             capture_output=True, text=True, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def machine() -> dict[str, Any]:
    return {"processor": platform.processor() or platform.machine(), "cores": os.cpu_count(),
            "system": platform.platform(), "python": platform.python_version(),
            "load_average": round(os.getloadavg()[0], 2)}


def save(name: str, figures: dict[str, Any], before: dict[str, Any]) -> Path:
    """Write `figures` to benchmarks/results/<name>.json with `before` (machine() taken when the
    run started), the machine after, the date and the commit; returns the path."""
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / f"{name}.json"
    record = {"benchmark": name, "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
              "commit": _commit(), "machine": before,
              "load_average_after": round(os.getloadavg()[0], 2), "figures": figures}
    path.write_text(json.dumps(record, indent=2) + "\n")
    return path
