"""Contact sheets: one example's masks in a grid, with z and depth under each."""

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


def contact_sheet(example: Example, columns: int = COLUMNS) -> Image.Image:
    """A grid image of the example's masks, each captioned with its index, z and depth."""
    n, H, W = example.masks.shape
    tw = THUMB_WIDTH
    th = max(1, round(H * tw / W))
    cols = min(columns, n)
    rows = math.ceil(n / cols)
    title = 24
    sheet = Image.new("L", (cols * (tw + 4) + 4, title + rows * (th + CAPTION) + 4), 64)
    draw = ImageDraw.Draw(sheet)
    d1 = "unlabelled" if math.isnan(example.d1) else f"d1 = {example.d1:.4f} m"
    draw.text((6, 6), f"{example.example_id}   n = {n}   {d1}", fill=255)
    for i in range(n):
        r, c = divmod(i, cols)
        x, y = 4 + c * (tw + 4), title + r * (th + CAPTION)
        mask = Image.fromarray(example.masks[i].astype(np.uint8) * 255)
        thumb = mask.resize((tw, th), Image.Resampling.BILINEAR)
        sheet.paste(thumb, (x, y))
        depth = "depth ?" if math.isnan(example.depth[i]) else f"depth {example.depth[i]:.3f} m"
        draw.text((x + 2, y + th + 4), f"#{i + 1}  z {example.z[i]:.4f} m  {depth}", fill=255)
    return sheet


def image_format(path: str | os.PathLike, option: str = "-o") -> str:
    """The format Pillow writes for `path`'s suffix; InputError when it has none Pillow writes."""
    Image.init()
    writable = {ext: fmt for ext, fmt in Image.registered_extensions().items() if fmt in Image.SAVE}
    suffix = Path(path).suffix.lower()
    if suffix not in writable:
        what = f"suffix {suffix} is not an image format Pillow writes" if suffix else "has no suffix"
        raise InputError(f"{option} {path}: {what}; name it e.g. sheet.png")
    return writable[suffix]


def save_image(image: Image.Image, path: str | os.PathLike, *, overwrite: bool = False,
               option: str = "-o") -> None:
    """Write `image` to `path` in the format of its suffix, as every output is (outputs.atomic_file)."""
    fmt = image_format(path, option)
    with atomic_file(path, overwrite=overwrite, option=option) as partial:
        try:
            image.save(partial, format=fmt)
        except (ValueError, KeyError) as e:
            raise InputError(f"{option} {path}: Pillow cannot write this image as {fmt} ({e})") from None
