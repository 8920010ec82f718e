"""More malformed predictions files that users really produce (issue 6's catalogue, together
with test_predictions.BAD): each must be one line naming the file, exit code 2, no traceback.
Plus fuzzing: any bytes either parse into predictions or raise the project's own error."""

from __future__ import annotations

import pytest
from _stores import make_store
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_predictions import BAD

from odms_data.cli import main
from odms_data.errors import OdmsError
from odms_data.evaluation.predictions import HEADER, read_predictions

ROWS = [f"tiny-val,tiny-val/{i:03d},{d}" for i, d in enumerate([0.2, 0.4, 0.5, 0.8, 1.0])]


def csv(*rows: str, header: str = HEADER) -> str:
    return "\n".join([header, *rows]) + "\n"


MORE = {
    "truncated mid-row": (csv(*ROWS)[:-12], "line 6"),
    "swapped columns d1 first": ("d1,example_id,split\n" + "\n".join(
        f"{r.split(',')[2]},{r.split(',')[1]},{r.split(',')[0]}" for r in ROWS), "another order"),
    "upper-case header": (csv(*ROWS, header="Split,Example_ID,D1"), "header"),
    "header twice": (csv(*ROWS[:2], HEADER, *ROWS[2:]), "line 4"),
    "overflowing number 1e400": (csv(*ROWS[:4], "tiny-val,tiny-val/004,1e400"), "line 6"),
    "units after the number": (csv(*ROWS[:4], "tiny-val,tiny-val/004,0.5 m"), "line 6 ('0.5 m')"),
    "percent sign": (csv(*ROWS[:4], "tiny-val,tiny-val/004,50%"), "line 6"),
    "boolean for d1": (csv(*ROWS[:4], "tiny-val,tiny-val/004,true"), "line 6"),
    "quoted empty d1": (csv(*ROWS[:4], 'tiny-val,tiny-val/004,""'), "line 6"),
    "thousands separator": (csv(*ROWS[:4], "tiny-val,tiny-val/004,1,000"), "line 6 has 4 fields"),
    "empty example id": (csv(*ROWS[:4], "tiny-val,,1.0"), "line 6"),
    "empty split": (csv(*ROWS[:4], ",tiny-val/004,1.0"), "line 6"),
    "id from another split": (csv(*ROWS[:4], "tiny-val,more-val/001,1.0"), "line 6"),
    "unterminated quote": (csv(*ROWS[:4], 'tiny-val,"tiny-val/004,1.0'), "p.csv"),
    "NUL byte inside": (csv(*ROWS).replace("0.5", "0\x005"), "NUL"),
    "pipe delimiter": (csv(*ROWS).replace(",", "|"), "separated by '|'"),
    "a PNG file renamed .csv": (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(40), "p.csv"),
    "JSON instead of CSV": ('[{"split": "tiny-val", "example_id": "tiny-val/000", "d1": 0.2}]\n', "p.csv"),
    "only a BOM": (b"\xef\xbb\xbf", "p.csv"),
    "hex number": (csv(*ROWS[:4], "tiny-val,tiny-val/004,0x1"), "line 6"),
    "capitalised NaN": (csv(*ROWS[:4], "tiny-val,tiny-val/004,NaN"), "line 6"),
    "plus infinity": (csv(*ROWS[:4], "tiny-val,tiny-val/004,+inf"), "line 6"),
    "missing one example among many": (csv(*ROWS[1:]), "have no prediction"),
}


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("truth")
    ex = [{"z": [d, d + 0.1], "areas": [100, 64], "d1": d} for d in (0.2, 0.4, 0.5, 0.8, 1.0)]
    make_store(root / "tiny-val.zarr", "tiny-val", ex)
    make_store(root / "more-val.zarr", "more-val", ex[:2])
    return root


def test_catalogue_has_at_least_40_cases():
    assert len(BAD) + len(MORE) >= 40


@pytest.mark.parametrize("case", sorted(MORE))
def test_more_bad_predictions_exit_2_with_one_line(tmp_path, data, case):
    text, expected = MORE[case]
    path = tmp_path / "p.csv"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    r = CliRunner().invoke(main, ["score", str(path), "--data", str(data)])
    assert r.exit_code == 2, (case, r.output)
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("odms-data: error: "), r.stderr
    assert "Traceback" not in r.output
    assert "p.csv" in lines[0] and expected in lines[0], lines[0]


@pytest.mark.parametrize("variant", ["old Mac line endings", "Windows line endings", "quoted numbers"])
def test_harmless_variants_are_read_as_intended(tmp_path, data, variant):
    text = {"old Mac line endings": csv(*ROWS).replace("\n", "\r"),
            "Windows line endings": csv(*ROWS).replace("\n", "\r\n"),
            "quoted numbers": csv(*(f'{r.rsplit(",", 1)[0]},"{r.rsplit(",", 1)[1]}"' for r in ROWS))}[variant]
    path = tmp_path / "p.csv"
    path.write_text(text, newline="")
    r = CliRunner().invoke(main, ["score", str(path), "--data", str(data), "--json"])
    assert r.exit_code == 0, r.output
    assert '"mean_percent_error": 0.0' in r.stdout


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.one_of(
    st.binary(max_size=400),
    st.lists(st.text(alphabet=st.sampled_from(list("ab,;\t\"'\r\n 0123456789.e-+naif/_")), max_size=30),
             max_size=8).map(lambda rows: (HEADER + "\n" + "\n".join(rows)).encode()),
))
def test_any_bytes_parse_or_raise_the_projects_error(tmp_path, data):
    path = tmp_path / "fuzz.csv"
    path.write_bytes(data)
    try:
        preds = read_predictions(path)
    except OdmsError as e:
        assert "\n" not in str(e)
        return
    assert list(preds.frame.columns[:3]) == ["split", "example_id", "d1"]
