"""Benchmark: adaptive caustic maps (``caustic-mapping``'s ``adaptive_levels``, Wyman and Nichols 2009)
against the regular photon grid, on bench_exact_caustics' ball and clear bunny over a floor.

For each scene: the Mitsuba composite reference (``--reference-spp`` spp, ``--seeds`` seeds averaged, as
bench_exact_caustics; cached on disk), then for regular grids and adaptive levels: the caustic-region
relMSE and PSNR, the live photons (CountPhotons: traced and splatted; adaptive ones split into the
finest cells of their blocks for the splat), and ms per frame twice: with the caustic map rebuilt
every frame (the light's intensity nudged by 1e-6 between frames, so the cached chain reruns) and cached,
best of 3 after a warm-up, wall clock (the image read back), each as a ratio to ``plain``'s at the same size and
spp measured the same way (rebuilt: its shadow maps too). ``--closeup`` adds a 256x192 camera over each caustic
(:func:`closeup`), where the image resolves the caustic's detail that 128x96 of the whole scene does not.

    .venv/bin/python bench/bench_adaptive_caustics.py [--size 128x96] [--reference-spp 1024] [--seeds 2] [--closeup]
"""
from __future__ import annotations

import sys
import time

import numpy as np

from bench_exact_caustics import print_table, reference_arguments, scenes
from caustica.metrics.images import psnr_linear, relmse
from caustica.metrics.regions import caustic_region
from caustica.reference.render import render_reference
from caustica.renderer import Renderer
from caustica.scene import Camera

TECHNIQUE = "depth-search+caustic-mapping"
# (label, parameters): regular grids at three budgets, then the adaptive levels over the default finest grid.
CONFIGS = [("grid 128", {"photon_grid": 128}), ("grid 256", {"photon_grid": 256}), ("grid 512 (default)", {}),
           *[(f"adaptive {levels}", {"adaptive_levels": levels}) for levels in (1, 2, 3)],
           ("adaptive 3, threshold 2", {"adaptive_levels": 3, "adaptive_threshold": 2.0})]


def frame_ms(renderer: Renderer, scene, technique: str, spp: int, rebuild: bool, **params) -> tuple[float, object]:
    """Best of 3 frames after a warm-up (ms) and the last image; ``rebuild``: the light's intensity nudged
    by a relative 1e-6 before each frame, so the cached caustic chain reruns."""
    light = scene.lights[0]
    base = np.array(light.intensity, np.float64)
    times, image = [], None
    for k in range(4):
        if rebuild:
            light.intensity = list(base * (1.0 + 1e-6 * (k % 2)))
        start = time.perf_counter()
        image = renderer.render(scene, technique, spp, **params)
        times.append((time.perf_counter() - start) * 1000.0)
    light.intensity = list(base)
    return min(times[1:]), image


def closeup(scene, size):
    """The scene seen by a camera over the glass object's caustic on the floor (y = 0): the ray from the light
    through the object's box centre meets the floor at the centre of the view, and the view holds the
    object's shadow (its half size scaled from the light), at 40 degrees from the vertical on the side away
    from the light (the object stands behind its caustic)."""
    glass = next(o for o in scene.objects if o.material.kind == "glass")
    lo, hi = glass.world_mesh().bounds
    light = np.asarray(scene.lights[0].position, np.float64)
    middle = 0.5 * (lo + hi)
    reach = light[1] / (light[1] - middle[1])
    centre = light + (middle - light) * reach
    radius = 0.5 * float((hi - lo)[[0, 2]].max()) * reach
    away = np.array([centre[0] - light[0], 0.0, centre[2] - light[2]])
    away /= max(np.linalg.norm(away), 1e-9)
    direction = np.cos(np.radians(40.0)) * np.array([0.0, 1.0, 0.0]) + np.sin(np.radians(40.0)) * away
    camera = Camera(position=centre + 4.0 * radius * direction, look_at=centre, fov_y=30.0, size=size)
    return scene.with_camera(camera)


def main(argv=None) -> None:
    parser = reference_arguments(__doc__.splitlines()[0], seeds=2)
    parser.add_argument("--closeup", action="store_true", help="also a 256x192 camera over each caustic (closeup)")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    rows, gl = [], ""
    views = [("view", scene) for scene in scenes(size)]
    if args.closeup:
        views += [("close-up", closeup(scene, (256, 192))) for scene in scenes(size)]
    for view, scene in views:
        reference = np.mean([render_reference(scene, spp=args.reference_spp, progress=False, seed=k)
                             for k in range(args.seeds)], axis=0)
        caustic = caustic_region(scene)
        with Renderer(scene.camera.size, keep_channels=True) as renderer:
            gl = renderer.info()["renderer"]
            plain = {rebuild: frame_ms(renderer, scene, "plain", args.spp, rebuild)[0] for rebuild in (True, False)}
            for label, params in CONFIGS:
                rebuilt, image = frame_ms(renderer, scene, TECHNIQUE, args.spp, rebuild=True, **params)
                photons = sum(renderer.channels["photon_counts"][0])
                cached, _ = frame_ms(renderer, scene, TECHNIQUE, args.spp, rebuild=False, **params)
                rows.append(f"| {scene.name} | {view} | {label} | {photons} | {relmse(image, reference, caustic):.4f} | "
                            f"{psnr_linear(image, reference, caustic):.1f} | {rebuilt:.0f} ({rebuilt / plain[True]:.1f}x) | "
                            f"{cached:.0f} ({cached / plain[False]:.1f}x) |")
                print(rows[-1], file=sys.stderr, flush=True)
    print_table(f"{args.size} (close-ups 256x192), {args.spp} spp, Mitsuba {args.reference_spp} spp x {args.seeds} "
                f"seeds; map_size 512; ratios against plain at the same size and spp; GL: {gl}",
                ["scene", "camera", "photons", "live photons", "caustic relMSE", "caustic PSNR", "ms, map rebuilt",
                 "ms, map cached"], rows)


if __name__ == "__main__":
    main()
