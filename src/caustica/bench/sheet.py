"""Contact sheets: each technique's image, its FLIP error map and the reference, labelled, in one PNG."""
from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from ..images import to_srgb8

LABEL_HEIGHT = 18


def labelled(tile: np.ndarray, label: str) -> Image.Image:
    """An 8-bit tile with its label in a strip above it."""
    h, w = tile.shape[:2]
    canvas = Image.new("RGB", (w, h + LABEL_HEIGHT), (24, 24, 24))
    canvas.paste(Image.fromarray(tile), (0, LABEL_HEIGHT))
    ImageDraw.Draw(canvas).text((4, 3), label, fill=(235, 235, 235))
    return canvas


def contact_sheet(rows: list[tuple[str, np.ndarray, np.ndarray | None]], reference: np.ndarray,
                  reference_label: str = "reference", tonemap: str = "clip") -> Image.Image:
    """Rows of (label, linear image, FLIP colour map in [0,1] or None) beside the reference; the images and the
    reference through the PNG tone curve ``tonemap`` (images.TONEMAPS), the error maps as they are."""
    tiles = []
    for label, image, error_map in rows:
        row = [labelled(to_srgb8(image, tonemap=tonemap), label)]
        if error_map is not None:
            row.append(labelled((np.clip(error_map, 0, 1) * 255 + 0.5).astype(np.uint8), f"{label}: FLIP error"))
        row.append(labelled(to_srgb8(reference, tonemap=tonemap), reference_label))
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
