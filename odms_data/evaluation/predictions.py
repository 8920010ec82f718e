"""Predictions files (schemas/PREDICTIONS.md): reading with strict checks, and writing.

A predictions file is UTF-8 CSV with the header `split,example_id,d1` and one row per example.
`read_predictions` checks the file's form (encoding, delimiter, header, fields, numbers);
`check_against` checks its rows against the ground truth (splits, ids, duplicates, coverage).
Every problem is one InputError line naming the file, the first offending lines or ids and
how many there are.
"""

from __future__ import annotations

import codecs
import csv
import difflib
import io
import re
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError

COLUMNS = ("split", "example_id", "d1")
HEADER = ",".join(COLUMNS)
SHOW = 3  # offending rows or ids named in a message
OTHER_DELIMITERS = {";": "';'", "\t": "a tab", "|": "'|'"}
BOMS = {
    codecs.BOM_UTF32_LE: "UTF-32", codecs.BOM_UTF32_BE: "UTF-32",
    codecs.BOM_UTF8: "UTF-8 with a byte-order mark",
    codecs.BOM_UTF16_LE: "UTF-16", codecs.BOM_UTF16_BE: "UTF-16",
}


@dataclass
class Predictions:
    """The rows of a predictions file; `line` is each row's line number in the file."""

    path: str
    frame: pd.DataFrame  # columns split (str), example_id (str), d1 (float64), line (int)

    def __len__(self) -> int:
        return len(self.frame)

    @property
    def splits(self) -> list[str]:
        return sorted(self.frame["split"].unique())


def _listing(items: Sequence[str], total: int | None = None) -> str:
    """'a, b, c' (+ 'and N more')."""
    total = len(items) if total is None else total
    shown = ", ".join(items[:SHOW])
    return shown + (f" and {total - SHOW} more" if total > SHOW else "")


def _lines(frame: pd.DataFrame, mask: np.ndarray, what: str = "") -> str:
    """'N rows: line 4 ('x'), line 9 ('y'), ...' for the rows selected by `mask`."""
    bad = frame[mask].head(SHOW)
    shown = [f"line {r.line}" + (f" ({getattr(r, what)!r})" if what else "") for r in bad.itertuples()]
    n = int(mask.sum())
    return f"{n} row{'s' if n != 1 else ''}: {_listing(shown, n)}"


def _decode(path: str, raw: bytes) -> str:
    if not raw.strip():
        raise InputError(f"{path}: the file is empty; it needs the header '{HEADER}' and one row per example")
    for bom, name in BOMS.items():
        if raw.startswith(bom):
            raise InputError(f"{path}: the file is encoded as {name}; save it as plain UTF-8 (no BOM)")
    if b"\0" in raw[:4096]:
        raise InputError(f"{path}: the file holds NUL bytes (UTF-16 or binary?); save it as plain UTF-8")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        raise InputError(
            f"{path}: line {line} is not valid UTF-8 (byte 0x{raw[e.start]:02x}); save the file as UTF-8"
        ) from None


def _looks_like_data(fields: list[str]) -> bool:
    if len(fields) != 3:
        return False
    try:
        float(fields[2])
    except ValueError:
        return False
    return "/" in fields[1]


