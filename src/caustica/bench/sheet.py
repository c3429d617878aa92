"""Contact sheets: each technique's image, its FLIP error map and the reference, labelled, in one PNG."""
from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from ..images import linear_to_srgb

LABEL_HEIGHT = 18


def to_rgb8(image: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear float image -> 8-bit sRGB."""
    encoded = linear_to_srgb(np.clip(image * 2.0**exposure, 0.0, 1.0))
    return (encoded * 255.0 + 0.5).astype(np.uint8)


def labelled(tile: np.ndarray, label: str) -> Image.Image:
    """An 8-bit tile with its label in a strip above it."""
    h, w = tile.shape[:2]
    canvas = Image.new("RGB", (w, h + LABEL_HEIGHT), (24, 24, 24))
    canvas.paste(Image.fromarray(tile), (0, LABEL_HEIGHT))
    ImageDraw.Draw(canvas).text((4, 3), label, fill=(235, 235, 235))
    return canvas


def contact_sheet(rows: list[tuple[str, np.ndarray, np.ndarray | None]], reference: np.ndarray,
                  reference_label: str = "reference") -> Image.Image:
    """Rows of (label, linear image, FLIP colour map in [0,1] or None) beside the reference."""
    tiles = []
    for label, image, error_map in rows:
        row = [labelled(to_rgb8(image), label)]
        if error_map is not None:
            row.append(labelled((np.clip(error_map, 0, 1) * 255 + 0.5).astype(np.uint8), f"{label}: FLIP error"))
        row.append(labelled(to_rgb8(reference), reference_label))
        tiles.append(row)
    tile_w, tile_h = tiles[0][0].size
    columns = max(len(r) for r in tiles)
    sheet = Image.new("RGB", (columns * tile_w, len(tiles) * tile_h), (0, 0, 0))
    for r, row in enumerate(tiles):
        for c, tile in enumerate(row):
            sheet.paste(tile, ((c if c < len(row) - 1 else columns - 1) * tile_w, r * tile_h))
    return sheet


def save_sheet(sheet: Image.Image, path) -> None:
    """Write atomically (temp file, then rename) so no half-written PNG remains."""
    from ..atomic import write_atomic

    write_atomic(path, lambda tmp: sheet.save(tmp, format="PNG"))
