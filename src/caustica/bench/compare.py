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
from .timing import timed_render

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


def reference_image(scene, size, reference_spp: int, progress: bool = True):
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
            progress: bool = True, log=print) -> CompareResult:
    """Render each technique and the reference; measure them per region."""
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
    for name in techniques:
        log(f"rendering {name} ...")
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
    gl = renderer.info()["renderer"] if renderer._device is not None else "none (CPU techniques only)"
    return CompareResult(scene.name, camera.size, spp, description, gl,
                         {k: int(v.sum()) for k, v in masks.items()}, results, reference)


def format_table(result: CompareResult) -> str:
    """The report: one block per region, one row per technique."""
    lines = [f"scene {result.scene}, {result.size[0]}x{result.size[1]}, {result.spp} spp; "
             f"reference: {result.reference}; GL: {result.renderer}"]
    header = f"{'technique':14s} {'ms':>9s} {'PSNR lin':>9s} {'PSNR sRGB':>9s} {'relMSE':>9s} {'SSIM':>6s} {'FLIP':>6s} {'angle mean/p95 (deg)':>21s}"
    for region in REGIONS:
        pixels = result.region_pixels.get(region, sum(result.region_pixels.values()))
        lines.append(f"\n[{region}] ({pixels} pixels)")
        lines.append(header)
        for r in result.results:
            m = r.metrics[region]
            angle = "-" if r.angular is None else f"{r.angular['mean_deg']:.3f}/{r.angular['p95_deg']:.3f}"
            lines.append(f"{r.technique:14s} {r.ms:9.1f} {m['psnr_linear']:9.2f} {m['psnr_srgb']:9.2f} "
                         f"{m['relmse']:9.5f} {m['ssim']:6.3f} {m['flip']:6.3f} {angle:>21s}")
    return "\n".join(lines)
