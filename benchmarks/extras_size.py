"""What the install and each extra weigh on disk, as installed in this environment.

    python benchmarks/extras_size.py

The baseline is `pip install .`: the installed files (each distribution's RECORD) of odms-data's
requirements and theirs, all the way down. An extra's row counts what it adds to that: the
distributions its requirements bring that the base install does not. Sizes are those of the builds
installed here (PyTorch's CPU or CUDA build: the row names the version, `+cpu` for the CPU build).
"""

from __future__ import annotations

import argparse
import sys
from importlib import metadata
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

PROJECT = "odms-data"


def installed() -> dict[str, metadata.Distribution]:
    return {canonicalize_name(d.metadata["Name"]): d for d in metadata.distributions()}


def closure(requirements: list[Requirement], dists: dict[str, metadata.Distribution]) -> set[str]:
    """The installed distributions `requirements` need, and theirs, without extras' optional ones."""
    seen: set[str] = set()
    todo = list(requirements)
    while todo:
        r = todo.pop()
        name = canonicalize_name(r.name)
        if name in seen or name not in dists:
            continue
        seen.add(name)
        for spec in dists[name].requires or []:
            sub = Requirement(spec)
            if sub.marker is None or sub.marker.evaluate({"extra": ""}) or any(
                    sub.marker.evaluate({"extra": e}) for e in r.extras):
                todo.append(sub)
    return seen


def size(dist: metadata.Distribution) -> int:
    total = 0
    for f in dist.files or []:
        path = Path(str(dist.locate_file(f)))
        if path.is_file():
            total += path.stat().st_size
    return total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    _results.add_options(ap)
    a = ap.parse_args()
    dists = installed()
    project = dists[canonicalize_name(PROJECT)]
    specs = [Requirement(s) for s in project.requires or []]
    base_reqs = [r for r in specs if r.marker is None]
    base = closure(base_reqs, dists)
    base_mb = sum(size(dists[n]) for n in base) / 1e6
    print(f"pip install . : {len(base)} distributions, {base_mb:.0f} MB")
    rows = []
    for extra in project.metadata.get_all("Provides-Extra") or []:
        reqs = [r for r in specs if r.marker is not None and r.marker.evaluate({"extra": extra})]
        missing = [r.name for r in reqs if canonicalize_name(r.name) not in dists]
        added = closure(reqs, dists) - base
        mb = sum(size(dists[n]) for n in added) / 1e6
        biggest = sorted(added, key=lambda n: -size(dists[n]))[:3]
        named = ", ".join(f"{dists[n].metadata['Name']} {dists[n].version} ({size(dists[n]) / 1e6:.0f} MB)"
                          for n in biggest)
        print(f"[{extra}]: +{mb:.0f} MB, {len(added)} distributions; largest: {named}"
              + (f"; not installed here: {', '.join(missing)}" if missing else ""))
        rows.append({"extra": extra, "adds MB": mb, "distributions": len(added), "largest": named,
                     "not installed here": ", ".join(missing)})
    _results.save(a, "Install size: `pip install .` and what each extra adds (installed files)",
                  {"what": "pip install . (its requirements and theirs)", "value": base_mb, "unit": "MB"},
                  rows)


if __name__ == "__main__":
    main()
