"""Broken stores, one kind of damage each, made from a valid store by writing with zarr or h5py
directly (as a bug, a disk or a hand would): what every command must refuse with one line."""

from __future__ import annotations

import json
import os
import re
import shutil
import stat
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


def copy_store(src: Path, dst: Path) -> None:
    """A copy of a store as it is: links kept, a FIFO made anew (shutil refuses to copy one)."""
    def copy(s: str | Path, d: str | Path) -> None:
        os.mkfifo(d) if stat.S_ISFIFO(os.lstat(s).st_mode) else shutil.copy2(s, d)

    shutil.copytree(src, dst, symlinks=True, copy_function=copy) if src.is_dir() else copy(src, dst)


def _fifo(rel: str) -> Callable[[Path], None]:
    """The file at `rel` (the store itself for '') replaced by a FIFO, which no writer ever opens:
    a reader that opens it waits forever."""
    def damage(path: Path) -> None:
        target = path / rel if rel else path
        target.unlink()
        os.mkfifo(target)
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


def broken_stores(root: Path, valid: dict[str, Path],
                  damages: dict[str, tuple[str, Callable[[Path], None]]] | None = None) -> dict[str, Path]:
    """Every damage (default: DAMAGE) applied to a copy of the valid store of each backend it
    applies to: '<damage> (<backend>)' -> path under `root`."""
    out = {}
    for i, (name, (backends, damage)) in enumerate((DAMAGE if damages is None else damages).items()):
        for backend in backends.split():
            src = valid[backend]
            dst = root / f"b{i:02d}-{backend}{src.suffix}"
            shutil.copytree(src, dst) if src.is_dir() else shutil.copy(src, dst)
            damage(dst)
            out[f"{name} ({backend})"] = dst
    return out


# --- hostile stores: made to cost a reader memory, or to read as something they are not ---------
BOMB_BYTES = 2**32  # what a bomb decodes to: far past the memory the untrusted-read tests allow