def _check_header(path: str, first: str) -> None:
    fields = [f.strip().strip('"').strip() for f in first.split(",")]
    if fields == list(COLUMNS):
        return
    if "," not in first:
        for delim, name in OTHER_DELIMITERS.items():
            if delim in first:
                raise InputError(
                    f"{path}: fields are separated by {name}; a predictions file uses commas "
                    f"(header '{HEADER}')"
                )
    if _looks_like_data(fields):
        raise InputError(f"{path}: the header line is missing; the first line must be '{HEADER}'")
    if sorted(fields) == sorted(COLUMNS):
        raise InputError(
            f"{path}: header {first.strip()!r} has the columns in another order; write '{HEADER}'"
        )
    hints = []
    for i, f in enumerate(fields):
        if i < len(COLUMNS) and f == COLUMNS[i]:
            continue
        if f in COLUMNS:
            hints.append(f"column {i + 1} {f!r} is out of place")
            continue
        if i >= len(COLUMNS):
            hints.append(f"extra column {i + 1} {f!r}")
            continue
        close = difflib.get_close_matches(f, COLUMNS, n=1, cutoff=0.5)
        hints.append(f"column {i + 1} {f!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
    if len(fields) < len(COLUMNS):
        hints.append(f"missing {', '.join(repr(c) for c in COLUMNS[len(fields):])}")
    raise InputError(f"{path}: header {first.strip()!r} is not '{HEADER}': {'; '.join(hints)}")


def _field_count_error(path: str, line: int, fields: int) -> None:
    hint = " (a decimal comma? d1 must use '.')" if fields == 4 else ""
    raise InputError(f"{path}: line {line} has {fields} fields, expected 3{hint}") from None


def read_predictions(path: str | Path) -> Predictions:
    """Read and check the form of a predictions file; raises InputError on the first problem."""
    path = str(path)
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise InputError(f"{path}: no such predictions file") from None
    text = _decode(path, raw)
    _check_header(path, text.splitlines()[0])
    try:
        with warnings.catch_warnings():
            # pandas only warns when the first row is longer than the header
            warnings.simplefilter("error", pd.errors.ParserWarning)
            frame = pd.read_csv(
                io.StringIO(text), dtype=str, keep_default_na=False, na_filter=False,
                skip_blank_lines=False, skipinitialspace=True, index_col=False,
            )
    except pd.errors.ParserWarning:
        _field_count_error(path, 2, len(next(csv.reader([text.splitlines()[1]]))))
    except pd.errors.ParserError as e:
        m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(e))
        if not m:
            raise InputError(f"{path}: not a readable CSV file ({' '.join(str(e).split())})") from None
        _field_count_error(path, int(m[2]), int(m[3]))
    frame.columns = list(COLUMNS)
    frame = pd.DataFrame({c: [v.strip() for v in frame[c].tolist()] for c in frame.columns})
    frame["line"] = np.arange(2, len(frame) + 2)
    # a final newline makes no row; blank lines anywhere else are errors
    blank = (frame[list(COLUMNS)] == "").all(axis=1).to_numpy()
    if blank.any():
        raise InputError(f"{path}: blank lines in the file, {_lines(frame, blank)}")
    if len(frame) == 0:
        raise InputError(f"{path}: the file has a header but no rows")
    for col in ("split", "example_id", "d1"):
        empty = (frame[col] == "").to_numpy()
        if empty.any():
            raise InputError(f"{path}: {col} is missing or empty in {_lines(frame, empty)}")
    d1 = pd.to_numeric(frame["d1"], errors="coerce").to_numpy(np.float64)
    literal_nan = frame["d1"].str.lower().str.lstrip("+-").eq("nan").to_numpy()
    non_numeric = np.isnan(d1) & ~literal_nan
    if non_numeric.any():
        raise InputError(f"{path}: d1 is not a number in {_lines(frame, non_numeric, 'd1')}")
    not_finite = ~np.isfinite(d1)
    if not_finite.any():
        raise InputError(f"{path}: d1 is NaN or infinite in {_lines(frame, not_finite, 'd1')}")
    frame["d1"] = d1
    return Predictions(path, frame[["split", "example_id", "d1", "line"]].reset_index(drop=True))


def check_against(
    preds: Predictions, truth_ids: dict[str, list[str]], required: dict[str, list[str]] | None = None,
    *, allow_partial: bool = False,
) -> dict[str, int]:
    """Check the rows against the example ids of each split; returns {split: missing count}.

    `truth_ids` maps every known split to its example ids, `required` to those that must be
    predicted (default: all; scoring requires the labelled ones). Unknown splits, ids that do
    not start with their split, unknown ids and duplicates are always errors; missing required
    examples are errors unless `allow_partial`.
    """
    required = truth_ids if required is None else required
    f, path = preds.frame, preds.path
    known = f["split"].isin(list(truth_ids)).to_numpy()
    if not known.all():
        unknown = sorted(set(f["split"][~known]))
        have = ", ".join(sorted(truth_ids)) or "none"
        raise InputError(
            f"{path}: unknown split{'s' if len(unknown) > 1 else ''} {_listing(unknown)} in "
            f"{_lines(f, ~known, 'split')}; the ground-truth stores hold: {have}"
        )
    pairs = zip(f["split"].tolist(), f["example_id"].tolist(), strict=True)
    prefixed = np.array([e.startswith(s + "/") for s, e in pairs])
    if not prefixed.all():
        raise InputError(
            f"{path}: example_id does not start with '<split>/' in {_lines(f, ~prefixed, 'example_id')}"
        )
    dup = f.duplicated(["split", "example_id"], keep=False).to_numpy()
    if dup.any():
        ids = list(dict.fromkeys(f["example_id"][dup]))
        lines = f[dup].groupby("example_id", sort=False)["line"].apply(list)
        shown = [f"{i!r} (lines {', '.join(map(str, lines[i][:SHOW]))})" for i in ids[:SHOW]]
        raise InputError(
            f"{path}: {len(ids)} example id(s) appear more than once: {_listing(shown, len(ids))}"
        )
    missing = {}
    for split, rows in f.groupby("split", sort=True):
        expected = set(truth_ids[split])
        unknown = ~rows["example_id"].isin(expected).to_numpy()
        if unknown.any():
            raise InputError(
                f"{path}: example ids not in split {split} in {_lines(rows, unknown, 'example_id')}"
            )
        given = set(rows["example_id"].tolist())
        absent = [e for e in required[split] if e not in given]
        missing[split] = len(absent)
        if absent and not allow_partial:
            raise InputError(
                f"{path}: {len(absent)} of {len(required[split])} examples of split {split} have no "
                "prediction "
                f"(first: {_listing(absent)}); pass --allow-partial to score a subset"
            )
    return missing


def write_predictions(
    path: str | Path, rows: Iterable[tuple[str, str, float]] | pd.DataFrame
) -> int:
    """Write `(split, example_id, d1)` rows; floats round-trip exactly. Returns the row count."""
    frame = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(list(rows), columns=list(COLUMNS))
    frame = frame[list(COLUMNS)]
    if not np.isfinite(frame["d1"].to_numpy(np.float64)).all():
        raise InputError(f"{path}: refusing to write NaN or infinite predictions")
    frame.to_csv(path, index=False, lineterminator="\n")
    return len(frame)
