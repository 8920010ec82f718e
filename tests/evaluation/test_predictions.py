"""Predictions files through `odms-data score`: every malformed case exits 2 with one line."""

from __future__ import annotations

import codecs
import json

import numpy as np
import pytest
from _stores import make_store
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.evaluation.predictions import HEADER, read_predictions, write_predictions

D1 = [0.2, 0.4, 0.5, 0.8, 1.0]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """A data folder with two stores: tiny-val (5 labelled examples) and more-val (3, one unlabelled)."""
    root = tmp_path_factory.mktemp("truth")
    ex = [{"z": [d, d + 0.1], "areas": [100, 64], "d1": d} for d in D1]
    make_store(root / "tiny-val.zarr", "tiny-val", ex)
    more = [{"z": [1, 2], "areas": [100, 64], "d1": d} for d in (1.0, 2.0, float("nan"))]
    make_store(root / "more-val.zarr", "more-val", more)
    return root


def truth_rows(split="tiny-val", d1=D1):
    return [f"{split},{split}/{i:03d},{d!r}" for i, d in enumerate(d1)]


def run(args, data):
    return CliRunner().invoke(main, [*args, "--data", str(data)])


def write(tmp_path, text: str | bytes, name="p.csv"):
    p = tmp_path / name
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    return p


def score_file(tmp_path, data, text, *extra):
    return run(["score", str(write(tmp_path, text)), *extra], data)


def test_ground_truth_scores_exactly_zero(tmp_path, data):
    r = score_file(tmp_path, data, "\n".join([HEADER, *truth_rows()]) + "\n", "--json")
    assert r.exit_code == 0, r.output
    (s,) = json.loads(r.stdout)["splits"]
    assert (s["mean_percent_error"], s["median_percent_error"], s["mean_abs_error_m"]) == (0.0, 0.0, 0.0)
    assert s["n"] == 5 and not s["partial"]


def test_write_then_read_round_trips_floats_exactly(tmp_path):
    values = [0.1 + 0.2, 1 / 3, 12.345678901234567, -0.0, 5e-324]
    write_predictions(tmp_path / "p.csv", [("s", f"s/{i}", v) for i, v in enumerate(values)])
    back = read_predictions(tmp_path / "p.csv").frame["d1"].to_numpy()
    assert back.tolist() == values


def test_zero_negative_and_crlf_quoted_rows_are_valid_and_scored_as_they_are(tmp_path, data):
    rows = truth_rows(d1=[0.0, -0.4, 0.5, 0.8, 1.0])
    rows[2] = '"tiny-val", "tiny-val/002" , 0.5'
    r = score_file(tmp_path, data, "\r\n".join([HEADER, *rows]) + "\r\n", "--json")
    assert r.exit_code == 0, r.output
    (s,) = json.loads(r.stdout)["splits"]
    assert s["mean_percent_error"] == pytest.approx((100 + 200 + 0 + 0 + 0) / 5)


def test_rows_in_any_order_and_several_splits(tmp_path, data):
    rows = truth_rows()[::-1] + truth_rows("more-val", [1.0, 2.0])
    r = score_file(tmp_path, data, "\n".join([HEADER, *rows]), "--json")
    assert r.exit_code == 0, r.output
    assert [s["split"] for s in json.loads(r.stdout)["splits"]] == ["more-val", "tiny-val"]


def test_unlabelled_examples_need_no_prediction_and_one_is_ignored(tmp_path, data):
    rows = truth_rows("more-val", [1.0, 2.0, 7.0])
    r = score_file(tmp_path, data, "\n".join([HEADER, *rows]))
    assert r.exit_code == 0, r.output
    assert "1 predictions for unlabelled examples were ignored" in r.stdout


def test_allow_partial_scores_a_subset_and_says_so_loudly(tmp_path, data):
    text = "\n".join([HEADER, *truth_rows()[:3]])
    r = score_file(tmp_path, data, text)
    assert r.exit_code == 2
    r = score_file(tmp_path, data, text, "--allow-partial")
    assert r.exit_code == 0, r.output
    assert r.stdout.count("PARTIAL SCORE") == 2 and "tiny-val 3/5" in r.stdout
    r = score_file(tmp_path, data, text, "--allow-partial", "--json")
    assert json.loads(r.stdout)["partial"] is True


