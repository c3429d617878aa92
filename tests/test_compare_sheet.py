"""``caustica compare``'s contact sheet and table: the numbers under each image, the FLIP colour bar, the
reference once, a title; table columns as wide as their content."""
from __future__ import annotations

import json

import numpy as np
import pytest

import caustica

LONG = "impostors+caustic-mapping"  # longer than the table's old 14-character column


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    """A tiny compare (32x32, two techniques), its JSON and its contact sheet written side by side."""
    pytest.importorskip("flip_evaluator", reason="the metrics extra is not installed")
    from caustica.bench.compare import compare
    from caustica.bench.sheet import compare_sheet, save_sheet

    folder = tmp_path_factory.mktemp("compare")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("CAUSTICA_CACHE", str(folder / "cache"))
        result = compare(caustica.load_scene("caustic-sphere"), ["env-map", LONG], size=(32, 32), spp=1, frames=1,
                         reference_spp=4, progress=False, log=lambda message: None)
    (folder / "c.json").write_text(json.dumps(result.to_json()))
    save_sheet(compare_sheet(result), folder / "c.png")
    return result, folder


def test_the_sheet_and_its_json_are_written_with_the_numbers(compared):
    from caustica.bench.sheet import technique_caption

    result, folder = compared
    assert (folder / "c.png").stat().st_size > 0
    data = json.loads((folder / "c.json").read_text())
    assert [t["technique"] for t in data["techniques"]] == ["env-map", LONG]
    for entry in data["techniques"]:
        whole = entry["regions"]["all"]
        caption = technique_caption(entry)
        assert f"{entry['ms_per_frame']:.1f} ms" in caption
        assert f"PSNR {float(whole['psnr_srgb']):.2f} dB" in caption and f"FLIP {float(whole['flip']):.3f}" in caption


def test_the_sheet_has_a_title_the_reference_once_and_captions(compared):
    """Title band, reference and colour bar row, then a row per technique; every text band holds text."""
    from PIL import Image

    from caustica.bench.sheet import BACKGROUND, MIN_COLUMN, compose, sheet_grid, sheet_title, technique_caption

    result, folder = compared
    sheet = np.asarray(Image.open(folder / "c.png").convert("RGB"))
    rows = [(r.technique, r.image, r.error_map) for r in result.results]
    captions = [technique_caption(r.to_json()) for r in result.results]
    places = compose(sheet_grid(rows, result.reference_image, "reference: x", captions=captions))[1]
    assert len(places) == 3 and all(len(row) == 2 for row in places)  # the reference once, then the techniques
    assert sheet.shape[1] == 2 * MIN_COLUMN and sheet.shape[0] > 3 * 32  # two columns, room for the texts
    title = sheet_title(result)
    assert result.scene in title and "32x32" in title and "1 spp" in title and result.renderer in title
    title_height = sheet.shape[0] - (np.asarray(compose(sheet_grid(rows, result.reference_image, "reference: x",
                                                                   captions=captions))[0]).shape[0])
    assert title_height > 0

    def has_text(band) -> bool:
        return band.size > 0 and bool((np.abs(band.astype(int) - BACKGROUND).sum(axis=2) > 100).any())

    assert has_text(sheet[:title_height])
    tops = [title_height + y for (_, y), _ in places]
    assert has_text(sheet[title_height:tops[0]])  # "reference: ..." and "FLIP error" above the first row
    for r in (1, 2):
        assert has_text(sheet[tops[r - 1] + 32:tops[r], :MIN_COLUMN])  # numbers under the row above, name over it
    assert has_text(sheet[tops[2] + 32:, :MIN_COLUMN])  # the last technique's numbers
    # The first row holds the reference tile and the colour bar: FLIP's colour for 1 at the top, 0 at the bottom.
    from caustica.bench.sheet import flip_colours

    bar = sheet[tops[0]:tops[0] + 32, MIN_COLUMN:]
    colours = flip_colours()
    assert (np.abs(bar.astype(int) - colours[255]).sum(axis=2) <= 3).any()
    assert (np.abs(bar.astype(int) - colours[0]).sum(axis=2) <= 3).any()


def test_the_colour_bar_is_flip_s_own_scale():
    """flip_colours()[round(255 e)] is the colour metrics.flip_map gives a pixel whose FLIP error is e."""
    pytest.importorskip("flip_evaluator", reason="the metrics extra is not installed")
    from caustica.bench.sheet import flip_colours
    from caustica.metrics import flip_error_map, flip_map

    rng = np.random.default_rng(3)
    test, reference = rng.random((24, 24, 3)), rng.random((24, 24, 3)) ** 2
    errors, colours = flip_error_map(test, reference), flip_map(test, reference)
    expected = flip_colours()[np.round(errors * 255).astype(int)].astype(int)
    assert np.abs(np.round(colours * 255).astype(int) - expected).max() <= 1


def test_table_columns_line_up_with_a_long_technique_name(compared):
    from caustica.bench.compare import TABLE_HEADER, format_table

    result, _ = compared
    blocks = format_table(result).split("\n\n")[1:]
    assert len(blocks) == 4
    for block in blocks:
        header, *lines = block.splitlines()[1:]  # after the "[region] (n pixels)" line
        # the two techniques, then the reference's noise floor (two halves of Mitsuba's 4 spp; none from exact)
        assert len(lines) == (2 if result.floor is None else 3) and lines[1].startswith(LONG + "  ")
        assert result.floor is None or lines[2].startswith("(reference floor)")
        # The names' column is as wide as the longest name; each other column ends where its header does
        # (right-aligned) and starts two spaces after the one before ends.
        ends, at = [len(LONG)], len(LONG)
        for name in TABLE_HEADER[1:]:
            at = header.index(name, at) + len(name)
            ends.append(at)
        starts = [0] + [end + 2 for end in ends[:-1]]
        for line in [header, *lines]:
            assert len(line) == ends[-1]
            assert line[:ends[0]].rstrip() in ("technique", "env-map", LONG, "(reference floor)")
            for start, end in zip(starts[1:], ends[1:]):
                cell = line[start:end]
                assert cell.strip() and not cell.endswith(" ") and line[start - 2:start] == "  "
