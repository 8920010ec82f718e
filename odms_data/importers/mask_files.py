"""Mask image files (PNG or JPEG) read into binary masks, with one-line errors naming the file.

A file is checked before it is decoded (PNG: signature, chunk CRCs, IHDR, IEND; JPEG: start and
end markers, and its header as Pillow reads it without decoding), so a truncated or corrupt file is
reported as such rather than decoded to garbage, and the size its header declares is bounded
(`MAX_PIXELS`, `MAX_FILE_BYTES`, and the size the other masks have) before anything is decoded.
Binarisation: a mask whose pixels take at most two values, one of them 0, is binary and
everything nonzero is object (0/1 and 0/255 PNGs, 1-bit PNGs); any other mask (JPEG, anti-aliased)
is thresholded, pixels >= `threshold` being object. A colour mask is read as grey; a PNG with
transparency is read from its alpha channel when the object is drawn there (`_rgba_mask`).
"""

from __future__ import annotations

import io
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from PIL.JpegImagePlugin import JpegImageFile

from ..errors import InputError
from ..inputs import read_input
from .plan import DEFAULT_THRESHOLD

MASK_SUFFIXES = (".png", ".jpg", ".jpeg")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# 4096 x 4096: above a 4K video frame, and a decoded 16-bit RGBA image of it is 128 MiB
MAX_PIXELS = 1 << 24
MAX_FILE_BYTES = 1 << 28  # 256 MiB: more than any image of MAX_PIXELS compresses to
PNG_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}  # by colour type


def is_mask_file(path: Path) -> bool:
    return path.suffix.lower() in MASK_SUFFIXES and not path.name.startswith(".")


def _check_png(path: Path, data: bytes) -> tuple[int, int]:
    """(height, width) of a structurally sound PNG; InputError naming what is wrong otherwise."""
    if not data.startswith(PNG_SIGNATURE):
        raise InputError(f"{path}: not a PNG file (bad signature)")
    pos, size, seen_end = 8, None, False
    while pos < len(data):
        if pos + 12 > len(data):
            raise InputError(f"{path}: truncated PNG (chunk header cut off at byte {pos})")
        length, kind = struct.unpack(">I4s", data[pos : pos + 8])
        end = pos + 12 + length
        if end > len(data):
            raise InputError(f"{path}: truncated PNG ({kind.decode('latin-1')} chunk cut off)")
        body = data[pos + 8 : end - 4]
        if zlib.crc32(kind + body) != struct.unpack(">I", data[end - 4 : end])[0]:
            raise InputError(f"{path}: corrupt PNG (CRC error in {kind.decode('latin-1')} chunk)")
        if kind == b"IHDR":
            size = _png_size(path, body)
        if kind == b"IEND":
            seen_end = True
            break
        pos = end
    if size is None:
        raise InputError(f"{path}: corrupt PNG (no IHDR chunk)")
    if not seen_end:
        raise InputError(f"{path}: truncated PNG (no IEND chunk)")
    return size


def _png_size(path: Path, ihdr: bytes) -> tuple[int, int]:
    """(height, width) of an IHDR chunk that libpng would accept; InputError otherwise."""
    if len(ihdr) != 13:
        raise InputError(f"{path}: corrupt PNG (IHDR chunk of {len(ihdr)} bytes, not 13)")
    width, height, depth, colour = struct.unpack(">IIBB", ihdr[:10])
    if not (0 < width < 1 << 31 and 0 < height < 1 << 31) or depth not in PNG_DEPTHS.get(colour, ()):
        raise InputError(f"{path}: corrupt PNG (IHDR declares {width}x{height} pixels, bit depth {depth}, "
                         f"colour type {colour})")
    return height, width


def _check_jpeg(path: Path, data: bytes) -> tuple[int, int]:
    """(height, width) of a JPEG whose markers and header are sound; InputError otherwise."""
    if not data.startswith(b"\xff\xd8"):
        raise InputError(f"{path}: not a JPEG file (bad start marker)")
    if not data.rstrip(b"\0").endswith(b"\xff\xd9"):
        raise InputError(f"{path}: truncated JPEG (no end-of-image marker)")
    try:  # Pillow's JPEG reader reads the header only; MAX_PIXELS bounds what it declares (_size),
        # so Pillow's own bound, which warns, is not asked (Image.open would)
        with JpegImageFile(io.BytesIO(data)) as im:
            width, height = im.size
    except (OSError, SyntaxError, ValueError) as e:
        raise InputError(f"{path}: corrupt JPEG header ({' '.join(str(e).split())})") from None
    return height, width


