"""Library errors name what is wrong in the library's words; the command line writes the inputs
they name as its flags and adds how its options fix them (cli/fixes.py)."""

from __future__ import annotations

import pytest

from odms_data.cli.fixes import with_fix
from odms_data.errors import InputError, OutputExistsError
from odms_data.importers.synthia_protocol import Selection, parse_classes
from odms_data.outputs import check_replaceable


@pytest.mark.parametrize("refuse, library, command_line", [
    (lambda: Selection(classes=()).check(), "classes: give at least one class",
     "--classes: give at least one class"),
    (lambda: Selection(frames=(1,)).check(), "frames: an example", "--frames: an example"),
    (lambda: Selection(d1=(5.0, 3.0)).check(), "d1 5.0 3.0: expected 0 <= MIN < MAX",
     "--d1-range 5.0 3.0: expected 0 <= MIN < MAX"),
    (lambda: parse_classes("car,lorry"), "classes 'lorry': not a class", "--classes 'lorry': not a class"),
])
def test_an_input_the_library_names_is_written_as_its_flag(refuse, library, command_line):
    with pytest.raises(InputError) as refused:
        refuse()
    assert str(refused.value).startswith(library) and "--" not in str(refused.value)
    assert with_fix(refused.value).startswith(command_line)


def test_an_existing_output_names_the_option_and_its_fix(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("x\n")
    with pytest.raises(OutputExistsError) as refused:
        check_replaceable(path, False, option="output")
    assert str(refused.value) == f"output {path}: already exists"
    assert with_fix(refused.value) == f"-o {path}: already exists; pass --overwrite to replace it"


def test_a_message_that_does_not_start_with_its_input_is_left_as_it_is():
    e = InputError("something else: classes", option="classes")
    assert with_fix(e) == "something else: classes"
