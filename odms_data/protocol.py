"""The ODMS benchmark's facts, written once: its domains and splits, their sizes, the units the
paper reports, the robot protocol and the rule that picks evenly spaced observations.

Sources: Griffin & Corso, ECCV 2020 (the benchmark and its appendix tables) and the released
data (../shared/data/README.md describes its layout).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .errors import InputError

OFFICIAL_DOMAINS = ("robot", "driving", "normal", "perturb")
FAMILIES = ("val", "test")
OFFICIAL_SPLITS = tuple(f"{d}-{f}" for f in FAMILIES for d in OFFICIAL_DOMAINS)
OFFICIAL_COUNTS = {
    "robot-val": 1760, "driving-val": 500, "normal-val": 2000, "perturb-val": 2000,
    "robot-test": 2640, "driving-test": 750, "normal-test": 3000, "perturb-test": 3000,
}
ABS_UNITS = {"robot": "cm", "driving": "m", "normal": "cm", "perturb": "cm"}  # as the paper prints them

ROBOT_FRAMES = 30  # frames of one robot approach, 2 cm apart
ROBOT_WINDOWS = (10, 15, 20, 25, 30)  # camera movement windows of the robot protocol, in frames
ROBOT_N_OBS = 10  # observations per robot example


def official_name(split: str, domain: str) -> tuple[str, str] | None:
    """(domain, family) when `split` is one of the eight official splits and holds that domain."""
    d, _, fam = split.partition("-")
    return (d, fam) if d in OFFICIAL_DOMAINS and fam in FAMILIES and d == domain else None


def split_order(split: str) -> tuple:
    """Official splits first (val before test, then robot, driving, normal, perturb), then by name."""
    d, _, fam = split.partition("-")
    if d in OFFICIAL_DOMAINS and fam in FAMILIES:
        return (0, FAMILIES.index(fam), OFFICIAL_DOMAINS.index(d), "")
    return (1, 0, 0, split)


def evenly_spaced(first: int, last: int, count: int) -> np.ndarray:
    """`count` indices from `first` to `last`, both included: `numpy.linspace` truncated to
    integers. The robot protocol, VOS-DE and the network inputs all choose observations so."""
    return np.linspace(first, last, count).astype(np.int64)


def observation_indices(n: int, n_obs: int) -> np.ndarray:
    """Indices of `n_obs` evenly spaced observations out of `n`, first and last included."""
    if not 2 <= n_obs <= n:
        raise InputError(f"need 2 <= n_obs <= n, got n_obs={n_obs} for an example of {n} frames")
    return evenly_spaced(0, n - 1, n_obs)


def protocol_windows(n_frames: int, lengths: Iterable[int], n_obs: int) -> list[tuple[int, int, np.ndarray]]:
    """(length, start, frame offsets) of every window of the robot protocol over n_frames frames:
    each window of `length` consecutive frames contributes n_obs evenly spaced frames."""
    return [(w, s, evenly_spaced(s, s + w - 1, n_obs)) for w in lengths for s in range(n_frames - w + 1)]
