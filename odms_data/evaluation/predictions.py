"""Predictions files (schemas/PREDICTIONS.md): reading with strict checks, and writing.

A predictions file is UTF-8 CSV with the header `split,example_id,d1` and one row per example.
`read_predictions` checks the file's form (encoding, delimiter, header, fields, numbers) as it
reads it, line by line: binary content, an overlong line or more rows than the ground truth has
examples stop it at once, so memory follows the examples scored, never the file's size.
`check_against` checks its rows against the ground truth (splits, ids, duplicates, coverage).
Every problem is one InputError line naming the file, the first offending lines or ids and
how many there are.
"""

from __future__ import annotations

import codecs
import csv
import difflib
import hashlib
import io
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..inputs import open_input
from ..outputs import atomic_file

COLUMNS = ("split", "example_id", "d1")
HEADER = ",".join(COLUMNS)
SHOW = 3  # offending rows or ids named in a message
MAX_LINE = 4096  # characters in a line: a longer one is not a predictions row
BLOCK = 1 << 20  # characters read at a time
OTHER_DELIMITERS = {";": "';'", "\t": "a tab", "|": "'|'"}
BOMS = {
    codecs.BOM_UTF32_LE: "UTF-32", codecs.BOM_UTF32_BE: "UTF-32",
    codecs.BOM_UTF8: "UTF-8 with a byte-order mark",
    codecs.BOM_UTF16_LE: "UTF-16", codecs.BOM_UTF16_BE: "UTF-16",
}
_NOT_UTF8 = re.compile("[\udc80-\udcff]")  # the bytes 'surrogateescape' could not decode


@dataclass
class Predictions:
    """The rows of a predictions file; `line` is each row's line number in the file."""

    path: str
    frame: pd.DataFrame  # columns split (str), example_id (str), d1 (float64), line (int)
    sha256: str = ""  # of the file's bytes

    def __len__(self) -> int:
        return len(self.frame)


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
    hints = "; ".join(_header_hints(fields))
    raise InputError(f"{path}: header {first.strip()!r} is not '{HEADER}': {hints}")


def _header_hints(fields: list[str]) -> list[str]:
    """What is wrong with each column of a header that is not HEADER."""
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
    return hints


class _Hashed(io.RawIOBase):
    """A binary file read through, hashing what is read."""

    def __init__(self, raw: io.RawIOBase) -> None:
        self.raw, self.sha = raw, hashlib.sha256()

    def readable(self) -> bool:
        return True

    def readinto(self, b) -> int:
        n = self.raw.readinto(b) or 0
        self.sha.update(memoryview(b)[:n])
        return n

    def close(self) -> None:
        self.raw.close()
        super().close()


def _open(path: str) -> tuple[io.BufferedReader, _Hashed]:
    hashed = _Hashed(open_input(path, "a predictions file"))
    return io.BufferedReader(hashed), hashed


def _blocks(path: str, binary: io.BufferedReader) -> Iterator[tuple[int, list[str]]]:
    """(number of the first line, whole lines without their line ends) of the file as UTF-8 text,
    a block at a time, each checked as it comes: the encoding, NUL bytes and the line length."""
    head = binary.peek(4)[:4]
    for bom, name in BOMS.items():
        if head.startswith(bom):
            raise InputError(f"{path}: the file is encoded as {name}; save it as plain UTF-8 (no BOM)")
    text = io.TextIOWrapper(binary, encoding="utf-8", errors="surrogateescape", newline=None)
    number, tail = 1, ""
    while True:
        chunk = text.read(BLOCK)
        if chunk:
            lines = (tail + chunk).split("\n")
            tail = lines.pop()
        else:  # the end: a last line without its line end (a final line end makes no row)
            lines, tail = [tail] if tail else [], ""
        block = "\n".join(lines)
        if "\0" in block or "\0" in tail:
            raise InputError(f"{path}: the file holds NUL bytes (UTF-16 or binary?); save it as plain UTF-8")
        bad = None if block.isascii() else _NOT_UTF8.search(block)
        if bad:
            raise InputError(f"{path}: line {number + block.count(chr(10), 0, bad.start())} is not valid "
                             f"UTF-8 (byte 0x{ord(bad.group()) - 0xDC00:02x}); save the file as UTF-8")
        longest = max(map(len, lines), default=0)
        if longest > MAX_LINE or len(tail) > MAX_LINE:
            at = number + next((i for i, x in enumerate(lines) if len(x) > MAX_LINE), len(lines))
            raise InputError(f"{path}: line {at} is longer than {MAX_LINE} characters; a predictions "
                             f"file has short rows '{HEADER}'")
        if lines:
            yield number, lines
        number += len(lines)
        if not chunk:
            return


def _field_count_error(path: str, line: int, fields: int) -> InputError:
    hint = " (a decimal comma? d1 must use '.')" if fields == 4 else ""
    return InputError(f"{path}: line {line} has {fields} fields, expected 3{hint}")


def _parse(path: str, first: int, lines: list[str]) -> list[list[str]]:
    """The CSV rows of `lines`, one per line (a blank line: no fields); InputError for a row that
    is not CSV, spans lines (an unclosed quote) or has another number of fields than 3."""
    reader = csv.reader(lines, skipinitialspace=True)
    try:
        rows = list(reader)
    except csv.Error:
        rows = []
    if len(rows) != len(lines) or reader.line_num != len(lines):  # find the culprit, row by row
        reader = csv.reader(iter(lines), skipinitialspace=True)
        for i in range(len(lines)):
            try:
                next(reader)
            except csv.Error as e:
                raise InputError(f"{path}: line {first + i} is not a readable CSV row ({e})") from None
            if reader.line_num > i + 1:
                raise InputError(f"{path}: a quoted field runs from line {first + i} to line "
                                 f"{first + reader.line_num - 1}; is a quote not closed?")
    for i, fields in enumerate(rows):
        if len(fields) != 3 and any(f.strip() for f in fields):
            raise _field_count_error(path, first + i, len(fields))
    if any(" " in line or "\t" in line for line in lines):  # spaces around a field are ignored
        rows = [[f.strip() for f in fields] for fields in rows]
    return rows


