"""Every command over every broken store (broken_stores.DAMAGE): one line and exit code 2, never an
internal error (exit 3), nothing written; and validate finds every kind of damage."""

from __future__ import annotations

import shutil

import pytest
from broken_stores import DAMAGE, broken_stores, make_valid
from hostile import run_inprocess


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    root = tmp_path_factory.mktemp("broken")
    valid = {"zarr": make_valid(root / "v.zarr"), "h5": make_valid(root / "v.h5")}
    (root / "b").mkdir()
    rows = "".join(f"tiny,tiny/{i:06d},0.3\n" for i in range(4))
    (root / "p.csv").write_text("split,example_id,d1\n" + rows)
    return root, broken_stores(root / "b", valid)


def commands(store: str, out: str) -> dict[str, list[str]]:
    return {
        "info": ["info", "--json", store], "show": ["show", store, "tiny/000001", "-o", f"{out}.png"],
        "convert": ["convert", store, out + (".zarr" if store.endswith(".h5") else ".h5")],
        "baseline": ["baseline", "vosde", store, "--n-obs", "3", "-o", f"{out}.csv"],
        "score": ["score", "p.csv", "--data", store], "export": ["export", store, "-o", f"{out}-hub"],
    }


NAMES = [f"{name} ({backend})" for name, (backends, _) in DAMAGE.items() for backend in backends.split()]


def test_every_damage_is_in_the_walk():
    assert len(NAMES) >= 40


@pytest.mark.parametrize("name", NAMES)
def test_commands_on_a_broken_store(stores, name, tmp_path):
    root, broken = stores
    store = str(broken[name].relative_to(root))
    v = run_inprocess(["validate", store], root)
    assert v.rc == 1 and "INVALID" in v.out, (name, v.out)
    for command, args in commands(store, str(tmp_path / "out")).items():
        r = run_inprocess(args, root)
        assert r.rc in (0, 2), (name, command, r.rc, r.err)
        assert "Traceback" not in r.err and "Warning" not in r.err, (name, command, r.err)
        if r.rc == 2:
            lines = r.err.strip().splitlines()
            assert [x for x in lines if x.startswith("odms-data:")] == lines[-1:], (name, command, r.err)
            assert lines[-1].startswith("odms-data: error: "), (name, command, r.err)
            assert list(tmp_path.iterdir()) == [], (name, command, "left", list(tmp_path.iterdir()))
        for p in tmp_path.iterdir():  # the next command writes afresh
            p.unlink() if p.is_file() else shutil.rmtree(p)