def csv(*rows: str) -> str:
    return "\n".join([HEADER, *rows])


T = truth_rows()
BAD = {
    "empty file": (b"", "the file is empty"),
    "whitespace only": (b" \n\n", "the file is empty"),
    "header only": (HEADER + "\n", "has a header but no rows"),
    "missing header": ("\n".join(T), "the header line is missing"),
    "misspelled header": (csv(*T).replace("example_id", "exmaple_id"),
                          "column 2 'exmaple_id' (did you mean 'example_id'?)"),
    "missing column": ("split,example_id\ntiny-val,tiny-val/000\n", "missing 'd1'"),
    "extra column": ("split,example_id,d1,comment\n", "extra column 4 'comment'"),
    "wrong column order": ("example_id,split,d1\n", "has the columns in another order; write 'split,"),
    "semicolons": (csv(*T).replace(",", ";"), "fields are separated by ';'"),
    "tabs": (csv(*T).replace(",", "\t"), "fields are separated by a tab"),
    "utf-8 bom": (codecs.BOM_UTF8 + csv(*T).encode(), "UTF-8 with a byte-order mark"),
    "utf-16": (csv(*T).encode("utf-16"), "encoded as UTF-16"),
    "utf-16 without bom": (csv(*T).encode("utf-16-le"), "NUL bytes"),
    "latin-1": (csv(*T, "tiny-val,tiny-val/caf\xe9,1").encode("latin-1"),
                "line 7 is not valid UTF-8 (byte 0xe9)"),
    "too many fields": (csv(*T, "tiny-val,tiny-val/000,1,2,3"), "line 7 has 5 fields, expected 3"),
    "decimal comma": (csv("tiny-val,tiny-val/000,0,2"), "a decimal comma?"),
    "blank line": (csv(*T[:2], "", *T[2:]), "blank lines in the file, 1 row: line 4"),
    "empty d1": (csv(*T[:4], "tiny-val,tiny-val/004,"), "d1 is missing or empty in 1 row: line 6"),
    "non-numeric": (csv(*T[:3], "tiny-val,tiny-val/003,abc", "tiny-val,tiny-val/004,1m"),
                    "d1 is not a number in 2 rows: line 5 ('abc'), line 6 ('1m')"),
    "nan": (csv(*T[:4], "tiny-val,tiny-val/004,nan"), "d1 is NaN or infinite in 1 row: line 6"),
    "inf": (csv(*T[:4], "tiny-val,tiny-val/004,-inf"), "NaN or infinite in 1 row: line 6 ('-inf')"),
    "unknown split": (csv(*T, "robot-val,robot-val/x,1"), "unknown split robot-val in 1 row: line 7"),
    "id without its split": (csv(*T[:4], "tiny-val,more-val/000,1"),
                             "example_id does not start with '<split>/' in 1 row: line 6"),
    "unknown ids": (csv(*T, "tiny-val,tiny-val/999,1", "tiny-val,tiny-val/x,1"),
                    "example ids not in split tiny-val in 2 rows: line 7 ('tiny-val/999'), line 8"),
    "duplicates": (csv(*T, T[1]), "1 example id(s) appear more than once: 'tiny-val/001' (lines 3, 7)"),
    "missing examples": (csv(*T[:2]), "3 of 5 examples of split tiny-val have no prediction (first: "
                         "tiny-val/002, tiny-val/003, tiny-val/004); pass --allow-partial"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_predictions_exit_2_with_one_line(tmp_path, data, case):
    text, expected = BAD[case]
    r = score_file(tmp_path, data, text)
    assert r.exit_code == 2, (case, r.output)
    assert r.stdout == ""
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("odms-data: error: "), r.stderr
    assert expected in lines[0], lines[0]
    assert "p.csv" in lines[0]


def test_many_offenders_are_counted_and_only_the_first_named(tmp_path, data):
    rows = [f"tiny-val,tiny-val/{i:03d},x{i}" for i in range(5)]
    r = score_file(tmp_path, data, "\n".join([HEADER, *rows]))
    assert "d1 is not a number in 5 rows: line 2 ('x0'), line 3 ('x1'), line 4 ('x2') and 2 more" in r.stderr


def test_no_stores_or_missing_file_are_one_line_errors(tmp_path, data):
    p = write(tmp_path, "\n".join([HEADER, *truth_rows()]))
    r = CliRunner().invoke(main, ["score", str(p), "--data", str(tmp_path / "nowhere")])
    assert r.exit_code == 2 and "no such data folder or store" in r.stderr
    r = run(["score", str(tmp_path / "absent.csv")], data)
    assert r.exit_code == 2 and "no such predictions file" in r.stderr


def test_n_obs_beyond_the_examples_observations_is_refused(tmp_path, data):
    """score --n-obs 11 on 10-observation examples was reported as n = 11; score refuses it as
    every command does (protocol.observation_indices), naming the store."""
    text = "\n".join([HEADER, *truth_rows()]) + "\n"
    r = score_file(tmp_path, data, text, "--n-obs", "3")
    assert r.exit_code == 2 and "need 2 <= n_obs <= n, got n_obs=3 for an example of 2 frames" in r.stderr
    assert "tiny-val.zarr" in r.stderr and r.stderr.count("\n") == 1
    assert score_file(tmp_path, data, text, "--n-obs", "2").exit_code == 0


def test_hdf5_stores_serve_their_split_by_attribute(tmp_path):
    folder = tmp_path / "h5"
    folder.mkdir()
    ex = [{"z": [d, d + 0.1], "areas": [100, 64], "d1": d} for d in D1]
    make_store(folder / "any-name.h5", "tiny-val", ex)
    p = write(tmp_path, "\n".join([HEADER, *truth_rows()]))
    r = CliRunner().invoke(main, ["score", str(p), "--data", str(folder)])
    assert r.exit_code == 0, r.output
    assert "tiny-val " in r.stdout
    make_store(folder / "again.zarr", "tiny-val", ex)
    r = CliRunner().invoke(main, ["score", str(p), "--data", str(folder)])
    assert r.exit_code == 2 and "two stores hold split tiny-val" in r.stderr


def test_data_from_environment_variable(tmp_path, data):
    p = write(tmp_path, "\n".join([HEADER, *truth_rows()]))
    r = CliRunner(env={"ODMS_DATA": str(data)}).invoke(main, ["score", str(p)])
    assert r.exit_code == 0, r.output


def test_schema_describes_the_columns_and_accepts_valid_rows(tmp_path):
    import jsonschema

    from odms_data.evaluation.predictions import COLUMNS
    from odms_data.resources import resource_dir

    schema = json.loads((resource_dir("schemas") / "predictions.schema.json").read_text())
    assert schema["x-csv"]["header"] == list(COLUMNS) == schema["required"]
    frame = read_predictions(write(tmp_path, "\n".join([HEADER, *truth_rows()]))).frame
    for row in frame[list(COLUMNS)].to_dict("records"):
        jsonschema.validate(row, schema)
    assert np.isfinite(frame["d1"]).all()


def test_one_duplicate_row_in_a_full_file_names_its_lines(tmp_path, data):
    """Every example once plus one repeated row: the file has one row more than the stores hold
    examples, and the message names the repeat, not the stores."""
    rows = [*truth_rows(), *truth_rows("more-val", [1.0, 2.0, 3.0])]
    r = score_file(tmp_path, data, csv(*rows, rows[1]))
    assert r.exit_code == 2, r.output
    assert r.stderr.splitlines() == [
        f"odms-data: error: {tmp_path / 'p.csv'}: 1 example id(s) appear more than once: "
        "'tiny-val/001' (lines 3, 10)"]
