"""Broken stores, one kind of damage each, made from a valid store by writing with zarr or h5py
directly (as a bug, a disk or a hand would): what every command must refuse with one line."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import zarr

from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams

TINY = GeneratorParams(n_obs=3, image_size=(24, 36), sizes=(12, 20), perturb_std=1.0)


def make_valid(path: Path, count: int = 4, split: str = "tiny") -> Path:
    """A small valid generated store (Zarr or HDF5 by the suffix)."""
    generate(str(path), count, TINY, 3, split=split)
    return path


@contextmanager
def opened(path: Path) -> Iterator[Any]:
    """The store's root (zarr group or h5py file) open for writing."""
    if path.is_dir():
        yield zarr.open_group(str(path), mode="r+")
    else:
        with h5py.File(path, "r+") as f:
            yield f


def attrs_of(root: Any) -> dict:
    raw = root.attrs["odms"]
    return json.loads(raw) if isinstance(raw, str | bytes) else dict(raw)


def set_attrs(root: Any, attrs: dict) -> None:
    root.attrs["odms"] = json.dumps(attrs) if isinstance(root, h5py.File) else attrs


def edit_attrs(fn: Callable[[dict], None]) -> Callable[[Path], None]:
    def damage(path: Path) -> None:
        with opened(path) as root:
            a = attrs_of(root)
            fn(a)
            set_attrs(root, a)
    return damage


def put(name: str, where: Any, value: Any) -> Callable[[Path], None]:
    """Write `value` into array `name` at index `where`."""
    def damage(path: Path) -> None:
        with opened(path) as root:
            root[name][where] = value
    return damage


def recreate(name: str, data: np.ndarray) -> Callable[[Path], None]:
    """Replace array `name` by `data` (another shape or dtype)."""
    def damage(path: Path) -> None:
        with opened(path) as root:
            if isinstance(root, h5py.File):
                del root[name]
                root.create_dataset(name, data=data)
            else:
                root.create_array(name, data=data, overwrite=True)
    return damage


def _no_examples(path: Path) -> None:
    with opened(path) as root:
        for name, width in (("frame_index", root["frame_index"].shape[1]), ("d1", None),
                            ("example_id", root["example_id"].shape[1]), ("source", root["source"].shape[1])):
            dtype = root[name].dtype
            recreate(name, np.zeros((0,) if width is None else (0, width), dtype))(path)
        a = attrs_of(root)
    a["counts"] = {"examples": 0, "frames": a["counts"]["frames"], "labelled": 0}
    with opened(path) as root:
        set_attrs(root, a)


def _id(text: bytes) -> Callable[[Path], None]:
    def damage(path: Path) -> None:
        with opened(path) as root:
            row = np.zeros(root["example_id"].shape[1], np.uint8)
            row[: len(text)] = np.frombuffer(text[: len(row)], np.uint8)
            root["example_id"][1] = row
    return damage


def _duplicate_id(path: Path) -> None:
    with opened(path) as root:
        root["example_id"][1] = root["example_id"][0]


def _remove(rel: str) -> Callable[[Path], None]:
    def damage(path: Path) -> None:
        target = path / rel
        shutil.rmtree(target) if target.is_dir() else target.unlink()
    return damage


def _write_file(rel: str, data: bytes) -> Callable[[Path], None]:
    def damage(path: Path) -> None:
        (path / rel).write_bytes(data)
    return damage


def _truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _not_hdf5(path: Path) -> None:
    path.write_bytes(b"split,example_id,d1\n")


# name -> (backends it applies to, damage)
DAMAGE: dict[str, tuple[str, Callable[[Path], None]]] = {
    "frame_index past the frames": ("zarr h5", put("frame_index", (1, 1), 10_000)),
    "frame_index below -1": ("zarr", put("frame_index", (1, 1), -7)),
    "padding inside an example": ("zarr", put("frame_index", (2, 1), -1)),
    "an example of one frame": ("zarr", put("frame_index", (0, slice(1, None)), -1)),
    "z not finite": ("zarr h5", put("z", 4, np.nan)),
    "z infinite": ("zarr", put("z", 0, np.inf)),
    "z not increasing": ("zarr", put("z", 5, -1.0)),
    "depth infinite": ("zarr h5", put("depth", 2, np.inf)),
    "depth negative": ("zarr", put("depth", 2, -0.5)),
    "d1 negative": ("zarr", put("d1", 1, -0.3)),
    "d1 infinite": ("zarr", put("d1", 1, np.inf)),
    "d1 is not the first frame's depth": ("zarr", put("d1", 1, 12.5)),
    "id without its split": ("zarr h5", _id(b"other/000001")),
    "duplicate ids": ("zarr h5", _duplicate_id),
    "empty id": ("zarr", _id(b"")),
    "id not UTF-8": ("zarr", _id(b"tiny/\xff\xfe")),
    "no examples": ("zarr h5", _no_examples),
    "counts.labelled wrong": ("zarr", edit_attrs(lambda a: a["counts"].update(labelled=1))),
    "incomplete": ("zarr h5", edit_attrs(lambda a: a.update(complete=False))),
    "attribute missing": ("zarr", edit_attrs(lambda a: a.pop("digest"))),
    "image_size disagrees with masks": ("zarr", edit_attrs(lambda a: a.update(image_size=[24, 99]))),
    "stats disagree with masks": ("zarr h5", put("area", 0, 7)),
    "largest_area negative": ("zarr", put("largest_area", 3, -5)),
    "digest wrong": ("zarr h5", edit_attrs(lambda a: a.update(digest="sha256:" + "1" * 64))),
    "z as float32": ("zarr", lambda p: recreate("z", zarr.open_array(str(p / "z"))[:].astype(np.float32))(p)),
    "masks missing": ("zarr", _remove("masks")),
    "d1 chunk missing": ("zarr", _remove("d1/c")),
    "masks shard garbage": ("zarr", _write_file("masks/c/0/0/0", b"\x00" * 64)),
    "root metadata garbage": ("zarr", _write_file("zarr.json", b"{not json")),
    "truncated HDF5": ("h5", _truncate),
    "an .h5 that is not HDF5": ("h5", _not_hdf5),
    "an empty folder": ("zarr", lambda p: (shutil.rmtree(p), p.mkdir())),
}


def broken_stores(root: Path, valid: dict[str, Path]) -> dict[str, Path]:
    """Every damage applied to a copy of the valid store of each backend it applies to:
    '<damage> (<backend>)' -> path under `root`."""
    out = {}
    for i, (name, (backends, damage)) in enumerate(DAMAGE.items()):
        for backend in backends.split():
            src = valid[backend]
            dst = root / f"b{i:02d}-{backend}{src.suffix}"
            shutil.copytree(src, dst) if src.is_dir() else shutil.copy(src, dst)
            damage(dst)
            out[f"{name} ({backend})"] = dst
    return out
