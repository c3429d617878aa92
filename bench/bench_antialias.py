"""Benchmark: footprint-filtered environment lookups, post-process edge anti-aliasing, multisampled
outlines (msaa) and adaptive 2 x 2 supersampling (adaptive) against k x k supersampling, per scene.

The error of each way of anti-aliasing is measured against the same technique's own image at 8 x 8
samples per pixel with bilinear (point) environment lookups, a box filter of the pixel (so it is the
aliasing alone, not the technique's error against ground truth), on the presets and on a twin of each
with the camera orbited by 35 degrees and raised (scenes the filters were not tuned on). Costs are ms
per frame in the same run (ctx.finish() and wall clock; the fastest of 3 rounds in which the ways take turns),
relative to the first way (1 spp with bilinear lookups unless ``--ways`` picks others). ``--cost-only`` skips
the reference and the errors (for larger sizes) and gives the process's CPU time too (every llvmpipe thread's; it
hardly grows with other processes' load). The last column is the fraction of pixels adaptive flagged.

    .venv/bin/python bench/bench_antialias.py [--presets a,b] [--size 192x144] [--technique auto] [--cost-only]
        [--ways "1 spp footprint,4 spp footprint"]
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
    ("1 spp footprint + edge", 1, "edge", "footprint"), ("1 spp footprint + msaa", 1, "msaa", "footprint"),
    ("1 spp footprint + adaptive", 1, "adaptive", "footprint"),
    ("4 spp", 4, "none", "bilinear"), ("4 spp footprint", 4, "none", "footprint"),
    ("4 spp footprint + msaa", 4, "msaa", "footprint"), ("9 spp", 9, "none", "bilinear"),
    ("9 spp footprint", 9, "none", "footprint"),
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


def fastest_costs(renderer, scene, technique, ways, rounds: int = 3, frames: int = 2) -> dict:
    """{way name: (fastest wall ms, fastest process CPU ms)} over ``rounds`` rounds in which each way (of WAYS)
    renders a warm-up frame and then ``frames`` timed ones, the ways in turns, so that load on shared cores,
    which drifts over seconds, hits them alike (bench/timing.py's fastest_in_blocks, with the environment
    filter switched per way)."""
    fastest = {name: [float("inf"), float("inf")] for name, *_ in ways}
    for _ in range(rounds):
        for name, spp, antialias, environment_filter in ways:
            scene.environment.filter = environment_filter
            renderer.render(scene, technique, spp, antialias=antialias)
            for _ in range(frames):
                cpu = time.process_time()
                wall = renderer.render_timed(scene, technique, spp, antialias=antialias)[1]
                cpu = (time.process_time() - cpu) * 1000.0
                fastest[name] = [min(fastest[name][0], wall), min(fastest[name][1], cpu)]
    return fastest


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default=",".join(PRESETS))
    parser.add_argument("--size", default="192x144")
    parser.add_argument("--technique", default="auto")
    parser.add_argument("--cost-only", action="store_true", help="costs alone (no 64 spp reference, no errors)")
    parser.add_argument("--ways", help="comma-separated way names (default all); costs are relative to the first")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    names = [name for name, *_ in WAYS]
    wanted = names if args.ways is None else [w.strip() for w in args.ways.split(",") if w.strip()]
    unknown = [w for w in wanted if w not in names]
    if unknown or not wanted:
        parser.error(f"unknown ways {unknown}; choose from {', '.join(names)}")
    ways = [next(way for way in WAYS if way[0] == name) for name in wanted]
    totals = {name: [] for name, *_ in ways}
    flagged = []
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
                costs = fastest_costs(renderer, scene, args.technique, ways)
                base_ms, base_cpu = costs[ways[0][0]]
                scene.environment.filter = "bilinear"
                reference = None if args.cost_only else renderer.render(scene, args.technique, 64)
                cells = []
                scene.environment.filter = "footprint"  # adaptive's own (the default)
                renderer.render(scene, args.technique, 1, antialias="adaptive")
                flagged.append(renderer.last_adaptive_fraction or 0.0)
                for name, spp, antialias, environment_filter in ways:
                    ratio, cpu_ratio = costs[name][0] / base_ms, costs[name][1] / base_cpu
                    if reference is None:
                        totals[name].append((cpu_ratio, 0.0, ratio))
                        cells.append(f"{ratio:.2f} / {cpu_ratio:.2f}")
                        continue
                    scene.environment.filter = environment_filter
                    image = renderer.render(scene, args.technique, spp, antialias=antialias)
                    lin, srgb = psnr_linear(image, reference), psnr_srgb(image, reference)
                    totals[name].append((lin, srgb, ratio))
                    cells.append(f"{lin:.1f} / {srgb:.1f} / {ratio:.2f}")
                rows.append(f"| {preset} ({variant}) | " + " | ".join(cells) + f" | {base_ms:.1f} | {flagged[-1]:.3f} |")
                print(rows[-1], file=sys.stderr, flush=True)
    against = "" if args.cost_only else ", against its own 64 spp (8 x 8) image with bilinear environment lookups"
    print(f"{args.size}, technique {args.technique}{against}; GL: {gl}\n")
    base = ways[0][0]
    print(f"cells: wall ms / process CPU ms relative to {base}\n" if args.cost_only
          else f"cells: PSNR linear / PSNR sRGB (dB) / ms relative to {base}\n")
    print("| scene | " + " | ".join(name for name, *_ in ways) + f" | {base} ms | adaptive flagged |")
    print("|---|" + "---|" * (len(ways) + 2))
    print("\n".join(rows))
    means = [np.mean(np.array(v), axis=0) for v in totals.values()]
    if args.cost_only:
        print("| mean | " + " | ".join(f"{m[2]:.2f} / {m[0]:.2f}" for m in means) + f" | | {np.mean(flagged):.3f} |")
    else:
        print("| mean | " + " | ".join(f"{m[0]:.1f} / {m[1]:.1f} / {m[2]:.2f}" for m in means) + f" | | {np.mean(flagged):.3f} |")


if __name__ == "__main__":
    main()
