"""``caustica compare``: every technique against ground truth on one scene, in one run.

For each technique: ms per frame (median of N after a warm-up), PSNR (linear
and sRGB), relMSE, SSIM and FLIP per region (refractor pixels, caustic region,
rest, all), and the angular error of exit directions against ``exact`` where
the technique exposes them. The reference is Mitsuba 3 (cached) when the
``reference`` extra is installed, otherwise the ``exact`` oracle (said so in
the report).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..renderer import Renderer
from ..techniques import get_technique
from .timing import steps, timed_render

REGIONS = ("all", "refractor", "caustic", "rest")
METRICS = ("psnr_linear", "psnr_srgb", "relmse", "ssim", "flip")


@dataclass
class TechniqueResult:
    technique: str
    ms: float
    metrics: dict  # region -> metric -> value
    angular: dict | None  # mean_deg, p95_deg, count, or None where no directions are exposed
    image: np.ndarray = field(repr=False, default=None)
    error_map: np.ndarray = field(repr=False, default=None)

    def to_json(self) -> dict:
        return {"technique": self.technique, "ms_per_frame": self.ms, "regions": _finite(self.metrics),
                "angular_error": _finite(self.angular)}


@dataclass
class CompareResult:
    scene: str
    size: tuple[int, int]
    spp: int
    reference: str
    renderer: str
    region_pixels: dict
    results: list[TechniqueResult]
    reference_image: np.ndarray = field(repr=False, default=None)

    def to_json(self) -> dict:
        return {"scene": self.scene, "size": list(self.size), "spp": self.spp, "reference": self.reference,
                "renderer": self.renderer, "region_pixels": self.region_pixels,
                "techniques": [r.to_json() for r in self.results]}


def _finite(value):
    """JSON has no inf/NaN: write them as strings."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def reference_image(scene, size, reference_spp: int, progress: bool | None = None):
    """(image, description): Mitsuba when installed, else the exact oracle at the same spp."""
    from ..errors import CausticaError

    try:
        from ..reference.render import reference_caveats, render_reference

        image = render_reference(scene, size=size, spp=reference_spp, progress=progress)
        caveats = "".join(f"; {c}" for c in reference_caveats(scene))
        return image, f"mitsuba ({reference_spp} spp, composite of path and ptracer{caveats})"
    except ImportError:
        pass
    except CausticaError as exc:  # the reference extra is missing
        warnings.warn(f"{exc}; comparing against 'exact' instead", stacklevel=2)
    image = Renderer(size).render(scene, "exact", spp=reference_spp)
    return image, (f"exact ({reference_spp} spp, caustics from exact photons; Mitsuba not available: no caustics "
                   "from the environment in the reference)")


def compare(scene, techniques: list[str], size=None, spp: int = 4, frames: int = 5, reference_spp: int = 256,
            progress: bool | None = None, log=print) -> CompareResult:
    """Render each technique and the reference; measure them per region. ``progress``: the reference's
    progress display (caustica.progress: None follows the policy, True always, False never)."""
    from ..metrics import angular_error, compare_images, exact_exit_directions, flip_map, region_masks

    for name in techniques:
        get_technique(name)  # fail early on an unknown name
    renderer = Renderer(size)
    camera = renderer.camera_for(scene)
    log(f"reference for {scene.name} at {camera.size[0]}x{camera.size[1]} ...")
    reference, description = reference_image(scene, camera.size, reference_spp, progress)
    masks = region_masks(scene, camera, spp=max(1, spp))
    exact_dirs = None
    results = []
    with steps(len(techniques), f"compare {scene.name}", "techniques") as bar:
        for name in techniques:
            log(f"rendering {name} ...")
            bar.set_postfix_str(name)
            image, ms = timed_render(renderer, scene, name, spp, frames)
            metrics = compare_images(image, reference, masks)
            angular = None
            if get_technique(name).uses_gl:
                directions = renderer.exit_directions(scene, name)
                if directions is not None:
                    if exact_dirs is None:
                        exact_dirs = exact_exit_directions(scene, camera)
                    dirs, valid = directions
                    angular = angular_error(dirs, exact_dirs[0], valid & exact_dirs[1])
            elif name == "exact":
                angular = {"mean_deg": 0.0, "p95_deg": 0.0, "count": int(masks["refractor"].sum())}
            results.append(TechniqueResult(name, ms, metrics, angular, image, flip_map(image, reference)))
            bar.update()
    gl = renderer.info()["renderer"] if renderer._device is not None else "none (CPU techniques only)"
    return CompareResult(scene.name, camera.size, spp, description, gl,
                         {k: int(v.sum()) for k, v in masks.items()}, results, reference)


TABLE_HEADER = ("technique", "ms", "PSNR lin", "PSNR sRGB", "relMSE", "SSIM", "FLIP", "angle mean/p95 (deg)")


def table_cells(r: TechniqueResult, region: str) -> list[str]:
    """One technique's row of the report in ``region``, as the cells under TABLE_HEADER."""
    m = r.metrics[region]
    angle = "-" if r.angular is None else f"{r.angular['mean_deg']:.3f}/{r.angular['p95_deg']:.3f}"
    return [r.technique, f"{r.ms:.1f}", f"{m['psnr_linear']:.2f}", f"{m['psnr_srgb']:.2f}", f"{m['relmse']:.5f}",
            f"{m['ssim']:.3f}", f"{m['flip']:.3f}", angle]


def column_widths(rows: list[list[str]]) -> list[int]:
    """The widest cell of each column."""
    return [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]


def aligned(rows: list[list[str]], widths: list[int] | None = None) -> list[str]:
    """Rows of cells as lines, each column ``widths`` wide (default: its widest cell here): the first
    left-aligned, the others right-aligned, two spaces apart, so a column starts at the same place on every line."""
    widths = widths or column_widths(rows)
    return ["  ".join(cell.ljust(w) if i == 0 else cell.rjust(w) for i, (cell, w) in enumerate(zip(row, widths)))
            for row in rows]


def format_table(result: CompareResult) -> str:
    """The report: one block per region, one row per technique; the columns as wide as their content in
    every block, so long technique names keep them aligned."""
    blocks = {region: [list(TABLE_HEADER), *(table_cells(r, region) for r in result.results)] for region in REGIONS}
    widths = column_widths([row for block in blocks.values() for row in block])
    lines = [f"scene {result.scene}, {result.size[0]}x{result.size[1]}, {result.spp} spp; "
             f"reference: {result.reference}; GL: {result.renderer}"]
    for region, block in blocks.items():
        pixels = result.region_pixels.get(region, sum(result.region_pixels.values()))
        lines += [f"\n[{region}] ({pixels} pixels)", *aligned(block, widths)]
    return "\n".join(lines)
