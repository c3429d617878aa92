"""Benchmark: the environment's light on curved and flat diffuse receivers that are neither a floor nor a box
(issue 23), against Mitsuba, per region, with auto's cost over plain's.

Scenes under sky-checker, no light of their own (its sun the only light):

- ``env-spheres``: a diffuse sphere (radius 0.7) beside a clear glass ball (radius 0.8) on a floor;
- ``env-cow``: the shared cow mesh (5.8K triangles, 2 long) standing on a floor beside a clear ball (radius 0.6);
  left out where /work/shared/data is missing;
- ``env-backdrop``: a diffuse sphere and a clear ball before a vertical backdrop (one quad), no floor.

For each: the Mitsuba composite at ``--reference-spp`` over ``--seeds`` seeds (bench_exact_environment), auto's
PSNR per region (glass, caustic, diffuse, all) at ``--spp``, the bake's seconds (light_maps, once per scene state,
not in the frame times), and auto's fastest frame over plain's (bench/timing.fastest_in_blocks, wall clock and
process CPU time, 1 spp). It uses only what main had too, so the same command measures before and after.

    .venv/bin/python bench/bench_curved_receivers.py [--size 128x96] [--spp 4] [--reference-spp 1024] [--seeds 2]
        [--rounds 3]
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from bench_exact_caustics import MODELS, print_table, standing  # noqa: E402
from bench_exact_environment import reference_parser, region_cells, seeded_reference  # noqa: E402

from caustica.bench.timing import fastest_in_blocks  # noqa: E402
from caustica.lighting.bake import light_maps  # noqa: E402
from caustica.lighting.environment import environment_sun  # noqa: E402
from caustica.raytrace.environment_bake import BAKE_SIZE  # noqa: E402
from caustica.renderer import Renderer  # noqa: E402
from caustica.scene import Camera, Diffuse, Glass, Scene, SceneObject, Transform, procedural_environment  # noqa: E402
from caustica.scene.shapes import plane, sphere  # noqa: E402


def _ball(radius: float, subdivisions: int = 5):
    mesh = sphere(radius, subdivisions)
    mesh.analytic_sphere = (np.zeros(3), radius)
    return mesh


def scenes(size, models: Path = MODELS):
    """The benchmark's scenes (see the module docstring)."""
    sky = procedural_environment("sky-checker")
    floor = SceneObject("floor", plane((10.0, 10.0)), Diffuse(color=[0.75, 0.75, 0.75]))
    camera = Camera(position=[2.4, 3.0, 4.6], look_at=[-0.2, 0.6, 0.0], fov_y=40.0, size=size)
    white = SceneObject("sphere", sphere(0.7, 4), Diffuse(color=[0.7, 0.7, 0.7]), Transform(position=[-0.8, 0.7, -0.3]))
    clear = SceneObject("ball", _ball(0.8), Glass(ior=1.5), Transform(position=[0.8, 0.8, 0.4]))
    yield Scene(camera=camera, objects=[floor, white, clear], environment=sky, name="env-spheres")
    cow_path = models / "cow.obj"
    if cow_path.is_file():
        cow = SceneObject("cow", standing(cow_path, 2.0), Diffuse(color=[0.65, 0.5, 0.35]),
                          Transform(position=[-0.6, 0.0, -0.2], rotation=[0.0, 30.0, 0.0]))
        small = SceneObject("ball", _ball(0.6), Glass(ior=1.5), Transform(position=[1.1, 0.6, 0.6]))
        yield Scene(camera=camera, objects=[floor, cow, small], environment=sky, name="env-cow")
    else:
        print(f"env-cow left out: {cow_path} missing", file=sys.stderr)
    backdrop = SceneObject("backdrop", plane((3.0, 5.0)), Diffuse(color=[0.7, 0.7, 0.7]),
                           Transform(position=[0.0, 0.5, -1.2], rotation=[90.0, 0.0, 0.0]))
    front = Camera(position=[0.8, 1.2, 4.2], look_at=[0.0, 0.3, -0.6], fov_y=40.0, size=size)
    near = SceneObject("sphere", sphere(0.5, 4), Diffuse(color=[0.7, 0.7, 0.7]), Transform(position=[-0.7, 0.2, -0.5]))
    lens = SceneObject("ball", _ball(0.5), Glass(ior=1.5), Transform(position=[0.6, 0.2, -0.3]))
    yield Scene(camera=front, objects=[backdrop, near, lens], environment=sky, name="env-backdrop")


def main(argv=None) -> None:
    parser = reference_parser(__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    rows = []
    with Renderer() as renderer:
        gl = renderer.info()["renderer"]
        for scene in scenes(size):
            reference, masks = seeded_reference(scene, args.reference_spp, args.seeds)
            start = time.perf_counter()
            light_maps(scene, environment_sun(scene.environment).light is not None, BAKE_SIZE)
            bake = time.perf_counter() - start
            image = renderer.render(scene, "auto", args.spp)
            plan = renderer.last_plan
            fastest = fastest_in_blocks(renderer, scene, {"auto": ("auto", {}), "plain": ("plain", {})}, 1,
                                        args.rounds)
            ratios = " | ".join(f"{fastest['auto'][k] / fastest['plain'][k]:.2f}" for k in ("wall", "cpu"))
            rows.append(f"| {scene.name} | {plan.technique} | {region_cells(image, reference, masks)} | {bake:.1f} | "
                        f"{ratios} |")
            print(rows[-1], file=sys.stderr, flush=True)
    print_table(f"{args.size}, auto {args.spp} spp, Mitsuba {args.reference_spp} spp x {args.seeds} seeds averaged, "
                f"cost at 1 spp (fastest of {args.rounds} rounds x 3 frames), GL: {gl}",
                ["scene", "plan", "glass PSNR", "caustic PSNR", "diffuse PSNR", "PSNR all", "bake (s)",
                 "x plain, wall", "x plain, CPU"], rows)


if __name__ == "__main__":
    main()
