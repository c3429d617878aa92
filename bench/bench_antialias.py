"""Benchmark: footprint-filtered environment lookups and post-process edge anti-aliasing against
k x k supersampling, per scene.

The error of each way of anti-aliasing is measured against the same technique's own image at 8 x 8
samples per pixel with bilinear (point) environment lookups, a box filter of the pixel (so it is the
aliasing alone, not the technique's error against ground truth), on the presets and on a twin of each
with the camera orbited by 35 degrees and raised (scenes the filters were not tuned on). Costs are ms
per frame in the same run (ctx.finish() and wall clock), relative to 1 spp with bilinear lookups.

    .venv/bin/python bench/bench_antialias.py [--presets a,b] [--size 192x144] [--technique auto]
"""
from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

import caustica
from caustica.metrics.images import psnr_linear, psnr_srgb
from caustica.renderer import Renderer

PRESETS = ["glass-sphere", "caustic-sphere", "tvcg-fig10", "caustics-point", "caustics-ring", "caustics-bunny",
           "door-mirror", "mirror-concave", "spectacle-convex", "tvcg-fig14", "tvcg-fig24", "caustics-prism"]
WAYS = [  # (name, spp, antialias, Environment.filter)
    ("1 spp", 1, "none", "bilinear"), ("1 spp footprint", 1, "none", "footprint"),
    ("1 spp footprint + edge", 1, "edge", "footprint"), ("4 spp", 4, "none", "bilinear"),
    ("4 spp footprint", 4, "none", "footprint"), ("9 spp", 9, "none", "bilinear"),
]


def orbited(scene, degrees: float, lift: float):
    """The scene with its camera turned ``degrees`` about the vertical through look_at and raised ``lift``
    of its distance."""
    camera = scene.camera
    offset = camera.position - camera.look_at
    a = math.radians(degrees)
    x, z = offset[0] * math.cos(a) + offset[2] * math.sin(a), -offset[0] * math.sin(a) + offset[2] * math.cos(a)
    moved = np.array([x, offset[1] + lift * np.linalg.norm(offset), z])
    camera.position = camera.look_at + moved
    camera.validate()
    return scene


def timed(renderer, scene, technique, spp, antialias, frames=3) -> tuple[np.ndarray, float]:
    image, times = None, []
    for _ in range(frames + 1):
        start = time.perf_counter()
        image = renderer.render(scene, technique, spp, antialias=antialias)
        times.append((time.perf_counter() - start) * 1000.0)
    return image, min(times[1:])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default=",".join(PRESETS))
    parser.add_argument("--size", default="192x144")
    parser.add_argument("--technique", default="auto")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    totals = {name: [] for name, *_ in WAYS}
    rows = []
    with Renderer(size) as renderer:
        gl = renderer.info()["renderer"]
        for preset in [p for p in args.presets.split(",") if p]:
            for variant in ("preset", "orbited"):
                try:
                    scene = caustica.load_scene(preset)
                except caustica.SceneError as exc:
                    print(f"skipped {preset}: {exc}", file=sys.stderr)
                    break
                if variant == "orbited":
                    scene = orbited(scene, 35.0, 0.15)
                scene.environment.filter = "bilinear"
                reference = renderer.render(scene, args.technique, 64)
                cells = []
                base_ms = None
                for name, spp, antialias, environment_filter in WAYS:
                    scene.environment.filter = environment_filter
                    image, ms = timed(renderer, scene, args.technique, spp, antialias)
                    base_ms = base_ms or ms
                    lin, srgb = psnr_linear(image, reference), psnr_srgb(image, reference)
                    totals[name].append((lin, srgb, ms / base_ms))
                    cells.append(f"{lin:.1f} / {srgb:.1f} / {ms / base_ms:.2f}")
                rows.append(f"| {preset} ({variant}) | " + " | ".join(cells) + " |")
                print(rows[-1], file=sys.stderr, flush=True)
    print(f"{args.size}, technique {args.technique}, against its own 64 spp (8 x 8) image with bilinear "
          f"environment lookups; GL: {gl}\n")
    print("cells: PSNR linear / PSNR sRGB (dB) / ms relative to 1 spp\n")
    print("| scene | " + " | ".join(name for name, *_ in WAYS) + " |")
    print("|---|" + "---|" * len(WAYS))
    print("\n".join(rows))
    means = [np.mean(np.array(v), axis=0) for v in totals.values()]
    print("| mean | " + " | ".join(f"{m[0]:.1f} / {m[1]:.1f} / {m[2]:.2f}" for m in means) + " |")


if __name__ == "__main__":
    main()
