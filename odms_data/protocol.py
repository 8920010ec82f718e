"""The benchmarks' facts, written once: each benchmark (ODMS, ODMS-detection, ODMD) is one
`Benchmark` record in BENCHMARKS holding its sets, their sizes, the units its paper prints, how
its All is formed, its published baselines and the bin edges of its breakdowns; also the robot
protocol and the rule that picks evenly spaced observations. Every other module reads these.

Sources: Griffin & Corso, ECCV 2020 (ODMS and its appendix tables), Griffin & Corso, CVPR 2021
(ODMD, and its conversion of the ODMS sets) and the released data (../shared/data/README.md).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError

GENERATED = "generated"  # the domain of a generated store
SPLIT_FAMILIES = ("val", "test")  # every benchmark's two families of sets, in this order
ALL_RULE = "the unweighted mean of the per-set means"  # how every benchmark forms its All


@dataclass(frozen=True)
class Benchmark:
    """One benchmark's facts. A set (domain) of family f is the split `split(domain, f)`;
    `counts` holds every split's examples, `units` the unit the paper prints each set's
    absolute error in, `all_sets` the sets whose per-set means make All (ALL_RULE), `store_domain`
    the domain its stores record (None: the set's own name). `depth_bins` and `motion_bins` are
    each set's breakdown edges in metres (true d1; the camera's travel over an example)."""

    key: str
    title: str
    domains: tuple[str, ...]
    counts: dict[str, int]
    units: dict[str, str]
    baselines: tuple[str, ...]  # the published baselines' names, as the papers print them
    prefix: str  # split names: <prefix><domain, "_" written "-">-<family>
    decimals: int  # as the benchmark's papers print percent errors
    depth_bins: dict[str, tuple[float, ...]]
    motion_bins: dict[str, tuple[float, ...]]
    sequence_patterns: dict[str, str] = field(default_factory=dict)  # set -> regex over a source
    object_patterns: dict[str, str] = field(default_factory=dict)  # set -> regex over a source
    store_domain: str | None = None

    @property
    def all_sets(self) -> tuple[str, ...]:
        return self.domains

    def split(self, domain: str, family: str) -> str:
        return f"{self.prefix}{domain.replace('_', '-')}-{family}"

    def splits(self, family: str | None = None) -> tuple[str, ...]:
        """Its splits (of `family`, else of both), families in SPLIT_FAMILIES' order, sets in its own."""
        fams = SPLIT_FAMILIES if family is None else (family,)
        return tuple(self.split(d, f) for f in fams for d in self.domains)

    def split_of(self, split: str, domain: str) -> tuple[str, str] | None:
        """(set, family) when `split` is one of its splits and its store records `domain`
        (a generated store named robot-val is not ODMS's robot-val)."""
        name, _, fam = split.rpartition("-")
        d = name.removeprefix(self.prefix).replace("-", "_")
        if not name.startswith(self.prefix) or d not in self.domains or fam not in SPLIT_FAMILIES:
            return None
        return (d, fam) if domain == (self.store_domain or d) else None

    def all_of(self, means: dict[str, float]) -> float | None:
        """All from {set: mean} (ALL_RULE); None unless every set of all_sets is there."""
        if not all(d in means for d in self.all_sets):
            return None
        return float(np.mean([means[d] for d in self.all_sets]))


