"""Image output: atomic PNG writing and labelled contact sheets."""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from mimika.errors import ParameterError
from mimika.io.atomic import atomic_open

log = logging.getLogger(__name__)

SHEET_BG = (24, 26, 30)
LABEL_FG = (232, 232, 236)
TITLE_FG = (255, 255, 255)


def _as_image(img: np.ndarray | Image.Image, what: str = "image") -> Image.Image:
    if isinstance(img, Image.Image):
        return img
    a = np.asarray(img)
    if a.dtype != np.uint8:
        raise ParameterError(f"{what} has dtype {a.dtype}, expected uint8")
    if a.ndim == 2 or (a.ndim == 3 and a.shape[2] in (1, 3, 4)):
        return Image.fromarray(a[..., 0] if a.ndim == 3 and a.shape[2] == 1 else a)
    raise ParameterError(f"{what} has shape {a.shape}, expected (H, W), (H, W, 3) or (H, W, 4)")


def save_png(img: np.ndarray | Image.Image, path: str | os.PathLike) -> Path:
    """Write ``img`` (H, W[, 3|4]) uint8 to ``path`` as PNG, atomically.

    The image goes to a temporary file in the same directory, then replaces ``path``, so
    readers never see a half-written file. Parent directories are created. Returns the path.
    """
    path = Path(path)
    pil = _as_image(img)
    with atomic_open(path) as f:
        pil.save(f, format="PNG")
    log.debug("wrote %s (%dx%d)", path, *pil.size)
    return path


def _font(size: int) -> ImageFont.ImageFont | ImageFont.FreeTypeFont:
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: fixed-size bitmap font
        return ImageFont.load_default()


def _fit(draw: ImageDraw.ImageDraw, text: str, width: int, size: int):
    """A font (shrunk down to 60 % if needed) and ``text`` (ellipsised) fitting ``width``."""
    for s in range(size, max(int(size * 0.6), 8) - 1, -1):
        font = _font(s)
        if draw.textlength(text, font=font) <= width:
            return font, text
    while text and draw.textlength(text + "…", font=font) > width:
        text = text[:-1]
    return font, text + "…"


def contact_sheet(
    images: Sequence[np.ndarray],
    labels: Sequence[str],
    columns: int = 8,
    title: str | None = None,
) -> np.ndarray:
    """Tile ``images`` in a grid with each label under its tile, on a dark sheet.

    Tiles take the size of the first image (others are resized to it). Returns the sheet,
    shape (H, W, 3) uint8.
    """
    if len(images) == 0:
        raise ParameterError("contact_sheet needs at least one image")
    if len(labels) != len(images):
        raise ParameterError(f"got {len(images)} images but {len(labels)} labels")
    if int(columns) < 1:
        raise ParameterError(f"columns={columns!r} must be at least 1")
    tiles = [_as_image(im, f"images[{i}]").convert("RGB") for i, im in enumerate(images)]
    tw, th = tiles[0].size
    cols = min(int(columns), len(tiles))
    rows = math.ceil(len(tiles) / cols)
    font_size = int(np.clip(tw / 14, 13, 40))
    pad = max(4, font_size // 3)
    label_h = int(font_size * 1.5)
    title_size = int(font_size * 1.4)
    title_h = int(title_size * 1.8) if title else 0
    cell_w, cell_h = tw + pad, th + label_h + pad
    sheet = Image.new("RGB", (cols * cell_w + pad, rows * cell_h + pad + title_h), SHEET_BG)
    draw = ImageDraw.Draw(sheet)
    if title:
        font, text = _fit(draw, str(title), sheet.width - 2 * pad, title_size)
        draw.text((pad, title_h / 2), text, fill=TITLE_FG, font=font, anchor="lm")
    for i, (tile, label) in enumerate(zip(tiles, labels, strict=True)):
        r, c = divmod(i, cols)
        x, y = pad + c * cell_w, title_h + pad + r * cell_h
        if tile.size != (tw, th):
            tile = tile.resize((tw, th), Image.Resampling.LANCZOS)
        sheet.paste(tile, (x, y))
        font, text = _fit(draw, str(label), tw, font_size)
        draw.text((x + tw / 2, y + th + label_h / 2), text, fill=LABEL_FG, font=font, anchor="mm")
    return np.asarray(sheet, dtype=np.uint8).copy()
