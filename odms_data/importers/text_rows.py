"""Text files from strangers read row by row: each line's length and the count of lines bounded
before either is held, and numbers that must be finite, each refusal one line naming the file and
row (pose files, MOTChallenge and YOLO files, positions CSVs)."""

from __future__ import annotations

import io
import math
from collections.abc import Iterator
from pathlib import Path

from ..errors import InputError
from ..inputs import open_input


def text_rows(path: Path, max_chars: int, max_lines: int, row: str = "a row") -> Iterator[tuple[int, str]]:
    """The file's data lines (not blank, not # comments), stripped, with their line numbers;
    InputError for a line longer than `max_chars` (`row` names what a line holds) or more than
    `max_lines` lines."""
    try:
        with io.TextIOWrapper(open_input(path, "a text file"), encoding="utf-8") as f:
            for i in range(1, max_lines + 2):
                line = f.readline(max_chars + 1)
                if not line:
                    return
                if i > max_lines:
                    raise InputError(f"{path}: more than {max_lines} lines")
                if len(line) > max_chars:
                    raise InputError(f"{path} line {i}: longer than {row} can be ({max_chars} characters)")
                line = line.strip()
                if line and not line.startswith("#"):
                    yield i, line
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not a text file (a byte at {e.start} of a line is not UTF-8)") from None


def number(text: str, subject: str) -> float:
    """The finite number `text`; InputError '<subject> '<text>' is not a (finite) number'."""
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{subject} '{text[:40]}' is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{subject} '{text[:40]}' is not a finite number")
    return value