_ODMS_DOMAINS = ("robot", "driving", "normal", "perturb")
_ODMS_COUNTS = {"robot": (1760, 2640), "driving": (500, 750), "normal": (2000, 3000), "perturb": (2000, 3000)}
_ODMS_UNITS = {"robot": "cm", "driving": "m", "normal": "cm", "perturb": "cm"}
# Breakdown edges (m), to cover each set's range: the robot test set's d1 spans 0.11-0.6 m and its
# windows travel 0.18-0.58 m (9-29 steps of 2 cm); driving 1.8-62 m, travelling 4-68 m; the
# simulated sets 0.1-0.6 m, travelling 0.1-0.6 m; ODMD's sets 0.17-1.6 m, travelling 0.05-0.48 m.
_DEPTH_BINS: dict[str, tuple[float, ...]] = {
    "robot": (0.0, 0.15, 0.2, 0.3, 0.4, np.inf), "driving": (0.0, 5.0, 10.0, 20.0, 30.0, np.inf),
    "normal": (0.0, 0.2, 0.3, 0.4, 0.5, np.inf), "perturb": (0.0, 0.2, 0.3, 0.4, 0.5, np.inf),
}
_MOTION_BINS: dict[str, tuple[float, ...]] = {
    "robot": (0.0, 0.25, 0.35, 0.45, 0.55, np.inf), "driving": (0.0, 10.0, 15.0, 20.0, 30.0, np.inf),
    "normal": (0.0, 0.15, 0.2, 0.3, 0.4, np.inf), "perturb": (0.0, 0.15, 0.2, 0.3, 0.4, np.inf),
}
# What of an example's recorded source names its sequence and its object (a regex's match; the
# whole source where a set has none): a robot approach is its folder, test/robot/banana_0, whose
# object is banana; a driving example's SYNTHIA sequence is its folder's name up to the first "_"
# (test/driving/SYNTHIA-SEQS-01-DAWN_309_10_3). Simulated examples have a source of their own.
_SEQUENCES: dict[str, str] = {"driving": r"^.*/[^_/]*"}
_OBJECTS: dict[str, str] = {"robot": r"[^/]*(?=_[^_/]*$)"}
_ODMD_DOMAINS = ("normal", "perturb_motion", "perturb_detection", "robot")
_ODMD_DEPTH: tuple[float, ...] = (0.0, 0.5, 0.7, 0.9, 1.1, np.inf)
_ODMD_MOTION: tuple[float, ...] = (0.0, 0.15, 0.25, 0.35, np.inf)


def _counts(prefix: str, counts: dict[str, tuple[int, int]]) -> dict[str, int]:
    return {f"{prefix}{d.replace('_', '-')}-{f}": c[i] for i, f in enumerate(SPLIT_FAMILIES)
            for d, c in counts.items()}


BENCHMARKS: dict[str, Benchmark] = {
    "odms": Benchmark(
        "odms", "ODMS", _ODMS_DOMAINS, _counts("", _ODMS_COUNTS), _ODMS_UNITS, ("VOS-DE",), "", 1,
        _DEPTH_BINS, _MOTION_BINS, _SEQUENCES, _OBJECTS),
    "odms-detection": Benchmark(
        "odms-detection", "ODMS-detection", _ODMS_DOMAINS, _counts("odms-detect-", _ODMS_COUNTS), _ODMS_UNITS,
        ("Box_LS", "DBox"), "odms-detect-", 1, _DEPTH_BINS, _MOTION_BINS),
    "odmd": Benchmark(
        "odmd", "ODMD", _ODMD_DOMAINS, _counts("odmd-", dict.fromkeys(_ODMD_DOMAINS, (2400, 3000))),
        dict.fromkeys(_ODMD_DOMAINS, "cm"), ("Box_LS", "DBox", "DBox_Abs"), "odmd-", 2,
        dict.fromkeys(_ODMD_DOMAINS, _ODMD_DEPTH), dict.fromkeys(_ODMD_DOMAINS, _ODMD_MOTION),
        store_domain="odmd"),
}
ODMS = BENCHMARKS["odms"]
OFFICIAL_DOMAINS = ODMS.domains
OFFICIAL_SPLITS = ODMS.splits()
OFFICIAL_COUNTS = ODMS.counts
ABS_UNITS = ODMS.units  # as the paper prints them

ROBOT_FRAMES = 30  # frames of one robot approach, 2 cm apart
ROBOT_WINDOWS = (10, 15, 20, 25, 30)  # camera movement windows of the robot protocol, in frames
ROBOT_N_OBS = 10  # observations per robot example


