"""Contact sheets: a title, the reference and the FLIP colour bar once, then each technique's image with its
numbers under it beside its FLIP error map, in one PNG.

Every text is wrapped to the width it has (a tile, or the sheet for the title), so no label is cut at any
image size; the bands that hold it grow instead.
"""
from __future__ import annotations

import functools

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..images import to_srgb8

BACKGROUND = (24, 24, 24)
TEXT = (235, 235, 235)
PAD = 3  # pixels around a text band's lines
MIN_COLUMN = 128  # pixels: a column is at least this wide, so that its texts have room beside small tiles
FONT_SIZE = 12  # pixels, of Pillow's own font


@functools.lru_cache(maxsize=1)
def _font():
    try:
        return ImageFont.load_default(size=FONT_SIZE)
    except TypeError:  # Pillow before 10.1: its one bitmap font
        return ImageFont.load_default()


def line_height() -> int:
    """Pixels between two lines of the sheet's font."""
    return _font().getbbox("Ag|")[3] + 2


def wrap(text: str, width: int, separators=("  ", " ", "")) -> list[str]:
    """``text`` as lines at most ``width`` pixels wide in the sheet's font. Its fields (two spaces apart) are
    kept whole where they fit, else broken at spaces, and a word longer than a line where it must be."""
    separator, finer = separators[0], separators[1:]
    pieces = [p.strip() for p in text.split(separator)] if separator else list(text)
    lines: list[str] = []
    for piece in filter(None, pieces):
        if lines and _font().getlength(lines[-1] + separator + piece) <= width:
            lines[-1] += separator + piece
        elif _font().getlength(piece) <= width or not finer:
            lines.append(piece)
        else:
            lines += wrap(piece, width, finer)
    return lines


def text_band(text: str, width: int) -> Image.Image | None:
    """``text`` wrapped into a band ``width`` wide (None for no text)."""
    lines = wrap(text, max(1, width - 2 * PAD))
    if not lines:
        return None
    band = Image.new("RGB", (width, len(lines) * line_height() + 2 * PAD), BACKGROUND)
    draw = ImageDraw.Draw(band)
    for i, line in enumerate(lines):
        draw.text((PAD, PAD + i * line_height()), line, fill=TEXT, font=_font())
    return band


@functools.lru_cache(maxsize=1)
def flip_colours() -> np.ndarray:
    """(256, 3) uint8: the colour FLIP's error maps (metrics.flip_map) give an error of i / 255, read back from
    FLIP itself on ramps of known error (black to white, green to blue); any entry missed is interpolated."""
    from ..images import srgb_to_linear
    from ..metrics import flip_error_map, flip_map

    found = {0: flip_map(np.zeros((8, 8, 3)), np.zeros((8, 8, 3)))[4, 4]}  # no error
    t = np.linspace(0.0, 1.0, 1024)[None, :, None]
    for start, end in (((0, 0, 0), (1, 1, 1)), ((0, 1, 0), (0, 0, 1))):  # display values: errors up to ~1
        start, end = np.asarray(start, float), np.asarray(end, float)
        reference = srgb_to_linear(np.broadcast_to(start, (8, t.shape[1], 3)))
        test = srgb_to_linear(np.broadcast_to(start * (1 - t) + end * t, reference.shape))
        errors, colours = flip_error_map(test, reference)[4], flip_map(test, reference)[4]
        found.update(zip(np.round(errors * 255).astype(int).tolist(), colours))
    known = np.array(sorted(found))
    table = np.array([found[i] for i in known])
    filled = np.stack([np.interp(np.arange(256), known, table[:, c]) for c in range(3)], axis=1)
    return (filled * 255 + 0.5).astype(np.uint8)


