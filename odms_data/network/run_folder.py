"""The files of a training run (docs/TRAINING.md) and the configuration that names the run.

    RUN/config.json   the TrainConfig, and the software that wrote it
    RUN/last.pt       the latest checkpoint: what a resumed run continues from
    RUN/best.pt       the weights that did best on the validation stores so far
    RUN/best-SPLIT.pt the weights that did best on the validation store of split SPLIT so far
    RUN/curves.csv    one row per training iteration and per validation store and validation
    RUN/curves.png    the curves, drawn when the run completes

Checkpoints, the configuration and the plot are written to a `.partial` sibling, flushed and
renamed into place (outputs.replaced_via_partial), so an interruption or a full disk leaves the
previous complete file and no sibling. A run is written under the lock `RUN.lock`, and a folder is
a run only when its config.json is the one odms-data wrote (`RUN_OUTPUT`): `--overwrite` replaces
nothing else.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import IO, Any, get_type_hints

from .. import safe_json
from .._version import __version__
from ..errors import InputError, OdmsError
from ..inputs import open_input
from ..outputs import OutputType, replaced_via_partial
from ..store.manifests import load_manifest, split_names
from .variants import variant

CONFIG, LAST, BEST, CURVES, PLOT = "config.json", "last.pt", "best.pt", "curves.csv", "curves.png"
CURVE_COLUMNS = ("iteration", "seconds", "set", "loss", "percent_error")
TRAIN, VAL = "train", "val"  # curve sets besides each validation store's split
PER_SET = "per-set"  # predict's checkpoint choice: each set's own best (the authors' protocol)
# sane limits, checked before anything is built: a network of n_obs inputs takes 26 KB per input
# and a batch n_obs x 50 KB per example, so a config.json from a stranger cannot ask for gigabytes
MAX_OBS, MAX_BATCH, MAX_ITERATIONS = 100, 8192, 10**9
MAX_SEED = 2**64 - 1  # torch.manual_seed's largest
AddRow = Callable[[int, float, str, float, float], None]  # (iteration, seconds, set, loss, percent error)


@dataclass(frozen=True)
class TrainConfig:
    """What a run trains, on what, and how: two runs of one config see the same batches.

    `val`: the validation stores (paths; training needs one at least); the best checkpoint is the
    one with the lowest mean of their mean percent errors."""

    model: str = "odn-l"
    radial: bool = False
    n_obs: int = 10
    preset: str = "standard"
    seed: int = 0
    iterations: int = 5000
    batch_size: int = 512
    lr: float = 1e-3
    val_every: int = 10
    val: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        v = variant(self.model)
        problems = [
            f"{name} must be at least {least}, got {getattr(self, name)}"
            for name, least in (("n_obs", 2), ("seed", 0), ("iterations", 1), ("batch_size", 1),
                                ("val_every", 1))
            if getattr(self, name) < least
        ] + [
            f"{name} must be at most {most}, got {getattr(self, name)}"
            for name, most in (("n_obs", MAX_OBS), ("batch_size", MAX_BATCH), ("iterations", MAX_ITERATIONS),
                               ("val_every", MAX_ITERATIONS), ("seed", MAX_SEED))
            if getattr(self, name) > most
        ]
        if self.preset not in v.recipe.presets:
            problems.append(f"preset '{self.preset}' is not one of {self.model}'s stream (choose from "
                            f"{', '.join(v.recipe.presets)})")
        if self.radial and not v.recipe.radial:
            problems.append(f"{self.model} takes no radial image")
        if not 0 < self.lr < math.inf:
            problems.append(f"lr must be a positive finite number, got {self.lr}")
        problems += [f"seed {self.seed} generates split {name} (splits/{name}.json): a stream of it "
                     "would train on evaluation examples; choose another seed"
                     for name in _splits_of_seed(self.seed)]
        if problems:
            raise InputError("training configuration: " + "; ".join(problems))

    @classmethod
    def recipe(cls, model: str, **given: Any) -> TrainConfig:
        """The config of `model` with its authors' recipe (variants.Recipe) where `given` has no
        value (or None)."""
        r = variant(model).recipe
        defaults = {"preset": r.preset, "iterations": r.iterations, "batch_size": r.batch_size, "lr": r.lr,
                    "val_every": r.val_every}
        return cls(model=model, **{**defaults, **{k: v for k, v in given.items() if v is not None}})

    def to_json(self) -> dict[str, Any]:
        return {**asdict(self), "val": list(self.val)}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> TrainConfig:
        """The config a run folder's config.json holds, each value of its field's JSON type (a
        stranger's `n_obs: 2.5` or `val: "v.zarr"` would reach the network or be read as letters)."""
        if not isinstance(d, dict):
            raise InputError(f"training configuration: a JSON object, not {type(d).__name__}")
        hints = get_type_hints(cls)
        return cls(**{f.name: _of_type(f.name, d[f.name], hints[f.name]) for f in fields(cls) if f.name in d})

    def differences(self, other: TrainConfig) -> list[str]:
        mine, theirs = self.to_json(), other.to_json()
        return [f"{k} {theirs[k]!r} here, {mine[k]!r} asked" for k in mine if mine[k] != theirs[k]]


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


_JSON_TYPES: dict[Any, tuple[str, Callable[[Any], bool]]] = {
    bool: ("true or false", lambda v: isinstance(v, bool)),
    int: ("a whole number", lambda v: _is_number(v) and isinstance(v, int)),
    float: ("a number", lambda v: _is_number(v) and math.isfinite(v)),
    str: ("a string", lambda v: isinstance(v, str)),
    tuple[str, ...]: ("a list of strings",
                      lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v)),
}


