"""Benchmark: ``exact`` with the environment's light sampled (occluded, through glass, its sun's caustic)
against its old unoccluded SH ambient and against Mitsuba: a glass ball (radius 1, IOR 1.5) and a red
box on a grey floor in the sky-checker environment, with and without a point light.

For each scene: the Mitsuba composite at ``--reference-spp`` spp over ``--seeds`` seeds, averaged (the
two first seeds' spread is printed: the reference's own noise), then PSNR per region for ``exact`` with
``environment_samples=0`` (before) and the defaults (after), and its seconds (one render, photon map
included). Regions: glass (the refractor mask), caustic (diffuse pixels in the geometric shadow of the
glass for a light or the sun, taken as a directional light), diffuse (the other diffuse pixels).

    .venv/bin/python bench/bench_exact_environment.py [--size 128x96] [--spp 4] [--reference-spp 1024] [--seeds 2]
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np

from caustica.metrics.hits import objects_of_kind
from caustica.metrics.images import psnr_linear
from caustica.metrics.regions import region_masks
from caustica.raytrace.embree_scene import ray_scene_for
from caustica.reference.render import render_reference
from caustica.scene import Camera, Diffuse, DirectionalLight, Glass, PointLight, Scene, SceneObject, Transform
from caustica.scene.environment import procedural_environment
from caustica.scene.shapes import box, plane, sphere
from caustica.techniques.exact import Exact, ExactParams

SUN = np.array([0.4, 0.6, -0.7]) / np.linalg.norm([0.4, 0.6, -0.7])  # sky_checker's default sun direction


def mixed_scene(size, light: bool) -> Scene:
    ball = sphere(1.0, 6)
    ball.analytic_sphere = (np.zeros(3), 1.0)
    objects = [SceneObject("floor", plane((10.0, 10.0)), Diffuse(color=[0.75, 0.75, 0.75])),
               SceneObject("ball", ball, Glass(ior=1.5), Transform(position=[0.0, 1.0, 0.0])),
               SceneObject("box", box((0.8, 1.2, 0.8)), Diffuse(color=[0.7, 0.15, 0.1]),
                           Transform(position=[-1.6, 0.6, -0.6]))]
    camera = Camera(position=[2.4, 3.4, 4.6], look_at=[-0.3, 0.5, 0.0], fov_y=42.0, size=size)
    lights = [PointLight(position=[1.5, 5.0, 1.0], intensity=[20.0] * 3)] if light else []
    return Scene(camera=camera, objects=objects, lights=lights, environment=procedural_environment("sky-checker"),
                 name="env-mixed-light" if light else "env-mixed")


def regions(scene) -> dict[str, np.ndarray]:
    """glass / caustic / diffuse masks (see the module docstring)."""
    with_sun = dataclasses.replace(scene, lights=list(scene.lights) + [DirectionalLight(direction=-SUN)])
    masks = region_masks(with_sun)
    origins, dirs = scene.camera.primary_rays(1)
    hits = ray_scene_for(scene).intersect(origins.reshape(-1, 3), dirs.reshape(-1, 3))
    diffuse = objects_of_kind(scene, "diffuse")[hits.object_index].reshape(masks["rest"].shape)
    return {"glass": masks["refractor"], "caustic": masks["caustic"], "diffuse": diffuse & ~masks["caustic"]}


def seeded_reference(scene, spp: int, seeds: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The mean of ``seeds`` Mitsuba references and the region masks; the spread of two seeds per region
    (the noise of one seed, the mean's about 3 dB lower) on stderr."""
    refs = [render_reference(scene, spp=spp, progress=False, seed=k) for k in range(seeds)]
    masks = regions(scene)
    if len(refs) > 1:
        spread = " ".join(f"{name} {psnr_linear(refs[0], refs[1], m):.1f}" for name, m in masks.items())
        print(f"{scene.name}: reference seeds 0 and 1 differ by: {spread} dB; "
              f"pixels {' '.join(f'{n} {int(m.sum())}' for n, m in masks.items())}", file=sys.stderr, flush=True)
    return np.mean(refs, axis=0), masks


def region_cells(image, reference, masks) -> str:
    """The table cells PSNR per region, then over the whole image."""
    scores = " | ".join(f"{psnr_linear(image, reference, m):.1f}" for m in masks.values())
    return f"{scores} | {psnr_linear(image, reference):.1f}"


def reference_parser(description: str) -> argparse.ArgumentParser:
    """The options of a benchmark against seeded Mitsuba references: --size, --spp, --reference-spp, --seeds."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--size", default="128x96")
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--seeds", type=int, default=2)
    return parser


def main(argv=None) -> None:
    args = reference_parser(__doc__.splitlines()[0]).parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    rows = []
    for light in (False, True):
        scene = mixed_scene(size, light)
        reference, masks = seeded_reference(scene, args.reference_spp, args.seeds)
        for label, params in (("before (environment_samples=0)", ExactParams(environment_samples=0)),
                              ("after (defaults)", ExactParams())):
            start = time.perf_counter()
            image = Exact().render(scene, scene.camera, params, args.spp)
            seconds = time.perf_counter() - start
            rows.append(f"| {scene.name} | {label} | {region_cells(image, reference, masks)} | {seconds:.1f} |")
            print(rows[-1], file=sys.stderr, flush=True)
    print(f"{args.size}, exact {args.spp} spp, Mitsuba {args.reference_spp} spp x {args.seeds} seeds averaged\n")
    print("| scene | exact | glass PSNR | caustic PSNR | diffuse PSNR | PSNR all | seconds |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