def read_predictions(path: str | Path, max_rows: int | None = None) -> Predictions:
    """Read and check the form of a predictions file; raises InputError on the first problem.

    `max_rows` (the number of examples in the ground truth) stops the reading as soon as the file
    has more rows than that.
    """
    path = str(path)
    binary, hashed = _open(path)
    with binary:
        rows = _read_rows(path, binary, max_rows)
    frame = _frame(rows)
    frame["d1"] = _check_cells(path, frame)
    frame = frame.astype({"split": str, "example_id": str})
    return Predictions(path, frame[["split", "example_id", "d1", "line"]].reset_index(drop=True),
                       hashed.sha.hexdigest())


def _frame(rows: list[list[str]]) -> pd.DataFrame:
    """The rows as text columns with their line numbers (the header is line 1)."""
    rows = [r if len(r) == 3 else ["", "", ""] for r in rows]  # the others are blank (see _parse)
    frame = pd.DataFrame(rows, columns=list(COLUMNS), dtype=object)
    frame["line"] = np.arange(2, len(frame) + 2)
    return frame


def _read_rows(path: str, binary: io.BufferedReader, max_rows: int | None) -> list[list[str]]:
    """The rows after the checked header, each a list of fields."""
    rows: list[list[str]] = []
    header = None
    for first, lines in _blocks(path, binary):
        if header is None:
            k = next((i for i, line in enumerate(lines) if line.strip()), None)
            if k is None:
                continue
            if first + k > 1:
                raise InputError(f"{path}: line 1 is blank; the first line must be the header '{HEADER}'")
            header = lines[k]
            _check_header(path, header)
            first, lines = first + k + 1, lines[k + 1 :]
        rows += _parse(path, first, lines)
        if max_rows is not None and len(rows) > max_rows:
            _check_duplicates(path, _frame(rows))  # one row too many is most often a repeated one
            raise InputError(
                f"{path}: has more than {max_rows} rows, but the ground-truth stores hold {max_rows} "
                "examples in all (one row each); are they the right stores?"
            )
    if header is None:
        raise InputError(f"{path}: the file is empty; it needs the header '{HEADER}' and one row per example")
    return rows


def _check_cells(path: str, frame: pd.DataFrame) -> np.ndarray:
    """The d1 column as numbers, after checking that no row is blank and every cell is given."""
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
    non_numeric = np.isnan(d1)
    for i in np.flatnonzero(non_numeric):  # 'nan' is a number, though not a finite one
        non_numeric[i] = frame["d1"].iat[i].lower().lstrip("+-") != "nan"
    if non_numeric.any():
        raise InputError(f"{path}: d1 is not a number in {_lines(frame, non_numeric, 'd1')}")
    not_finite = ~np.isfinite(d1)
    if not_finite.any():
        raise InputError(f"{path}: d1 is NaN or infinite in {_lines(frame, not_finite, 'd1')}")
    return d1


def _check_duplicates(path: str, f: pd.DataFrame) -> None:
    """InputError naming the lines of rows that repeat a (split, example_id) pair."""
    given = f[f["example_id"] != ""]
    dup = given.duplicated(["split", "example_id"], keep=False).to_numpy()
    if dup.any():
        ids = list(dict.fromkeys(given["example_id"][dup]))
        lines = given[dup].groupby("example_id", sort=False)["line"].apply(list)
        shown = [f"{i!r} (lines {', '.join(map(str, lines[i][:SHOW]))})" for i in ids[:SHOW]]
        raise InputError(
            f"{path}: {len(ids)} example id(s) appear more than once: {_listing(shown, len(ids))}"
        )


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
    _check_duplicates(path, f)
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
                f"(first: {_listing(absent)})", fix="allow-partial"
            )
    return missing


def write_predictions(
    path: str | Path, rows: Iterable[tuple[str, str, float]] | pd.DataFrame, *, overwrite: bool = False
) -> int:
    """Write `(split, example_id, d1)` rows as every output is written (outputs.atomic_file);
    floats round-trip exactly. Returns the row count."""
    frame = predictions_table(path, rows)
    with atomic_file(path, overwrite=overwrite, option="output") as partial:
        frame.to_csv(partial, index=False, lineterminator="\n")
    return len(frame)


def predictions_table(
    path: str | Path, rows: Iterable[tuple[str, str, float]] | pd.DataFrame
) -> pd.DataFrame:
    """The rows as a predictions file's table, refused (naming `path`, where they were to go) when a
    d1 is NaN or infinite; its `to_csv(index=False)` is the file, floats round-tripping exactly."""
    frame = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(list(rows), columns=list(COLUMNS))
    frame = frame[list(COLUMNS)]
    bad = ~np.isfinite(frame["d1"].to_numpy(np.float64))
    if bad.any():
        first = frame[bad].iloc[0]
        raise InputError(f"{int(bad.sum())} prediction(s) are NaN or infinite, first for "
                         f"{first['example_id']} of split {first['split']}; nothing was written to {path}")
    return frame

