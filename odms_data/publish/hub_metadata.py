"""The metadata of an exported dataset (hub_export.py): the Hub's dataset card and Croissant JSON-LD.

The card is a README.md whose YAML header carries what the Hub indexes (licence, task, size,
tags, and `configs`, which maps each split to its Parquet files so that `datasets` and the Hub's
viewer find them); the Croissant file (MLCommons Croissant 1.0) describes the dataset, its files
and one record set whose fields are the Parquet columns. The columns follow from the array
table (format.ARRAYS) for the stores' kind; what the card says of the kind is its `KindText`.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache

from .._version import __version__
from ..errors import InputError
from ..protocol import official_name
from ..shown_text import Markdown, markdown, markdown_join, yaml_header
from ..store.format import StoreAttrs, arrays_of, arrays_per


@dataclass(frozen=True)
class KindText:
    """What the card and the Croissant metadata say of one kind of example (format.KINDS)."""

    benchmark: str  # its name, as the papers spell it
    venue: str  # the paper's venue and year
    paper: str  # the paper's title
    bibtex: Markdown
    url: str  # the authors' repository
    image: str  # what the columns `height` and `width` measure
    tags: tuple[str, ...]  # the card's Hub tags
    keywords: tuple[str, ...]  # Croissant's
    intro: Markdown  # the card's first words: what an example is
    summary: str  # the same in a line, for Croissant
    reading: Markdown  # Python that turns a row `ex` into arrays


KIND_TEXT = {
    "masks": KindText(
        benchmark="ODMS", venue="ECCV 2020",
        paper="Learning Object Depth from Camera Motion and Video Object Segmentation",
        bibtex=Markdown("""@inproceedings{GrCo20,
  author = {Griffin, Brent A. and Corso, Jason J.},
  title = {Learning Object Depth from Camera Motion and Video Object Segmentation},
  booktitle = {European Conference on Computer Vision (ECCV)},
  year = {2020}
}"""),
        url="https://github.com/griffbr/ODMS", image="mask",
        tags=("odms", "object-depth", "segmentation-masks", "camera-motion"),
        keywords=("ODMS", "object depth", "segmentation masks", "camera motion"),
        intro=Markdown("""\
ODMS (Object Depth via Motion and Segmentation; Griffin & Corso, ECCV 2020) examples: the binary
segmentation masks of one object seen from a camera moving along its optical axis, the camera
positions `z` and the label `d1`, the object's depth at the closest observation."""),
        summary="binary masks of an object seen from a camera moving along its optical axis, camera "
                "positions and the depth label d1",
        reading=Markdown("""\
masks = np.stack([np.unpackbits(np.frombuffer(m, np.uint8).reshape(ex["height"], -1), axis=-1,
                                count=ex["width"]).astype(bool) for m in ex["masks"]])  # (n, h, w)""")),
    "boxes": KindText(
        benchmark="ODMD", venue="CVPR 2021", paper="Depth from Camera Motion and Object Detection",
        bibtex=Markdown("""@inproceedings{GrCoCVPR21,
  author = {Griffin, Brent A. and Corso, Jason J.},
  booktitle = {The IEEE Conference on Computer Vision and Pattern Recognition (CVPR)},
  title = {Depth from Camera Motion and Object Detection},
  year = {2021}
}"""),
        url="https://github.com/griffbr/ODMD", image="image",
        tags=("odmd", "object-depth", "object-detection", "bounding-boxes", "camera-motion"),
        keywords=("ODMD", "object depth", "object detection", "bounding boxes", "camera motion"),
        intro=Markdown("""\
ODMD (Object Depth via Motion and Detection; Griffin & Corso, CVPR 2021) examples: the detection
boxes of one object seen from a camera moving in x, y and z, the camera's movement `move` from
each observation to the last, and the label `d1`, the object's depth at the last observation."""),
        summary="detection boxes of an object seen from a camera moving in x, y and z, the camera "
                "movements and the depth label d1",
        reading=Markdown("""\
boxes = np.array(ex["box"])  # (n, 4) [x_c, y_c, w, h]; x_c, w / width and y_c, h / height
move = np.array(ex["move"])  # (n, 3) m, from each observation to the last""")),
}
RELEASE_LICENCE = {  # the licence of the authors' released data (griffbr/ODMS)
    "license": "other", "license_name": "odms-research-only",
    "license_link": "https://github.com/griffbr/ODMS",
}
LICENCE_URLS = {"mit": "https://opensource.org/licenses/MIT"}

@dataclass
class SplitExport:
    """What one store became: its split, examples and Parquet files (relative to the output)."""

    split: str
    examples: int
    files: list[str]
    bytes: int