def _size(path: Path, data: bytes, expect: tuple[int, int] | None) -> tuple[int, int]:
    """(height, width) the header of a sound mask file declares, once it is `expect` (when given)
    and at most MAX_PIXELS."""
    h, w = _check_png(path, data) if path.suffix.lower() == ".png" else _check_jpeg(path, data)
    if expect is not None and (h, w) != tuple(expect):
        raise InputError(f"{path}: image size {h}x{w} differs from the {expect[0]}x{expect[1]} "
                         "(height x width) of the other images")
    if h * w > MAX_PIXELS:
        raise InputError(f"{path}: image of {h}x{w} pixels (height x width) is larger than the "
                         f"{MAX_PIXELS} pixels a mask may have")
    return h, w


def _checked(path: Path, expect: tuple[int, int] | None) -> bytes:
    """The bytes of the mask file at `path`, once `_size` accepts its header."""
    data = _read(path)
    _size(path, data, expect)
    return data


def image_size(path: Path) -> tuple[int, int]:
    """(height, width) of a mask file from its header, without decoding it (see `_size`)."""
    return _size(path, _read(path), None)


def _read(path: Path) -> bytes:
    """The file's bytes, refused before they are read when it declares more than MAX_FILE_BYTES."""
    return read_input(path, "a mask file", MAX_FILE_BYTES)


def read_png(path: Path, expect: tuple[int, int] | None = None) -> np.ndarray:
    """The PNG at `path` as stored (bit depth and channels kept, colour in OpenCV's BGR order),
    checked (and its size bounded, see `_checked`) before it is decoded."""
    return _decode(path, _checked(path, expect), cv2.IMREAD_UNCHANGED)


def _decode(path: Path, data: bytes, flag: int) -> np.ndarray:
    try:
        img = cv2.imdecode(np.frombuffer(data, np.uint8), flag)
    except cv2.error as e:
        reason = " ".join(str(getattr(e, "err", "") or e).split())  # OpenCV's own message is many lines
        raise InputError(f"{path}: cannot be decoded as an image ({reason})") from None
    if img is None:
        raise InputError(f"{path}: cannot be decoded as an image")
    return img


def read_mask(
    path: Path, threshold: int = DEFAULT_THRESHOLD, expect: tuple[int, int] | None = None
) -> np.ndarray:
    """(H, W) bool mask of the file at `path`, True = object; `expect` as in `read_png`."""
    if path.suffix.lower() == ".png":  # keeps the bit depth: a 16-bit 0/1 label image is not empty
        img = read_png(path, expect)
    else:
        img = _decode(path, _checked(path, expect), cv2.IMREAD_GRAYSCALE)
    if img.ndim == 3 and img.shape[2] == 4:
        return _rgba_mask(path, img, threshold)
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    return binarize(img, threshold)


def _rgba_mask(path: Path, img: np.ndarray, threshold: int) -> np.ndarray:
    """The mask of a PNG with transparency: its colour when the alpha channel is uniform, its alpha
    when the colour is uniform (the object drawn in transparency only), and either when both draw
    the same mask; InputError when colour and alpha draw different masks."""
    colour, alpha = img[:, :, :3], np.ascontiguousarray(img[:, :, 3])
    by_colour = binarize(cv2.cvtColor(colour, cv2.COLOR_BGR2GRAY), threshold)
    if alpha.min() == alpha.max():
        return by_colour
    by_alpha = binarize(alpha, threshold)
    if (colour == colour[0, 0]).all() or np.array_equal(by_colour, by_alpha):
        return by_alpha
    raise InputError(f"{path}: its colour and its alpha channel (transparency) draw different masks; "
                     "save the mask as a grayscale PNG, or make one of them uniform")


@dataclass(frozen=True)
class MaskFile:
    """A mask image file as a `MaskSource`."""

    path: Path

    @property
    def name(self) -> str:
        return self.path.name

    def __str__(self) -> str:
        return str(self.path)

    def size(self) -> tuple[int, int]:
        return image_size(self.path)

    def read(self, threshold: int, expect: tuple[int, int] | None = None) -> np.ndarray:
        return read_mask(self.path, threshold, expect)


def binarize(img: np.ndarray, threshold: int = DEFAULT_THRESHOLD) -> np.ndarray:
    """Binary rule for two-valued masks with 0, threshold for the rest (see the module doc).

    `threshold` is on the 8-bit scale; for 16-bit images it is scaled by 257.
    """
    threshold *= 257 if img.dtype == np.uint16 else 1
    mask = img >= threshold
    if mask.any():  # then max >= threshold, where both rules agree on {0, max} masks
        return mask
    lo, hi = cv2.minMaxLoc(img)[:2]
    at_max = cv2.compare(img, hi, cv2.CMP_EQ)  # type: ignore[call-overload]  # the stubs omit scalars
    if lo == 0 and hi > 0 and cv2.countNonZero(img) == cv2.countNonZero(at_max):
        return img != 0
    return mask
