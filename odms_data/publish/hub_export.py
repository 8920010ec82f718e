"""Export stores as a Hugging Face Hub dataset: Parquet shards, a dataset card and Croissant metadata.

    DIR/README.md                               dataset card (YAML header the Hub reads, then prose)
    DIR/croissant.json                          Croissant 1.0 JSON-LD (dataset, files, record set)
    DIR/data/<split>/<split>-00000-of-00002.parquet

One row per example: `example_id`, `split`, `source`, `d1` (NaN when unlabelled), `n`, `height`,
`width`, then a list of n per frame of each array of the stores' kind that the array table gives a
Hub column (format.ARRAYS; hub_metadata.columns_of): for masks `z`, `depth`, `area` and `masks`, each
bit-packed as the store packs them (store/masks.py: rows of ceil(width / 8) bytes, most
significant bit first); for boxes `depth`, `box` and `move`. An export holds one kind.
`datasets.load_dataset(DIR)` reads it, one split per store (named with `_` for `-`, as the Hub
allows only letters, digits and `_` in split names). The folder is written as DIR.partial and
renamed into place when complete, as every output is (outputs.py); a store whose content differs
from its recorded digest is refused, since the card publishes the digests. Needs pyarrow (the
`hub` extra).
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .. import safe_json
from ..errors import InputError, OdmsError
from ..extras import optional
from ..outputs import OutputType, atomic_folder
from ..store.build import Progress
from ..store.digest import READ_BYTES, check_recorded_digest
from ..store.format import ARRAYS
from ..store.masks import packed_width
from ..store.reader import Store, open_store
from .hub_metadata import (
    SplitExport,
    check_licence,
    columns_of,
    croissant,
    dataset_card,
    hub_split,
    licence_of,
)

ROW_GROUP = 100  # examples per Parquet row group: small groups let the Hub's viewer page quickly


def _example_rows(store: Store, rows: range) -> dict[str, list]:
    """The columns (hub_metadata.columns_of) of examples `rows` of `store`, their masks read a
    block of about READ_BYTES at a time."""
    columns = columns_of(store.kind)
    frames = [store.frames_of(i) for i in rows]
    flat = np.concatenate([np.zeros(0, np.int64), *frames])
    lo = int(flat.min()) if len(flat) else 0
    masks = any(ARRAYS[c].sharded for c in columns if c in ARRAYS)
    packed: dict[int, bytes] = {}  # frame -> its packed bytes, read READ_BYTES at a time
    if len(flat) and masks:
        hi, step = int(flat.max()) + 1, max(1, READ_BYTES // (store.height * packed_width(store.width)))
        for start in range(lo, hi, step):
            block = store.read_packed(start, min(hi, start + step))
            packed.update((start + j, m.tobytes()) for j, m in enumerate(block))
    out: dict[str, list] = {
        "split": [store.attrs.split] * len(rows),
        "n": [len(f) for f in frames],
        "height": [store.height] * len(rows),
        "width": [store.width] * len(rows),
    }
    for c in columns:
        a = ARRAYS.get(c)
        if a is None:
            continue
        if a.sharded:
            out[c] = [[packed[k] for k in f] for f in frames]
        elif a.per == "frame":
            values = store.checked(c)
            out[c] = [values[f].tolist() for f in frames]
        elif a.text:
            values = store.checked(c)
            out[c] = [values[i] for i in rows]
        else:
            out[c] = store.checked(c)[rows.start : rows.stop].tolist()
    return {c: out[c] for c in columns}


def _schema(kind: str):
    import pyarrow as pa

    def arrow(c: str):
        a = ARRAYS.get(c)
        if a is None:
            return pa.string() if c == "split" else pa.int32()
        if a.sharded:
            return pa.list_(pa.binary())
        if a.text:
            return pa.string()
        one = pa.from_numpy_dtype(a.dtype)
        for _ in a.trailing:
            one = pa.list_(one)
        return pa.list_(one) if a.per == "frame" else one

    return pa.schema([(c, arrow(c)) for c in columns_of(kind)])


def _write_split(store: Store, folder: Path, examples_per_file: int,
                 progress: Callable[[int], None]) -> SplitExport:
    import pyarrow as pa
    import pyarrow.parquet as pq

    split, n = store.attrs.split, store.n_examples
    count = max(1, -(-n // examples_per_file))
    (folder / "data" / split).mkdir(parents=True)
    files, size = [], 0
    for k in range(count):
        rows = range(k * examples_per_file, min(n, (k + 1) * examples_per_file))
        name = f"data/{split}/{split}-{k:05d}-of-{count:05d}.parquet"
        with pq.ParquetWriter(folder / name, _schema(store.kind), compression="zstd") as writer:
            for group in range(rows.start, rows.stop, ROW_GROUP):  # a group's masks in memory at a time
                part = range(group, min(rows.stop, group + ROW_GROUP))
                writer.write_table(pa.Table.from_pydict(_example_rows(store, part), schema=writer.schema))
        files.append(name)
        size += (folder / name).stat().st_size
        progress(len(rows))
    return SplitExport(split, n, files, size)


def sha256(path: Path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def _not_an_export(path: Path) -> str | None:
    """What makes `path` something else than an earlier export or an empty folder (None if not):
    an export is a folder whose croissant.json names odms-data as its creator."""
    if not path.is_dir():
        return "is a file, not an earlier export"
    if not any(path.iterdir()):
        return None
    try:
        creator = safe_json.load_file(path / "croissant.json")["creator"]["name"]
    except (OdmsError, KeyError, TypeError):
        creator = None
    if not (isinstance(creator, str) and creator.startswith("odms-data ")):
        return "is not an earlier export (no croissant.json written by odms-data)"
    return None


EXPORT = OutputType("export", _not_an_export)


_HEADER_LINE = re.compile(r" *(?:[a-z_]+:(?: (?P<value>.+))?|- (?P<item>.+))")


def _header_line(line: str) -> bool:
    """Whether `line` is one of a card header's: a key, a key and its value, a list item, each
    value a quoted scalar (JSON's) or a nested key."""
    m = _HEADER_LINE.fullmatch(line)
    if m is None:
        return False
    if m["item"] and _HEADER_LINE.fullmatch(m["item"]):  # a list of mappings: `- key: value`
        return _header_line(m["item"])
    value = m["value"] or m["item"]
    if value is None:
        return True
    try:
        json.loads(value)
    except ValueError:
        return False
    return True


def check_export(folder: Path, exported: Sequence[SplitExport]) -> None:
    """An export's readers' checks, before it replaces anything (outputs.Check): the card's YAML
    header parses to a mapping, croissant.json parses and names odms-data, and every Parquet file
    it lists has the sha256 it records and reads back as Parquet, each split's files holding its
    examples. InputError naming the file otherwise."""
    import pyarrow.parquet as pq

    card = (folder / "README.md").read_text(encoding="utf-8")
    head, sep, _ = card.removeprefix("---\n").partition("\n---\n")
    if not (card.startswith("---\n") and sep and all(map(_header_line, head.splitlines()))):
        raise InputError("README.md: its YAML header is not the one shown_text.yaml_header writes")
    if _not_an_export(folder):
        raise InputError("croissant.json: does not read as odms-data's Croissant metadata")
    listed = {d.get("contentUrl"): d.get("sha256") for d in safe_json.load_file(folder / "croissant.json")
              ["distribution"] if isinstance(d, dict)}
    for e in exported:
        rows = 0
        for f in e.files:
            if listed.get(f) != sha256(folder / f):
                raise InputError(f"{f}: its sha256 is not the one croissant.json records")
            try:
                rows += pq.ParquetFile(folder / f).metadata.num_rows
            except Exception as err:  # pyarrow's ArrowInvalid, OSError, ...: not Parquet
                raise InputError(f"{f}: does not read back as Parquet ({err})") from None
        if rows != e.examples:
            raise InputError(f"{e.split}: its Parquet files hold {rows} examples, not {e.examples}")


def export_hub(
    stores: Sequence[str],
    out_dir: str,
    *,
    name: str | None = None,
    licence: str | None = None,
    examples_per_file: int = 1000,
    overwrite: bool = False,
    progress: Progress = lambda output, done, total: None,
) -> list[SplitExport]:
    """Write `stores` (one split each) to `out_dir` as Parquet shards with a dataset card and
    Croissant metadata; returns what each store became."""
    optional("pyarrow", "the Hub export")
    if examples_per_file < 1:
        raise InputError(f"examples per file must be at least 1, got {examples_per_file}")
    target = Path(out_dir)
    opened = [open_store(p) for p in stores]
    try:
        other = next(((p, s.kind) for p, s in zip(stores, opened, strict=True) if s.kind != opened[0].kind),
                     None)
        if other is not None:  # a Hub dataset's splits share their columns, which follow the kind
            raise InputError(f"{other[0]}: a store of {other[1]} cannot join an export of stores of "
                             f"{opened[0].kind} ({stores[0]}); export each kind on its own")
        splits = [s.attrs.split for s in opened]
        twice = sorted({s for s in splits if splits.count(s) > 1})
        if twice:
            raise InputError(f"split {twice[0]} comes from more than one store; export each split once")
        names = [hub_split(s) for s in splits]
        clash = next((n for n in names if names.count(n) > 1), None)
        if clash:
            raise InputError(f"splits {' and '.join(s for s in splits if hub_split(s) == clash)} both become "
                             f"the Hub split {clash}; export them separately")
        licence = check_licence(licence) if licence else licence_of([s.attrs for s in opened])
        for path, s in zip(stores, opened, strict=True):  # the card publishes each store's digest
            check_recorded_digest(s, path)
        exported: list[SplitExport] = []
        with atomic_folder(target, EXPORT, overwrite=overwrite,
                           check=lambda folder: check_export(folder, exported)) as partial:
            total, done = sum(s.n_examples for s in opened), 0

            def written(n: int) -> None:
                nonlocal done
                done += n
                progress(str(out_dir), done, total)

            exported += [_write_split(s, partial, examples_per_file, written) for s in opened]
            title, attrs = name or target.name, [s.attrs for s in opened]
            (partial / "README.md").write_text(dataset_card(title, attrs, exported, licence))
            hashes = {f: sha256(partial / f) for e in exported for f in e.files}
            (partial / "croissant.json").write_text(croissant(title, attrs, exported, licence, hashes))
    finally:
        for s in opened:
            s.close()
    return exported