@cache
def columns_of(kind: str) -> dict[str, tuple[str, bool, str]]:
    """column: (Croissant data type, repeated, description) of an export of stores of `kind`, in
    the Parquet files' order: the example's own columns, then a list per example of each per-frame
    array the table exports (format.ARRAYS), the masks last."""
    image = KIND_TEXT[kind].image
    derived = {  # the columns that are not store arrays
        "split": ("sc:Text", "the store's split"),
        "n": ("sc:Integer", "observations (frames) of the example"),
        "height": ("sc:Integer", f"{image} height, pixels"),
        "width": ("sc:Integer", f"{image} width, pixels"),
    }
    exported = {a.name: hub for a in arrays_of(kind).values() if (hub := a.hub_of(kind))}
    head = ["example_id", "split", "source", "d1", "n", "height", "width"]
    head += [a.name for a in arrays_per("example", kind) if a.hub and a.name not in head]
    frame = sorted((a for a in arrays_per("frame", kind) if a.hub), key=lambda a: a.sharded)
    return {
        **{c: (t, False, d) for c in head for t, d in [derived.get(c) or exported[c]]},
        **{a.name: (t, True, d) for a in frame for t, d in [exported[a.name]]},
    }


def hub_split(split: str) -> str:
    """The Hub's name for a split: letters, digits and '_' only."""
    return re.sub(r"\W", "_", split)


def licence_of(stores: Sequence[StoreAttrs]) -> str:
    """The licence of the stores' data when odms-data knows it: the generator's output is MIT like
    odms-data, the official release is research-only; others (recordings, SYNTHIA) need one given."""
    if all(a.domain == "generated" for a in stores):
        return "mit"
    if all(a.domain == "generated" or official_name(a.split, a.domain) for a in stores):
        return "other"
    unknown = next(a.split for a in stores
                   if a.domain != "generated" and not official_name(a.split, a.domain))
    raise InputError(f"the licence of split {unknown} is not known to odms-data", fix="licence")


LICENCE_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9.+-]{0,63}")  # an SPDX identifier, or the Hub's (cc-by-4.0)
LICENCE_LINE = 200  # characters at most of a licence given as a line of text


def check_licence(licence: str) -> str:
    """`licence` when it is an SPDX (or the Hub's) identifier or a single line of text; else InputError."""
    if LICENCE_ID.fullmatch(licence) or (
            licence.isprintable() and licence.strip() == licence and 0 < len(licence) <= LICENCE_LINE):
        return licence
    raise InputError(f"licence {licence[:60]!r}{'...' if len(licence) > 60 else ''}: a licence is an SPDX "
                     f"identifier (e.g. cc-by-4.0) or a single line of at most {LICENCE_LINE} printable "
                     "characters", option="licence")


def _licence_fields(licence: str) -> dict[str, str]:
    if licence == "other":
        return dict(RELEASE_LICENCE)
    if LICENCE_ID.fullmatch(licence):
        return {"license": licence}
    slug = re.sub(r"[^a-z0-9]+", "-", licence.lower()).strip("-")
    return {"license": "other", "license_name": slug or "other"}


def _size_category(n: int) -> str:
    for limit, label in ((1_000, "n<1K"), (10_000, "1K<n<10K"), (100_000, "10K<n<100K"),
                         (1_000_000, "100K<n<1M"), (10_000_000, "1M<n<10M")):
        if n < limit:
            return label
    return "10M<n<100M"


CARD = """{header}
# {title}

{intro} Exported by
odms-data {version} from its stores; licence: {licence}.

| split | domain | examples | image size (h x w) | content digest of the store |
| --- | --- | ---: | --- | --- |
{rows}

## Fields (one row per example)

| column | type | meaning |
| --- | --- | --- |
{fields}

## Reading it

```python
import datasets, numpy as np
ds = datasets.load_dataset("path/or/hub-name", split="{first}")
ex = ds[0]
{reading}
```

`croissant.json` describes the same files in MLCommons Croissant 1.0. odms-data reads the stores
these came from with `odms_data.open_store`; the digests above identify them.

## Citation

```bibtex
{bibtex}
```
"""


