"""Benchmark: the caustic techniques and ``exact`` (photon-mapped caustics) against Mitsuba, on scenes
not among the presets: a glass ball (radius 1, IOR 1.5) and a clear glass bunny over a grey floor under a
point light, in a black environment (as path-traced references have).

For each scene: the Mitsuba composite (path + ptracer) at ``--reference-spp`` spp over ``--seeds``
independent seeds, averaged (the spread between two seeds is printed: the reference's own noise), then
each technique's caustic-region relMSE and PSNR and overall PSNR, and its ms per frame (GPU techniques:
best of 3 after a warm-up, ctx.finish() and wall clock; exact: one render, photon map included).

    .venv/bin/python bench/bench_exact_caustics.py [--size 128x96] [--reference-spp 1024] [--seeds 4]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from caustica.metrics.images import psnr_linear, relmse
from caustica.metrics.regions import region_masks
from caustica.reference.render import render_reference
from caustica.renderer import Renderer
from caustica.scene import Camera, Diffuse, Glass, PointLight, Scene, SceneObject, Transform
from caustica.scene.environment import procedural_environment
from caustica.scene.mesh import load_mesh
from caustica.scene.shapes import plane, sphere

BUNNY = Path(__file__).resolve().parents[2] / "shared" / "data" / "models" / "stanford-bunny.obj"
TECHNIQUES = ["exact", "depth-search+caustic-mapping", "depth-search+photon-splats", "depth-search+transport-table",
              "impostors+impostor-caustics", "auto"]


def over_floor(name: str, mesh, position, light, size) -> Scene:
    floor = SceneObject("floor", plane((10.0, 10.0)), Diffuse(color=[0.75, 0.75, 0.75]))
    glass = SceneObject(name, mesh, Glass(ior=1.5), Transform(position=position))
    camera = Camera(position=[2.4, 3.4, 4.6], look_at=[0.0, 0.4, 0.0], fov_y=40.0, size=size)
    return Scene(camera=camera, objects=[floor, glass], lights=[PointLight(position=light, intensity=[30.0] * 3)],
                 environment=procedural_environment("black"), name=name)


def scenes(size):
    ball = sphere(1.0, 6)
    ball.analytic_sphere = (np.zeros(3), 1.0)
    yield over_floor("ball-over-floor", ball, [0.0, 1.6, 0.0], [0.8, 6.0, -0.5], size)
    if BUNNY.is_file():
        bunny = load_mesh(BUNNY)
        lo, hi = bunny.bounds
        scale = 2.0 / float((hi - lo).max())
        bunny.vertices = (bunny.vertices - [(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2]) * scale
        bunny.validate(normals_missing=True)
        yield over_floor("bunny-over-floor", bunny, [0.0, 0.3, 0.0], [-0.6, 5.0, 0.8], size)


def reference_arguments(description: str, seeds: int) -> argparse.ArgumentParser:
    """The options every Mitsuba-referenced benchmark takes: --size, --spp, --reference-spp, --seeds."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--size", default="128x96")
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--seeds", type=int, default=seeds)
    return parser


def print_table(caption: str, columns: list[str], rows: list[str]) -> None:
    """A caption line, then a markdown table of ``columns`` over the prepared ``rows``."""
    print(f"{caption}\n")
    print("| " + " | ".join(columns) + " |")
    print("|" + "---|" * len(columns))
    print("\n".join(rows))


def main(argv=None) -> None:
    args = reference_arguments(__doc__.splitlines()[0], seeds=4).parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    rows, gl = [], ""
    for scene in scenes(size):
        refs = [render_reference(scene, spp=args.reference_spp, progress=False, seed=k) for k in range(args.seeds)]
        reference = np.mean(refs, axis=0)
        masks = region_masks(scene)
        caustic = masks["caustic"]
        spread = psnr_linear(refs[0], refs[1]) if len(refs) > 1 else float("nan")
        print(f"{scene.name}: {caustic.sum()} caustic pixels; two reference seeds differ by {spread:.1f} dB "
              f"(caustic relMSE {relmse(refs[0], refs[1], caustic):.4f})", file=sys.stderr, flush=True)
        with Renderer(size) as renderer:
            gl = renderer.info()["renderer"]
            for technique in TECHNIQUES:
                times = []
                for _ in range(1 if technique == "exact" else 4):
                    start = time.perf_counter()
                    image = renderer.render(scene, technique, args.spp)
                    times.append((time.perf_counter() - start) * 1000.0)
                ms = times[0] if technique == "exact" else min(times[1:])
                rows.append(f"| {scene.name} | {technique} | {relmse(image, reference, caustic):.4f} | "
                            f"{psnr_linear(image, reference, caustic):.1f} | {psnr_linear(image, reference):.1f} | "
                            f"{ms:.0f} |")
                print(rows[-1], file=sys.stderr, flush=True)
    print_table(f"{args.size}, {args.spp} spp, Mitsuba {args.reference_spp} spp x {args.seeds} seeds, black "
                f"environment; GL: {gl}", ["scene", "technique", "caustic relMSE", "caustic PSNR", "PSNR all",
                                           "ms per frame"], rows)


if __name__ == "__main__":
    main()