def _of_type(name: str, value: Any, hint: Any) -> Any:
    """`value` of config field `name` as its type `hint`, or one line saying what it must be."""
    what, fits = _JSON_TYPES[hint]
    if not fits(value):
        raise InputError(f"training configuration: {name} must be {what}, got {repr(value)[:40]}")
    return tuple(value) if hint == tuple[str, ...] else float(value) if hint is float else value


def best_of(split: str) -> str:
    """The file of the best checkpoint on validation split `split` (a store's split name, which
    the format confines to letters, digits and . _ -)."""
    return f"best-{split}.pt"


def domain_of(split: str) -> str:
    """What a val and a test split share: robot-val and robot-test are both robot."""
    name, sep, family = split.rpartition("-")
    return name if sep and family in ("val", "test") else split


def _splits_of_seed(seed: int) -> list[str]:
    manifests = (load_manifest(name) for name in split_names())
    return [m.name for m in manifests if m.generator and m.generator.get("seed") == seed]


# for the lock; RunFolder.check: what may be replaced
RUN_OUTPUT = OutputType("training run", lambda path: None)


class RunFolder:
    """A run's folder; `create` makes or reopens one for a config, `open` reads a finished one."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    def file(self, name: str) -> Path:
        return self.path / name

    def per_set_checkpoint(self, split: str) -> Path:
        """The checkpoint that predicts split `split` under the authors' protocol: the best on the
        validation set of its own domain (robot-val's for robot-test); InputError when the run
        validated on none or on several."""
        sets = sorted(p.name[len("best-"):-len(".pt")] for p in self.path.glob(best_of("*")))
        mine = [s for s in sets if domain_of(s) == domain_of(split)]
        if len(mine) != 1:
            what = "no validation set" if not mine else f"several validation sets ({', '.join(mine)})"
            raise InputError(f"{self.path}: checkpoint {PER_SET} needs the best checkpoint of {split}'s "
                             f"own validation set, and the run has {what} of that domain; its per-set "
                             f"checkpoints: {', '.join(sets) or 'none (train again to write them)'}")
        return self.file(best_of(mine[0]))

    def is_run(self) -> bool:
        """Whether the folder holds a run odms-data wrote: its config.json, a regular file, names
        odms-data and holds a configuration (a web app's config.json is not one)."""
        path = self.file(CONFIG)
        if path.is_symlink() or not path.is_file() or path.stat().st_size > 1 << 20:
            return False
        try:
            d = safe_json.load_file(path)
        except OdmsError:
            return False
        return _holds_run(d)

    def config(self) -> TrainConfig:
        if not self.is_run():
            raise InputError(f"{self.path}: not a training run (no {CONFIG} written by odms-data); "
                             "see `odms-data train`")
        return TrainConfig.from_json(safe_json.load_file(self.file(CONFIG))["config"])

    def check(self, config: TrainConfig, overwrite: bool) -> bool:
        """Whether the folder can hold a run of `config`: True when it holds one to resume
        (InputError when it holds something else); writes nothing."""
        if self.path.exists() and not self.path.is_dir():
            raise InputError(f"{self.path}: exists and is not a folder; give a new folder for the run")
        if self.is_run() and not overwrite:
            diff = config.differences(self.config())
            if diff:
                raise InputError(f"{self.path}: holds a run of another configuration ({'; '.join(diff)})",
                                 fix="overwrite-run")
            return self.file(LAST).is_file()
        if not self.is_run() and self.path.is_dir() and any(self.path.iterdir()):
            raise InputError(f"{self.path}: is not empty and holds no training run; "
                             "give a new or empty folder")
        return False

    def create(self, config: TrainConfig, overwrite: bool) -> bool:
        """Make the run folder for `config` (with `overwrite`, the run's own files there go first;
        anything else in the folder stays), or keep it to resume; True when resuming."""
        if self.check(config, overwrite):
            return True
        self.path.mkdir(parents=True, exist_ok=True)
        for name in (LAST, BEST, CURVES, PLOT):
            self.file(name).unlink(missing_ok=True)
        for path in self.path.glob(best_of("*")):
            path.unlink()
        text = json.dumps({"config": config.to_json(), "odms_data": __version__}, indent=2) + "\n"
        with replaced_via_partial(self.file(CONFIG), check=lambda p: _reads_as(p, config)) as partial:
            partial.write_text(text, encoding="utf-8")
        return False

    @contextmanager
    def curves(self, upto: int) -> Iterator[AddRow]:
        """Yields add(iteration, seconds, set, loss, percent_error) appending to curves.csv, whose
        rows after iteration `upto` (work a resumed run redoes) are dropped first."""
        path = self.file(CURVES)
        kept = [r for r in read_curves(path) if int(r["iteration"]) <= upto] if path.is_file() else []

        with replaced_via_partial(path) as partial, open(partial, "w", newline="", encoding="utf-8") as f:
            out = csv.writer(f, lineterminator="\n")
            out.writerow(CURVE_COLUMNS)
            out.writerows([r[c] for c in CURVE_COLUMNS] for r in kept)
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_NOFOLLOW)  # the file just written
        with open(fd, "a", newline="", encoding="utf-8") as f:
            yield _appender(csv.writer(f, lineterminator="\n"), f)


def _holds_run(d: Any) -> bool:
    """Whether the JSON value of a config.json is a run's: it names odms-data and holds a configuration."""
    return isinstance(d, dict) and isinstance(d.get("odms_data"), str) and isinstance(d.get("config"), dict)


def _reads_as(path: Path, config: TrainConfig) -> None:
    """The commit check of a run's config.json (outputs.Check): its reader's checks, and the config it
    reads back is `config`."""
    name, d = path.name, safe_json.load_file(path)
    if not _holds_run(d):
        raise InputError(f"{name} holds no run configuration")
    if TrainConfig.from_json(d["config"]) != config:
        raise InputError(f"{name} reads back as another configuration")


def _appender(out: Any, f: IO[str]) -> AddRow:
    def add(iteration: int, seconds: float, which: str, loss: float, percent_error: float) -> None:
        out.writerow([iteration, f"{seconds:.3f}", which, f"{loss:.6g}", f"{percent_error:.6g}"])
        f.flush()

    return add


def read_curves(path: Path) -> list[dict[str, str]]:
    with io.TextIOWrapper(io.BufferedReader(open_input(path, "a run's curves.csv")), encoding="utf-8",
                          newline="") as f:
        return list(csv.DictReader(f))
