"""Contact sheets: one example's masks (or boxes) in a grid, with z and depth under each."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from ..errors import InputError
from ..outputs import atomic_file
from ..store.reader import Example

THUMB_WIDTH = 240
CAPTION = 30
COLUMNS = 5
CROP_MARGIN = 0.25  # of the object's extent, on each side, kept around it by --crop
CROP_LEAST = 16  # px: the least side of a crop


def object_box(masks: np.ndarray) -> tuple[int, int, int, int] | None:
    """(top, bottom, left, right), bottom and right excluded, of the pixels set in any of the masks,
    with a margin, at least CROP_LEAST a side, inside the image; None when every mask is empty."""
    _, H, W = masks.shape
    rows, cols = np.flatnonzero(masks.any(axis=(0, 2))), np.flatnonzero(masks.any(axis=(0, 1)))
    if not rows.size:
        return None
    box = []
    for lo, hi, size in ((rows[0], rows[-1] + 1, H), (cols[0], cols[-1] + 1, W)):
        pad = max(int(CROP_MARGIN * (hi - lo)), (CROP_LEAST - (hi - lo) + 1) // 2, 0)
        box += [max(0, lo - pad), min(size, hi + pad)]
    return box[0], box[1], box[2], box[3]


def contact_sheet(example: Example, columns: int = COLUMNS, crop: bool = False) -> Image.Image:
    """A grid image of the example's masks, each captioned with its index, z and depth; `crop`:
    every mask cut to the box around the object in all of them (a 10-pixel object fills the
    thumbnail, pixels drawn as squares). An example of boxes draws each box's outline on a black
    frame of the image's shape (`crop` does not apply)."""
    masks = example.masks if example.boxes is None else np.zeros((example.n, *example.masks.shape[1:]), bool)
    crop = crop and example.boxes is None
    box = object_box(masks) if crop else None
    if box is not None:
        masks = masks[:, box[0]:box[1], box[2]:box[3]]
    n, H, W = masks.shape
    tw = THUMB_WIDTH
    th = max(1, round(H * tw / W))
    cols = min(columns, n)
    rows = math.ceil(n / cols)
    title = 24
    sheet = Image.new("L", (cols * (tw + 4) + 4, title + rows * (th + CAPTION) + 4), 64)
    draw = ImageDraw.Draw(sheet)
    d1 = "unlabelled" if math.isnan(example.d1) else f"d1 = {example.d1:.4f} m"
    where = ""
    if crop:
        where = (f"   rows {box[0]}..{box[1] - 1}, columns {box[2]}..{box[3] - 1}" if box
                 else "   (every mask is empty: nothing to crop to)")
    draw.text((6, 6), f"{example.example_id}   n = {n}   {d1}{where}", fill=255)
    for i in range(n):
        r, c = divmod(i, cols)
        x, y = 4 + c * (tw + 4), title + r * (th + CAPTION)
        mask = Image.fromarray(masks[i].astype(np.uint8) * 255)
        thumb = mask.resize((tw, th), Image.Resampling.NEAREST if W < tw else Image.Resampling.BILINEAR)
        sheet.paste(thumb, (x, y))
        mark = ""
        if example.boxes is not None and example.boxes[i, 2] != 0:  # width 0: a missed detection
            mark = _draw_box(draw, example.boxes[i], x, y, tw, th)
        depth = "depth ?" if math.isnan(example.depth[i]) else f"depth {example.depth[i]:.3f} m"
        draw.text((x + 2, y + th + 4), f"#{i + 1}  z {example.z[i]:.4f} m  {depth}{mark}", fill=255)
    return sheet


def _draw_box(draw: ImageDraw.ImageDraw, box: np.ndarray, x: int, y: int, tw: int, th: int) -> str:
    """Outline `box` (centre x, y, width, height, as fractions of the image) in the thumbnail at
    (x, y); returns what marks it in the caption. A negative width or height (ODMD's perturbed
    detections have them) is drawn as its mirror, in grey; corners far outside are clipped."""
    xc, yc, w, h = (float(v) for v in box)
    flipped = w < 0 or h < 0
    lo, hi = -1.0, 2.0  # in image fractions: enough to show that a box reaches past the edge
    left, right = sorted(min(hi, max(lo, v)) for v in (xc - w / 2, xc + w / 2))
    top, bottom = sorted(min(hi, max(lo, v)) for v in (yc - h / 2, yc + h / 2))
    draw.rectangle([x + left * tw, y + top * th, x + right * tw, y + bottom * th],
                   outline=128 if flipped else 255)
    return "  (negative size)" if flipped else ""


def image_format(path: str | os.PathLike, option: str = "output") -> str:
    """The format Pillow writes for `path`'s suffix; InputError when it has none Pillow writes."""
    Image.init()
    writable = {ext: fmt for ext, fmt in Image.registered_extensions().items() if fmt in Image.SAVE}
    suffix = Path(path).suffix.lower()
    if suffix not in writable:
        what = f"suffix {suffix} is not an image format Pillow writes" if suffix else "has no suffix"
        raise InputError(f"{option} {path}: {what}; name it e.g. sheet.png", option=option)
    return writable[suffix]


def save_image(image: Image.Image, path: str | os.PathLike, *, overwrite: bool = False,
               option: str = "output") -> None:
    """Write `image` to `path` in the format of its suffix, as every output is (outputs.atomic_file)."""
    fmt = image_format(path, option)
    with atomic_file(path, overwrite=overwrite, option=option) as partial:
        try:
            image.save(partial, format=fmt)
        except (ValueError, KeyError) as e:
            raise InputError(f"{option} {path}: Pillow cannot write this image as {fmt} ({e})",
                             option=option) from None
