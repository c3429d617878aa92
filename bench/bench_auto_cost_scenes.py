"""Benchmark: auto's cost and accuracy on two scenes of issue 19's kind that are no preset: glass before several
diffuse objects under the sky-checker environment, no lights (its sun the only light).

- ``lens-before-chart``: a thick biconvex lens before an 8 x 8 test chart and two boxes, 160x120;
- ``balls-and-boxes``: two glass balls (IOR 1.5 and 1.33) over a floor with three boxes, 128x96.

For each: auto's plan, PSNR (linear, overall / glass) against the Mitsuba reference (cached), and auto's
fastest frames over plain's (bench/timing.fastest_in_blocks: wall clock and process CPU time), with
``-p`` style variants of auto given as ``name=value`` pairs.

    .venv/bin/python bench/bench_auto_cost_scenes.py [--reference-spp 1024] [--rounds 3] [--frames 3]
        [--variant environment_lobes=0] ...
"""
from __future__ import annotations

import argparse
import sys

import caustica
from caustica.bench.compare import reference_image
from caustica.bench.timing import fastest_in_blocks
from caustica.metrics import compare_images, region_masks
from caustica.scene import Camera, Diffuse, Glass, Scene, SceneObject, Transform, procedural_environment
from caustica.scene.presets_per_vertex import test_chart
from caustica.scene.shapes import biconvex_lens, box, plane, sphere

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from bench_exact_caustics import print_table  # noqa: E402


def lens_before_chart() -> Scene:
    lens = SceneObject("lens", biconvex_lens(0.3, 0.14, 0.01, 64, 16), Glass(ior=1.5))
    boxes = [SceneObject("box-a", box((0.2, 0.2, 0.2)), Diffuse([0.7, 0.3, 0.2]), Transform(position=[-0.45, -0.3, -0.4])),
             SceneObject("box-b", box((0.15, 0.3, 0.15)), Diffuse([0.2, 0.5, 0.7]),
                         Transform(position=[0.45, 0.25, -0.45]))]
    camera = Camera(position=[0.12, 0.06, 0.9], look_at=[0.0, 0.0, -0.2], fov_y=38.0, size=(160, 120))
    return Scene(camera=camera, objects=[lens, *test_chart(center=(0.05, -0.02, -0.6), size=1.0, cells=8), *boxes],
                 environment=procedural_environment("sky-checker"), name="lens-before-chart")


def balls_and_boxes() -> Scene:
    objects = [
        SceneObject("floor", plane((6.0, 6.0)), Diffuse([0.7, 0.7, 0.7])),
        SceneObject("ball", sphere(0.5, 4), Glass(ior=1.5), Transform(position=[0.0, 0.5, 0.0])),
        SceneObject("ball-2", sphere(0.3, 4), Glass(ior=1.33), Transform(position=[0.9, 0.3, 0.5])),
        SceneObject("box-a", box((0.5, 0.8, 0.5)), Diffuse([0.7, 0.2, 0.15]), Transform(position=[-1.0, 0.4, -0.6])),
        SceneObject("box-b", box((0.4, 0.4, 0.4)), Diffuse([0.2, 0.6, 0.3]), Transform(position=[0.8, 0.2, -1.0])),
        SceneObject("box-c", box((0.3, 0.6, 0.3)), Diffuse([0.2, 0.3, 0.8]), Transform(position=[-0.5, 0.3, 0.9])),
    ]
    camera = Camera(position=[1.2, 2.0, 3.4], look_at=[0.0, 0.3, 0.0], fov_y=42.0, size=(128, 96))
    return Scene(camera=camera, objects=objects, environment=procedural_environment("sky-checker"), name="balls-and-boxes")


def _value(text: str):
    if text in ("true", "false"):
        return text == "true"
    try:
        return int(text)
    except ValueError:
        return float(text)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--frames", type=int, default=3)
    parser.add_argument("--variant", action="append", default=[], help="auto with name=value[,name=value] (repeatable)")
    args = parser.parse_args(argv)
    variants = {"auto": ("auto", {})}
    for text in args.variant:
        variants[f"auto {text}"] = ("auto", {k: _value(v) for k, v in (p.split("=") for p in text.split(","))})
    rows, gl = [], ""
    for scene in (lens_before_chart(), balls_and_boxes()):
        size = scene.camera.size
        reference, _ = reference_image(scene, size, args.reference_spp, False)
        with caustica.Renderer(size) as renderer:
            gl = renderer.info()["renderer"]
            masks = region_masks(scene, renderer.camera_for(scene), spp=4)
            fastest = fastest_in_blocks(renderer, scene, {**variants, "plain": ("plain", {})}, 4, args.rounds,
                                        args.frames)
            for name, (technique, params) in variants.items():
                image = renderer.render(scene, technique, 4, **params)
                figures = compare_images(image, reference, masks)
                rows.append(f"| {scene.name} {size[0]}x{size[1]} | {name} | {renderer.last_plan.technique} | "
                            f"{figures['all']['psnr_linear']:.2f} / {figures['refractor']['psnr_linear']:.2f} | "
                            f"{fastest[name]['wall'] / fastest['plain']['wall']:.2f} | "
                            f"{fastest[name]['cpu'] / fastest['plain']['cpu']:.2f} |")
                print(rows[-1], flush=True)
    print_table(f"\n4 spp, Mitsuba reference {args.reference_spp} spp, GL: {gl}",
                ["scene", "variant", "plan", "PSNR all / glass (dB)", "x plain, wall", "x plain, CPU"], rows)


if __name__ == "__main__":
    main()
