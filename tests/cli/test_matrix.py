"""The hostile matrix (matrix.py): every parameter of every command is classified, so that a new
one is covered the day it is added; a sample of the matrix, drawn with a fixed seed, keeps the
rule (benchmarks/hostile_matrix.py runs it whole)."""

from __future__ import annotations

import json
from pathlib import Path

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


# Cases the whole matrix finds broken on main (benchmarks/hostile_matrix.py), each to be fixed at
# its owner (issue 37 §1), case id -> what it breaks: an expected failure until then, strict, so
# that a fix shows as an unexpected pass, and its entry goes.
KNOWN: dict[str, str] = json.loads((Path(__file__).with_name("matrix_known.json")).read_text())


def test_known_failures_name_cases_of_the_matrix():
    from matrix import all_cases

    assert sorted(set(KNOWN) - {c.id for c in all_cases()}) == []


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    from matrix import Server, prepare

    s = Server(prepare(tmp_path_factory.mktemp("matrix")))
    yield s
    s.close()


def _sampled() -> list:
    from matrix import all_cases, sample

    return [pytest.param(c, id=c.id, marks=[pytest.mark.xfail(strict=True, reason=KNOWN[c.id])]
                         if c.id in KNOWN else []) for c in sample(all_cases())]


@pytest.mark.parametrize("case", _sampled())
def test_a_sampled_case_keeps_the_rule(case, server, tmp_path):
    from matrix import run_case

    broken, r = run_case(case, server, tmp_path)
    assert broken == []
    if case.kind == "base":  # the base works, so a refusal is the hostile value's (ODMD's own sets
        # are checked against their manifests: a small made-up one is refused once read)
        assert r.rc == (2 if case.args[:2] == ("import", "odmd") else 0), r.err