def zstd_bomb() -> bytes:
    """A zstd frame of BOMB_BYTES zeros (about 32 KB), its size not in its header."""
    import zstandard

    c = zstandard.ZstdCompressor(level=1, write_content_size=False).compressobj()
    zeros = bytes(2**24)
    return b"".join(c.compress(zeros) for _ in range(BOMB_BYTES // len(zeros))) + c.flush()


def gzip_bomb() -> bytes:
    """A zlib stream of BOMB_BYTES zeros (about 4 MB), as HDF5's gzip filter stores a chunk: after
    a full flush, each block of zeros deflates to the same bytes, so one is made and repeated."""
    import zlib

    zeros, n = bytes(2**24), BOMB_BYTES // 2**24
    c = zlib.compressobj(9)
    first = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
    piece = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
    end = c.flush()[:-4]  # the final block, without the checksum of two blocks
    adler = 1
    for _ in range(n):
        adler = zlib.adler32(zeros, adler)
    return first + piece * (n - 1) + end + adler.to_bytes(4, "big")


def rewrite_shard(store: Path, k: int, data: bytes | None) -> None:
    """Chunk k of the first mask shard of a Zarr store replaced by `data` (None: marked missing)."""
    import google_crc32c

    meta = json.loads((store / "masks" / "zarr.json").read_text())
    shard = meta["chunk_grid"]["configuration"]["chunk_shape"][0]
    per = shard // meta["codecs"][0]["configuration"]["chunk_shape"][0]
    path = store / "masks" / "c" / "0" / "0" / "0"
    raw = path.read_bytes()
    index = np.frombuffer(raw[-4 - 16 * per : -4], "<u8").reshape(-1, 2).copy()
    chunks = [raw[o : o + n] for o, n in index.tolist()]
    chunks[k] = data or b""
    body = b"".join(chunks)
    index[:, 1] = [len(c) for c in chunks]
    index[:, 0] = np.cumsum([0] + [len(c) for c in chunks[:-1]])
    if data is None:
        index[k] = 2**64 - 1
    tail = index.astype("<u8").tobytes()
    path.write_bytes(body + tail + google_crc32c.value(tail).to_bytes(4, "little"))


def _zstd_bomb_in(rel: str) -> Callable[[Path], None]:
    def damage(path: Path) -> None:
        (path / rel).write_bytes(zstd_bomb())
    return damage


def _forge_frames(n: int) -> Callable[[Path], None]:
    """Every per-frame array (and counts.frames) declares n frames; nothing else is written."""
    def damage(path: Path) -> None:
        if path.is_dir():
            for name in FRAME_NAMES:
                meta_path = path / name / "zarr.json"
                meta = json.loads(meta_path.read_text())
                meta["shape"][0] = n
                meta_path.write_text(json.dumps(meta))
        else:
            with h5py.File(path, "r+") as f:
                for name in FRAME_NAMES:
                    d = f[name]
                    shape, chunks, dtype = (n, *d.shape[1:]), d.chunks, d.dtype
                    del f[name]
                    f.create_dataset(name, shape=shape, chunks=chunks, dtype=dtype, compression="gzip")
        edit_attrs(lambda a: a["counts"].update(frames=n))(path)
    return damage


FRAME_NAMES = ("masks", "z", "depth", "area", "largest_area", "bbox")


def _h5_mask_chunk(data: bytes | None) -> Callable[[Path], None]:
    """The masks of an HDF5 store rewritten: one chunk of 1000 frames (whose size field holds
    megabytes) given as `data`, its raw deflated bytes; or, for None, one frame a chunk with
    frame 3's (the first of example 1) left unwritten."""
    def damage(path: Path) -> None:
        with h5py.File(path, "r+") as f:
            masks = f["masks"][...]
            del f["masks"]
            frames = 1 if data is None else 1000
            d = f.create_dataset("masks", shape=masks.shape, maxshape=(None, *masks.shape[1:]),
                                 dtype=masks.dtype, chunks=(frames, *masks.shape[1:]), compression="gzip")
            if data is None:
                d[:3], d[4:] = masks[:3], masks[4:]
            else:
                d.id.write_direct_chunk((0, 0, 0), data)
    return damage


def _h5_link(kind: str) -> Callable[[Path], None]:
    """`masks` replaced by an external link or a virtual dataset onto a copy in another file."""
    def damage(path: Path) -> None:
        other = path.with_name(path.stem + "-other.h5")
        with h5py.File(path, "r+") as f:
            masks = f["masks"][...]
            with h5py.File(other, "w") as o:
                o.create_dataset("masks", data=masks)
            del f["masks"]
            if kind == "external":
                f["masks"] = h5py.ExternalLink(other.name, "masks")
            else:
                layout = h5py.VirtualLayout(shape=masks.shape, dtype=masks.dtype)
                layout[...] = h5py.VirtualSource(other.name, "masks", shape=masks.shape)
                f.create_virtual_dataset("masks", layout)
    return damage


def _empty_chunk_side(path: Path) -> None:
    """`area` declares chunks of 0 frames (zarr opens such an array)."""
    meta_path = path / "area" / "zarr.json"
    meta = json.loads(meta_path.read_text())
    meta["chunk_grid"]["configuration"]["chunk_shape"][0] = 0
    meta_path.write_text(json.dumps(meta))


def _h5_chunk_indexes_damaged(path: Path) -> None:
    """The signature of every chunk B-tree node (version 1 "TREE", node type 1) damaged."""
    raw = bytearray(path.read_bytes())
    for node in re.finditer(rb"TREE\x01", raw):
        raw[node.start()] ^= 0xFF
    path.write_bytes(bytes(raw))


def _deep_json(path: Path) -> None:
    deep = "[" * 100_000 + "]" * 100_000
    if path.is_dir():
        text = (path / "zarr.json").read_text()
        (path / "zarr.json").write_text(text.replace('"attributes": {', f'"attributes": {{"x": {deep}, ', 1))
    else:
        with h5py.File(path, "r+") as f:
            f.attrs["odms"] = f.attrs["odms"].replace("{", '{"x": ' + deep + ", ", 1)


# name -> (backends it applies to, damage): each must be refused with one line, in bounded memory
HOSTILE: dict[str, tuple[str, Callable[[Path], None]]] = {
    "zstd bomb in a mask chunk": ("zarr", lambda p: rewrite_shard(p, 1, zstd_bomb())),
    "zstd bomb in a z chunk": ("zarr", _zstd_bomb_in("z/c/0")),
    "gzip bomb in a mask chunk": ("h5", _h5_mask_chunk(gzip_bomb())),
    "10^8 frames declared": ("zarr", _forge_frames(10**8)),
    "3x10^9 frames declared": ("h5", _forge_frames(3 * 10**9)),
    "a mask chunk missing": ("zarr h5", lambda p: rewrite_shard(p, 1, None) if p.is_dir()
                             else _h5_mask_chunk(None)(p)),
    "the mask shard missing": ("zarr", _remove("masks/c")),
    "an area chunk missing": ("zarr", _remove("area/c/0")),
    "masks an external link": ("h5", _h5_link("external")),
    "masks a virtual dataset": ("h5", _h5_link("virtual")),
    "a FIFO for the mask shard": ("zarr", _fifo("masks/c/0/0/0")),
    "a FIFO for a z chunk": ("zarr", _fifo("z/c/0")),
    "a FIFO for an array's metadata": ("zarr", _fifo("area/zarr.json")),
    "a FIFO for the store": ("h5", _fifo("")),
    "attributes nested 100,000 deep": ("zarr h5", _deep_json),
    "a chunk shape with an empty side": ("zarr", _empty_chunk_side),
    "every chunk index damaged": ("h5", _h5_chunk_indexes_damaged),
}