def dataset_card(
    title: str, stores: Sequence[StoreAttrs], exported: Sequence[SplitExport], licence: str
) -> Markdown:
    """README.md for the Hub: the YAML header, then what the data is, how to read it, where it
    came from; the title, licence and every store's text escaped (shown_text)."""
    total, text = sum(e.examples for e in exported), KIND_TEXT[stores[0].kind]
    header = {
        **_licence_fields(check_licence(licence)),
        "pretty_name": title,
        "task_categories": ["depth-estimation"],
        "tags": list(text.tags),
        "size_categories": [_size_category(total)],
        "configs": [{
            "config_name": "default",
            "data_files": [{"split": hub_split(e.split), "path": f"data/{e.split}/*.parquet"}
                           for e in exported],
        }],
    }
    rows = markdown_join("\n", (
        markdown("| `{split}` | {domain} | {n:,} | {size} | `{digest}` |", split=hub_split(e.split),
                 domain=a.domain, n=e.examples, size=f"{a.image_size[0]}x{a.image_size[1]}", digest=a.digest)
        for a, e in zip(stores, exported, strict=True)))
    fields = markdown_join("\n", (markdown("| `{k}` | {t} | {d} |", k=k, d=d,
                                            t=("list of " if rep else "") + t.split(":")[1])
                                   for k, (t, rep, d) in columns_of(stores[0].kind).items()))
    licence_text = ("non-commercial research use only, the licence of the authors' released data "
                    "(github.com/griffbr/ODMS)" if licence == "other" else licence)
    return markdown(CARD, header=yaml_header(header), title=title, intro=text.intro, version=__version__,
                    licence=licence_text, rows=rows, fields=fields,
                    first=hub_split(exported[0].split), reading=text.reading, bibtex=text.bibtex)


CONTEXT = {  # the JSON-LD context of Croissant 1.0
    "@language": "en", "@vocab": "https://schema.org/", "sc": "https://schema.org/",
    "cr": "http://mlcommons.org/croissant/", "rai": "http://mlcommons.org/croissant/RAI/",
    "dct": "http://purl.org/dc/terms/", "citeAs": "cr:citeAs", "column": "cr:column",
    "equivalentProperty": "cr:equivalentProperty",
    "conformsTo": "dct:conformsTo", "data": {"@id": "cr:data", "@type": "@json"},
    "dataType": {"@id": "cr:dataType", "@type": "@vocab"},
    "examples": {"@id": "cr:examples", "@type": "@json"},
    "extract": "cr:extract", "field": "cr:field", "fileProperty": "cr:fileProperty",
    "fileObject": "cr:fileObject", "fileSet": "cr:fileSet", "format": "cr:format", "includes": "cr:includes",
    "isLiveDataset": "cr:isLiveDataset", "jsonPath": "cr:jsonPath", "key": "cr:key", "md5": "cr:md5",
    "parentField": "cr:parentField", "path": "cr:path", "recordSet": "cr:recordSet",
    "references": "cr:references", "regex": "cr:regex", "repeated": "cr:repeated", "replace": "cr:replace",
    "samplingRate": "cr:samplingRate", "separator": "cr:separator", "source": "cr:source",
    "subField": "cr:subField", "transform": "cr:transform",
}


def croissant(title: str, stores: Sequence[StoreAttrs], exported: Sequence[SplitExport], licence: str,
              hashes: Mapping[str, str]) -> str:
    """Croissant 1.0 JSON-LD: the dataset, its Parquet files, and a record set over their columns."""
    text = KIND_TEXT[stores[0].kind]
    files = [{
        "@type": "cr:FileObject", "@id": f, "name": f, "contentUrl": f,
        "encodingFormat": "application/x-parquet", "sha256": hashes[f],
    } for e in exported for f in e.files]
    parquet = {"@type": "cr:FileSet", "@id": "parquet-files", "name": "parquet-files",
               "description": "every split's Parquet shards", "encodingFormat": "application/x-parquet",
               "includes": "data/*/*.parquet"}
    fields = [{
        "@type": "cr:Field", "@id": f"examples/{k}", "name": k, "description": d, "dataType": t,
        **({"repeated": True} if rep else {}),
        "source": {"fileSet": {"@id": "parquet-files"}, "extract": {"column": k}},
    } for k, (t, rep, d) in columns_of(stores[0].kind).items()]
    splits = ", ".join(f"{hub_split(e.split)} ({e.examples} examples, {a.domain})"
                       for a, e in zip(stores, exported, strict=True))
    doc = {
        "@context": CONTEXT,
        "@type": "sc:Dataset",
        "conformsTo": "http://mlcommons.org/croissant/1.0",
        "name": title,
        "description": f"{text.benchmark} examples (Griffin & Corso, {text.venue}: {text.paper}): "
                       f"{text.summary}. Splits: {splits}.",
        "license": LICENCE_URLS.get(licence, RELEASE_LICENCE["license_link"] if licence == "other"
                                    else licence),
        "url": text.url,
        "citeAs": text.bibtex,
        "version": "1.0.0",
        "keywords": list(text.keywords),
        "creator": {"@type": "sc:Organization", "name": f"odms-data {__version__}"},
        "distribution": [*files, parquet],
        "recordSet": [{"@type": "cr:RecordSet", "@id": "examples", "name": "examples",
                       "description": f"one {text.benchmark} example per record", "field": fields}],
    }
    return json.dumps(doc, indent=2) + "\n"
