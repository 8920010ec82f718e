"""The hostile matrix (matrix.py): every parameter of every command is classified, so that a new
one is covered the day it is added; a sample of the matrix, drawn with a fixed seed, keeps the
rule (benchmarks/hostile_matrix.py runs it whole)."""

from __future__ import annotations

import click
import pytest
from matrix import BASES, ROLES, Slot, Unclassified, commands, kind_of, slots, values_for


def test_every_parameter_of_every_command_is_classified():
    problems = []
    for slot in slots():
        try:
            assert values_for(slot), slot.key
        except Unclassified as e:
            problems.append(str(e))
    assert problems == []


def test_an_option_the_matrix_cannot_classify_fails():
    for option in (click.Option(["--frobnicate"], type=click.Path()), click.Option(["--colour"]),
                   click.Option(["--when"], type=click.DateTime())):
        with pytest.raises(Unclassified, match="frobnicate|colour|when"):
            kind_of(Slot(("score",), option))


def test_roles_and_bases_name_only_what_exists():
    keys = {slot.key for slot in slots()}
    assert sorted(set(ROLES) - keys) == []
    tree = commands()
    assert sorted(BASES) == sorted(" ".join(path) for path in tree)
    for path, cmd in tree.items():
        names = {p.name for p in cmd.params}
        assert sorted(set(BASES[" ".join(path)][0]) - names) == [], path


def test_every_command_has_its_parameters_in_the_matrix():
    from matrix import all_cases

    ids = [c.id for c in all_cases()]
    assert len(ids) == len(set(ids))
    for slot in slots():
        prefix = f"{' '.join(slot.command)} {slot.flag or slot.param.name}: "
        assert any(i.startswith(prefix) for i in ids), slot.key