def colour_bar(width: int, height: int) -> Image.Image:
    """A tile explaining the FLIP error maps: their colour scale from 0 (bottom) to 1 (top), marked."""
    tile = Image.new("RGB", (width, height), BACKGROUND)
    top, bottom = int(0.08 * height), int(0.92 * height) - 1
    left, right = int(0.2 * width), max(int(0.2 * width) + 1, int(0.4 * width))
    values = np.linspace(1.0, 0.0, bottom - top + 1)
    strip = flip_colours()[np.round(values * 255).astype(int)]
    tile.paste(Image.fromarray(np.repeat(strip[:, None], right - left, axis=1)), (left, top))
    draw = ImageDraw.Draw(tile)
    marks = ((1.0, "1"), (0.5, "0.5"), (0.0, "0")) if height >= 4 * line_height() else ((1.0, "1"), (0.0, "0"))
    for value, label in marks:
        y = round(bottom - value * (bottom - top))
        draw.line([(right, y), (right + 3, y)], fill=TEXT)
        draw.text((right + 5, min(max(0, y - line_height() // 2), height - line_height())), label, fill=TEXT,
                  font=_font())
    return tile


def compose(grid, title: str | None = None) -> tuple[Image.Image, list[list[tuple[int, int]]]]:
    """The sheet of ``grid`` (rows of (tile or None, text above, text below) cells, tiles all one height) under
    ``title``, in columns as wide as the widest tile and MIN_COLUMN; and where each cell's tile went (x, y of
    its top left) for tests and tools."""
    tiles = [tile for row in grid for tile, _, _ in row if tile is not None]
    width, height = max(MIN_COLUMN, *(tile.size[0] for tile in tiles)), max(tile.size[1] for tile in tiles)
    columns = max(len(row) for row in grid)
    cells = [[(tile, text_band(above, width), text_band(below, width)) for tile, above, below in row] for row in grid]
    heading = text_band(title, columns * width) if title else None
    rows_height = []
    for row in cells:
        above = max((a.size[1] for _, a, _ in row if a is not None), default=0)
        below = max((b.size[1] for _, _, b in row if b is not None), default=0)
        rows_height.append((above, below))
    total = (heading.size[1] if heading else 0) + sum(a + height + b for a, b in rows_height)
    sheet = Image.new("RGB", (columns * width, total), BACKGROUND)
    y = 0
    if heading is not None:
        sheet.paste(heading, (0, 0))
        y = heading.size[1]
    places = []
    for row, (above, below) in zip(cells, rows_height):
        places.append([])
        for c, (tile, top, bottom) in enumerate(row):
            x = c * width
            if top is not None:
                sheet.paste(top, (x, y + above - top.size[1]))
            if tile is not None:
                sheet.paste(tile, (x, y + above))
            if bottom is not None:
                sheet.paste(bottom, (x, y + above + height))
            places[-1].append((x, y + above))
        y += above + height + below
    return sheet, places


def sheet_grid(rows: list[tuple[str, np.ndarray, np.ndarray | None]], reference: np.ndarray,
               reference_label: str = "reference", tonemap: str = "clip", captions: list[str] | None = None):
    """compose's grid of a contact sheet: the reference beside the FLIP colour bar, then one row per (label,
    linear image, FLIP colour map in [0,1] or None) with ``captions[i]`` (its numbers) under the image. The
    images and the reference go through the PNG tone curve ``tonemap`` (images.TONEMAPS), the maps as they are."""
    reference_tile = Image.fromarray(to_srgb8(reference, tonemap=tonemap))
    bar = colour_bar(max(MIN_COLUMN, reference_tile.size[0]), reference_tile.size[1])
    grid = [[(reference_tile, reference_label, ""), (bar, "FLIP error", "")]]
    for i, (label, image, error_map) in enumerate(rows):
        error_tile = (None if error_map is None
                      else Image.fromarray((np.clip(error_map, 0, 1) * 255 + 0.5).astype(np.uint8)))
        grid.append([(Image.fromarray(to_srgb8(image, tonemap=tonemap)), label, captions[i] if captions else ""),
                     (error_tile, "FLIP error" if error_tile is not None else "", "")])
    return grid


def contact_sheet(rows: list[tuple[str, np.ndarray, np.ndarray | None]], reference: np.ndarray,
                  reference_label: str = "reference", tonemap: str = "clip", title: str | None = None,
                  captions: list[str] | None = None) -> Image.Image:
    """The sheet of :func:`sheet_grid` under ``title``: the reference once, each row's image and FLIP map."""
    return compose(sheet_grid(rows, reference, reference_label, tonemap, captions), title)[0]


def technique_caption(entry: dict) -> str:
    """A technique's numbers under its image, from its compare JSON (TechniqueResult.to_json()): ms per frame,
    and over the whole image PSNR (sRGB; marked * within 3 dB of the reference's noise floor) and mean FLIP."""
    whole = entry["regions"]["all"]
    mark = "*" if "psnr_srgb" in entry.get("at_reference_floor", {}).get("all", ()) else ""
    return (f"{entry['ms_per_frame']:.1f} ms  PSNR {float(whole['psnr_srgb']):.2f} dB{mark}  "
            f"FLIP {float(whole['flip']):.3f}")


def reference_name(result) -> str:
    """The reference of a CompareResult without its caveats (``mitsuba (256 spp, ...)`` -> ``mitsuba``)."""
    return result.reference.split(" (")[0]


def sheet_title(result) -> str:
    """The sheet's title from a CompareResult: scene, size, spp, GL renderer, the reference and its noise
    floor (the whole image's sRGB PSNR a perfect technique would score against it)."""
    floor = ("  noise floor not measured" if result.floor is None else
             f" at {result.floor.spp} spp  noise floor {result.floor.whole_srgb():.2f} dB (* within 3 dB of it)")
    return (f"{result.scene}  {result.size[0]}x{result.size[1]}  {result.spp} spp  GL: {result.renderer}  "
            f"reference: {reference_name(result)}{floor}")


def compare_sheet(result, tonemap: str = "clip") -> Image.Image:
    """The contact sheet of a compare run (bench.compare.CompareResult): its title, the reference once, and each
    technique's image, numbers (technique_caption of its JSON) and FLIP error map."""
    rows = [(r.technique, r.image, r.error_map) for r in result.results]
    return contact_sheet(rows, result.reference_image, f"reference: {reference_name(result)}", tonemap,
                         sheet_title(result), [technique_caption(r.to_json()) for r in result.results])


def save_sheet(sheet: Image.Image, path) -> None:
    """Write atomically (temp file, then rename) so no half-written PNG remains."""
    from ..atomic import write_atomic

    write_atomic(path, lambda tmp: sheet.save(tmp, format="PNG"))
