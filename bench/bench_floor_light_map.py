"""Benchmark: auto's light maps (issue 23, docs/environment-light.md) on the presets where auto plans them, which
they were not tuned on: auto as planned now against ``environment_bake=0`` (the SH ambient those lit presets had),
PSNR (linear) overall and per region (refractor, caustic, rest) against the cached Mitsuba reference, and the
bake's time.

    .venv/bin/python bench/bench_floor_light_map.py [--size 128x96] [--spp 4] [--reference-spp 1024]
        [--presets a,b,...]
"""
from __future__ import annotations

import argparse
import sys
import time

import caustica
from caustica.bench.compare import reference_image
from caustica.metrics import compare_images, region_masks
from caustica.scene.presets import PRESETS
from caustica.techniques import get_technique

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from bench_exact_caustics import print_table  # noqa: E402

CANDIDATES = ["glass-sphere", "caustic-sphere", "tvcg-fig10", "caustics-point", "caustics-spot", "caustics-ring",
              "caustics-two-lights", "door-mirror", "mirror-concave", "spectacle-convex", "tvcg-fig14", "tvcg-fig24"]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="128x96")
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--presets", default=",".join(CANDIDATES), help="comma-separated preset names")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    rows, gl = [], ""
    auto = get_technique("auto")
    for name in args.presets.split(","):
        scene = PRESETS[name]()
        scene = scene.with_camera(scene.camera.with_size(*size))
        planned = auto.for_scene(scene, auto.make_params())[1]
        if not (planned[0] if isinstance(planned, tuple) else planned).environment_bake:
            print(f"{name}: auto plans no light map", file=sys.stderr, flush=True)
            continue
        reference, _ = reference_image(scene, size, args.reference_spp, False)
        with caustica.Renderer(size) as renderer:
            gl = renderer.info()["renderer"]
            masks = region_masks(scene, renderer.camera_for(scene), spp=4)
            start = time.perf_counter()
            renderer.render(scene, "auto", args.spp)  # bakes the map
            bake_s = time.perf_counter() - start
            for label, params in (("SH (environment_bake=0)", {"environment_bake": 0}), ("light map (now)", {})):
                image = renderer.render(scene, "auto", args.spp, **params)
                figures = compare_images(image, reference, masks)
                cells = " | ".join(f"{figures[r]['psnr_linear']:.2f}" for r in ("all", "refractor", "caustic", "rest"))
                rows.append(f"| {name} | {renderer.last_plan.technique} | {label} | {cells} | "
                            f"{bake_s if params == {} else 0:.1f} |")
                print(rows[-1], file=sys.stderr, flush=True)
    print_table(f"{args.size}, auto {args.spp} spp, Mitsuba {args.reference_spp} spp, GL: {gl}",
                ["preset", "plan", "ambient", "all", "refractor", "caustic", "rest", "first frame s (bake, compile)"],
                rows)


if __name__ == "__main__":
    main()