def benchmark_of(split: str, domain: str) -> tuple[Benchmark, str, str] | None:
    """(benchmark, set, family) of the benchmark whose split `split` is, its store recording `domain`."""
    for b in BENCHMARKS.values():
        found = b.split_of(split, domain)
        if found:
            return (b, *found)
    return None


def _match(pattern: str | None, source: str) -> str | None:
    found = re.search(pattern, source) if pattern else None
    return found.group(0) if found else None


def sequence_of(split: str, domain: str, source: str) -> str | None:
    """The recorded sequence an example of `split` comes from, by its recorded source: a benchmark
    set's pattern picks it (the whole source where the set has none); a generated example has
    none (None: it stands alone), nor has an example without a source."""
    if domain == GENERATED or not source:
        return None
    found = benchmark_of(split, domain)
    pattern = found[0].sequence_patterns.get(found[1]) if found else None
    return _match(pattern, source) or source if pattern else source


def object_of(split: str, domain: str, source: str) -> str | None:
    """The object an example shows, where its benchmark set's source names one (ODMS's robot sets)."""
    found = benchmark_of(split, domain)
    return _match(found[0].object_patterns.get(found[1]), source) if found else None


def official_name(split: str, domain: str) -> tuple[str, str] | None:
    """(domain, family) when `split` is one of ODMS's eight splits and holds that domain."""
    return ODMS.split_of(split, domain)


def split_order(split: str) -> tuple:
    """Benchmark splits first (ODMS, ODMS-detection, ODMD; val before test; then each benchmark's
    order of sets), then every other split by name."""
    for i, b in enumerate(BENCHMARKS.values()):
        name, _, fam = split.rpartition("-")
        d = name.removeprefix(b.prefix).replace("-", "_")
        if name.startswith(b.prefix) and d in b.domains and fam in SPLIT_FAMILIES:
            return (0, i, SPLIT_FAMILIES.index(fam), b.domains.index(d), "")
    return (1, 0, 0, 0, split)


def evenly_spaced(first: int, last: int, count: int) -> np.ndarray:
    """`count` indices from `first` to `last`, both included: `numpy.linspace` truncated to
    integers. The robot protocol, VOS-DE and the network inputs all choose observations so."""
    return np.linspace(first, last, count).astype(np.int64)


def observation_indices(n: int, n_obs: int) -> np.ndarray:
    """Indices of `n_obs` evenly spaced observations out of `n`, first and last included."""
    if not 2 <= n_obs <= n:
        raise InputError(f"need 2 <= n_obs <= n, got n_obs={n_obs} for an example of {n} frames")
    return evenly_spaced(0, n - 1, n_obs)


MAX_RECORDING_FRAMES = 1_000_000  # frames of one recording an import reads
WHOLE = "all"  # the name of a recording's one example over all its frames


def window_id(split: str, length: int, start: int, digits: int) -> str:
    """The id of a recording's window of `length` frames from frame `start` (frames closest first),
    the start written with at least `digits` digits."""
    return f"{split}/w{length}-{start:0{digits}d}"


def window_of_id(example_id: str, split: str) -> tuple[int, int | None] | None:
    """(start, length) of a recording's example from its id (`window_id`): (0, None) for the one
    example over all frames, whose length its frames give; None for an id of another kind or a
    window reaching past MAX_RECORDING_FRAMES."""
    if example_id == f"{split}/{WHOLE}":
        return 0, None
    m = re.fullmatch(rf"{re.escape(split)}/w([1-9][0-9]{{0,6}})-([0-9]{{1,7}})", example_id)
    if m is None or int(m[1]) + int(m[2]) > MAX_RECORDING_FRAMES:
        return None
    return int(m[2]), int(m[1])


def protocol_windows(n_frames: int, lengths: Iterable[int], n_obs: int) -> list[tuple[int, int, np.ndarray]]:
    """(length, start, frame offsets) of every window of the robot protocol over n_frames frames:
    each window of `length` consecutive frames contributes n_obs evenly spaced frames."""
    return [(w, s, evenly_spaced(s, s + w - 1, n_obs)) for w in lengths for s in range(n_frames - w + 1)]
