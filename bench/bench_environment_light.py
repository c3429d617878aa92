"""Benchmark: the environment's light in real time (issue 23 parts 2, 3) against Mitsuba, per region.

Scenes: bench_exact_environment's glass ball and red box on a floor in sky-checker, with and without a point
light, from its camera and from a second, lower one. For each: the Mitsuba composite at ``--reference-spp``
over ``--seeds`` seeds (averaged), then PSNR per region (bench_exact_environment.regions: glass, caustic,
diffuse) and median ms of ``auto`` in three states: the sun left in the SH (before part 3), the sun as a
directional light (part 3, ``environment_lobes=0``), the sun plus ``--lobes`` environment lobes with
shadow maps of the opaque objects only (part 2 as first built), with the glass's transmittance in them
(tinted glass shadows), with the floor's bounce for the light from below, and with the occluders' bounce
where a lobe is blocked, and, auto now, the floor's light map (raytrace/environment_bake.py) in place of the
lobes; ``plain`` gives the cost floor (with the sun and no lobes, as it renders now). The light map's bake
time (once per scene state, not in the frame times) is printed per scene.
``tinted_scenes`` adds two scenes under the sky alone with coloured glass (``--no-tinted`` leaves them out),
``resting_scenes`` two of clear glass standing on the floor under a point light, ``convex_scenes`` two more convex
shapes (held out); ``--scenes a,b`` picks some; ``--exact`` gives exact's row per scene instead (its time in the ms
column); ``--completed`` adds the glass and overall PSNR against the reference completed with the lights' caustics
seen through glass, which Mitsuba's composite lacks.

    .venv/bin/python bench/bench_environment_light.py [--size 128x96] [--reference-spp 1024] [--seeds 2]
    .venv/bin/python bench/bench_environment_light.py --cost-rounds 5  # the cost alone, in blocks
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import sys
import time
from unittest import mock

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from bench_auto import completed_reference  # noqa: E402
from bench_exact_caustics import print_table  # noqa: E402
from bench_exact_environment import mixed_scene, region_cells, seeded_reference  # noqa: E402

from caustica.bench.timing import fastest_in_blocks, timed_render  # noqa: E402
from caustica.metrics.images import psnr_linear  # noqa: E402
from caustica.lighting import bake as light_bake  # noqa: E402
from caustica.lighting import environment as environment_light, samples as light_samples  # noqa: E402
from caustica.passes.shading import shadows as lights  # noqa: E402
from caustica.lighting.environment import environment_sun  # noqa: E402
from caustica.raytrace.environment_bake import BAKE_SAMPLES, BAKE_SIZE  # noqa: E402
from caustica.renderer import Renderer  # noqa: E402
from caustica.scene import Camera, Diffuse, Glass, PointLight, SceneObject, Transform  # noqa: E402
from caustica.scene.shapes import box, cylinder, sphere  # noqa: E402
from caustica.techniques.exact import Exact, ExactParams  # noqa: E402


def scenes(size, tinted: bool = True):
    for light in (False, True):
        scene = mixed_scene(size, light)
        yield scene
        low = Camera(position=[-3.6, 1.6, 3.4], look_at=[-0.4, 0.5, -0.2], fov_y=45.0, size=size)
        yield dataclasses.replace(scene, camera=low, name=scene.name + "-low")
    if tinted:
        yield from tinted_scenes(size)
    yield from resting_scenes(size)
    yield from convex_scenes(size)


def resting_scenes(size):
    """Clear glass standing on the floor with a point light, where the view through the glass meets the floor
    under it: env-cube-light, a cube 0.9 (IOR 1.5) turned 20 degrees about y beside the red box, from
    mixed_scene's camera and light; env-cylinder-light (held out: tuned on nothing), a cylinder of radius 0.55 and
    height 0.8, from a lower camera on the other side, its light elsewhere and warmer."""
    base = mixed_scene(size, True)
    floor, box_object = base.objects[0], base.objects[2]
    cube = SceneObject("cube", box((0.9, 0.9, 0.9)), Glass(ior=1.5),
                       Transform(position=[0.0, 0.45, 0.0], rotation=[0.0, 20.0, 0.0]))
    yield dataclasses.replace(base, objects=[floor, cube, box_object], name="env-cube-light")
    column = SceneObject("cylinder", cylinder(0.55, 0.8, 64), Glass(ior=1.5), Transform(position=[0.5, 0.4, 0.6]))
    camera = Camera(position=[-2.2, 2.3, 4.2], look_at=[0.2, 0.2, 0.2], fov_y=40.0, size=size)
    light = PointLight(position=[-2.0, 4.5, -1.0], intensity=[24.0, 20.0, 16.0])
    yield dataclasses.replace(base, objects=[floor, column, box_object], lights=[light], camera=camera,
                              name="env-cylinder-light")


def convex_scenes(size):
    """Two more convex glass shapes, held out (tuned on nothing) for depth-search's exact exits of any convex mesh
    (passes/shading/convex_exits.py): env-prism-light, an 8-sided smooth-shaded column (shapes.cylinder r 0.45, h 1.1)
    standing on the floor turned 10 degrees, from the right, under a cooler point light; env-log, a 32-sided
    cylinder (r 0.35, length 1.4) lying on the floor along x, touching it along an edge, under the sky alone."""
    base = mixed_scene(size, True)
    floor, box_object = base.objects[0], base.objects[2]
    prism = SceneObject("prism", cylinder(0.45, 1.1, 8), Glass(ior=1.5),
                        Transform(position=[0.3, 0.55, 0.3], rotation=[0.0, 10.0, 0.0]))
    camera = Camera(position=[3.4, 1.5, 3.0], look_at=[0.0, 0.45, 0.0], fov_y=42.0, size=size)
    light = PointLight(position=[2.5, 4.0, 2.0], intensity=[18.0, 20.0, 24.0])
    yield dataclasses.replace(base, objects=[floor, prism, box_object], lights=[light], camera=camera,
                              name="env-prism-light")
    log = SceneObject("log", cylinder(0.35, 1.4, 32), Glass(ior=1.5),
                      Transform(position=[0.4, 0.35, 0.5], rotation=[0.0, 0.0, 90.0]))
    camera = Camera(position=[-1.0, 2.2, 4.0], look_at=[0.3, 0.3, 0.3], fov_y=40.0, size=size)
    yield dataclasses.replace(base, objects=[floor, log, box_object], lights=[], camera=camera, name="env-log")


def chosen(all_scenes, names: str):
    """The scenes named in ``names`` (comma-separated; empty: all), or SystemExit naming the known ones."""
    if not names:
        yield from all_scenes
        return
    wanted = names.split(",")
    scenes_by_name = {scene.name: scene for scene in all_scenes}
    unknown = [name for name in wanted if name not in scenes_by_name]
    if unknown:
        raise SystemExit(f"unknown scene {', '.join(unknown)}: choose from {', '.join(scenes_by_name)}")
    yield from (scenes_by_name[name] for name in wanted)


def tinted_scenes(size):
    """Two more scenes under the sky alone (where auto draws the lobes): env-tinted, a small amber ball
    (radius 0.5, transmittance 0.85 / 0.55 / 0.2 per unit length) and a large clear one (radius 1.1) beside
    the red box, seen from above; env-slab, a green glass block (1.6 x 0.5 x 1.0, IOR 1.5, 0.4 / 0.85 / 0.5
    per unit length) on two grey posts 0.6 high with the red box behind, from the side."""
    base = mixed_scene(size, False)
    floor, box_object = base.objects[0], base.objects[2]
    small = sphere(0.5, 5)
    small.analytic_sphere = (np.zeros(3), 0.5)
    large = sphere(1.1, 6)
    large.analytic_sphere = (np.zeros(3), 1.1)
    amber = Glass(ior=1.5, absorption_color=[0.85, 0.55, 0.2], absorption_distance=1.0)
    tinted = [floor, box_object,
              SceneObject("amber", small, amber, Transform(position=[0.9, 0.5, 1.0])),
              SceneObject("clear", large, Glass(ior=1.5), Transform(position=[0.4, 1.1, -1.7]))]
    above = Camera(position=[1.5, 6.0, 5.5], look_at=[-0.3, 0.3, 0.2], fov_y=45.0, size=size)
    yield dataclasses.replace(base, objects=tinted, camera=above, name="env-tinted")
    green = Glass(ior=1.5, absorption_color=[0.4, 0.85, 0.5], absorption_distance=1.0)
    grey = Diffuse(color=[0.5, 0.5, 0.5])
    slab = [floor, box_object,
            SceneObject("block", box((1.6, 0.5, 1.0)), green, Transform(position=[0.6, 0.85, 0.4])),
            SceneObject("post-a", box((0.2, 0.6, 0.2)), grey, Transform(position=[-0.05, 0.3, 0.4])),
            SceneObject("post-b", box((0.2, 0.6, 0.2)), grey, Transform(position=[1.25, 0.3, 0.4]))]
    side = Camera(position=[3.8, 1.4, 3.6], look_at=[0.2, 0.5, 0.0], fov_y=45.0, size=size)
    yield dataclasses.replace(base, objects=slab, camera=side, name="env-slab")


def states(lobes: int):
    """(label, context manager, auto parameters) of each state measured."""
    no_sun = mock.patch.object(light_samples, "environment_sun",
                               lambda env: environment_light.EnvironmentSun(None, env.irradiance_sh()))
    def without(**fields):  # the lobes' EnvironmentShadows with ``fields`` taken out (set to None)
        draw = environment_passes.EnvironmentLobeMaps._environment_shadows
        return mock.patch.object(environment_passes.EnvironmentLobeMaps, "_environment_shadows", lambda *args: (
            None if (shadows := draw(*args)) is None else dataclasses.replace(shadows, **fields)))

    return [("sun in SH (before)", no_sun, {"environment_lobes": 0}),
            ("sun as a light", contextlib.nullcontext(), {"environment_lobes": 0}),
            (f"+ {lobes} lobes, glass left out", without(glass=None, ambient_sh=None, bounce=None),
             {"environment_lobes": lobes}),
            ("+ glass transmits", without(ambient_sh=None, bounce=None), {"environment_lobes": lobes}),
            ("+ floor bounce", without(bounce=None), {"environment_lobes": lobes}),
            ("+ occluders' bounce", contextlib.nullcontext(), {"environment_lobes": lobes}),
            ("floor light map, no lobes (now)", contextlib.nullcontext(), {})]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="128x96")
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--lobes", type=int, default=environment_light.LOBES)
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("--no-tinted", action="store_true", help="only the four mixed scenes")
    parser.add_argument("--spp", type=int, default=1, help="auto's and plain's samples a pixel")
    parser.add_argument("--scenes", default="", help="comma-separated scene names (default: all)")
    parser.add_argument("--exact", action="store_true", help="exact's row per scene (its defaults, --spp) instead of auto's")
    parser.add_argument("--last", type=int, default=0, help="only the last N states (0: all)")
    parser.add_argument("--completed", action="store_true",
                        help="also score against the reference completed with exact's caustics of the lights seen "
                             "through glass (bench_auto.completed_reference): glass and overall PSNR")
    parser.add_argument("--cost-rounds", type=int, default=0,
                        help="only the cost: auto with the floor's light map and with the lobes over plain, "
                             "fastest_in_blocks over this many rounds")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    if args.cost_rounds:
        return costs(size, not args.no_tinted, args.lobes, args.cost_rounds, args.scenes)
    rows = []
    for scene in chosen(scenes(size, not args.no_tinted), args.scenes):
        reference, masks = seeded_reference(scene, args.reference_spp, args.seeds)
        completed = completed_reference(scene, reference, size, 4) if args.completed else None

        def cells(image):  # the regions' PSNR, then glass and overall against the completed reference
            extra = "" if completed is None else (f" | {psnr_linear(image, completed, masks['glass']):.1f} / "
                                                  f"{psnr_linear(image, completed):.1f}")
            return region_cells(image, reference, masks) + extra
        if args.exact:
            start = time.perf_counter()
            image = Exact().render(scene, scene.camera, ExactParams(), args.spp)
            seconds = time.perf_counter() - start
            rows.append(f"| {scene.name} | exact (defaults) | {cells(image)} | "
                        f"{1000 * seconds:.0f} | - |")
            print(rows[-1], file=sys.stderr, flush=True)
            continue
        start = time.perf_counter()
        maps = light_bake.light_maps(scene, environment_sun(scene.environment).light is not None, BAKE_SIZE)
        print(f"{scene.name}: light maps baked in {time.perf_counter() - start:.1f} s (the floor's {BAKE_SIZE}x"
              f"{BAKE_SIZE} texels and {len(maps) - 1} box faces', {BAKE_SAMPLES} rays a texel)", file=sys.stderr,
              flush=True)
        with Renderer() as renderer:
            _, plain_ms = timed_render(renderer, scene, "plain", args.spp, args.frames)
        for label, context, params in states(args.lobes)[-args.last if args.last else 0:]:
            # A renderer (and device cache) per state: the states share the scene's cache key, and the
            # shadow maps cached with the sun must not serve the state without it.
            with context, Renderer() as renderer:
                image, ms = timed_render(renderer, scene, "auto", args.spp, args.frames, params)
            rows.append(f"| {scene.name} | {label} | {cells(image)} | {ms:.0f} | "
                        f"{ms / plain_ms:.2f} |")
            print(rows[-1], file=sys.stderr, flush=True)
    print_table(f"{args.size}, auto {args.spp} spp, Mitsuba {args.reference_spp} spp x {args.seeds} seeds averaged",
                ["scene", "auto", "glass PSNR", "caustic PSNR", "diffuse PSNR", "PSNR all",
                 *(["completed: glass / all"] if args.completed else []), "ms", "x plain"], rows)


def costs(size, tinted: bool, lobes: int, rounds: int, names: str = "") -> None:
    """auto's fastest frame (bench/timing.fastest_in_blocks: wall clock and process CPU time, 3 frames a block)
    over plain's, as planned now (the floor's light map, baked before the timing) and with the lobes instead."""
    variants = {"light map (now)": ("auto", {}), f"{lobes} lobes": ("auto", {"environment_lobes": lobes}),
                "plain": ("plain", {})}
    rows = []
    with Renderer() as renderer:
        gl = renderer.info()["renderer"]
        for scene in chosen(scenes(size, tinted), names):
            fastest = fastest_in_blocks(renderer, scene, variants, 1, rounds)
            for name in list(variants)[:-1]:
                rows.append(f"| {scene.name} | {name} | {fastest[name]['wall']:.1f} | "
                            f"{fastest[name]['wall'] / fastest['plain']['wall']:.2f} | "
                            f"{fastest[name]['cpu'] / fastest['plain']['cpu']:.2f} |")
                print(rows[-1], file=sys.stderr, flush=True)
    print_table(f"{size[0]}x{size[1]}, 1 spp, fastest of {rounds} rounds x 3 frames, GL: {gl}",
                ["scene", "auto", "ms", "x plain, wall", "x plain, CPU"], rows)


if __name__ == "__main__":
    main()
