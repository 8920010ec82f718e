"""`Oddity`: one thing an imported store's data shows that is recorded rather than refused (z not
increasing, an empty mask) or a bad source left out of an import (problem "skipped"); the store's
`oddities` attribute holds them."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError

SKIPPED = "skipped"  # the problem of an oddity left out of the store (a bad frame, file or folder)


@dataclass(frozen=True)
class Oddity:
    """The `problem` (the key "kind" in the store's JSON), the `subject` it concerns (an example
    id, a file, a CSV line) and a one-line `detail`."""

    problem: str
    subject: str
    detail: str

    def __post_init__(self) -> None:
        for name, value in (("kind", self.problem), ("subject", self.subject), ("detail", self.detail)):
            if not isinstance(value, str):
                raise InputError(f"oddity {name} {value!r} is not a string")

    def to_json(self) -> dict[str, str]:
        return {"example": self.subject, "kind": self.problem, "detail": self.detail}

    @classmethod
    def from_json(cls, d: dict[str, str]) -> Oddity:
        return cls(problem=d["kind"], subject=d["example"], detail=d["detail"])


def skipped_details(oddities: list[Oddity]) -> list[str]:
    """The details of the oddities whose problem is "skipped", in order."""
    return [o.detail for o in oddities if o.problem == SKIPPED]
