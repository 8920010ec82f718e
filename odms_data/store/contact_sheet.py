"""Contact sheets: one example's masks in a grid, with z and depth under each."""

from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw

from .reader import Example

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
