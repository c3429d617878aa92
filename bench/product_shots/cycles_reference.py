"""Cycles references of the product shots: each scene's .blend rendered twice with independent seeds.

Run with Blender's Python (as ``make_scenes.py``), niced on shared cores:

    nice -n 10 /work/bpy-venv/bin/python bench/product_shots/cycles_reference.py [--blends DIR]
        [--out DIR] [--spp 512] [--threads 2] [--only a,b]

Renders each ``NAME.blend`` of ``--blends`` (make_scenes.py's, default ``$CAUSTICA_CACHE/product_shots/blend``)
and writes ``NAME.seed1.exr`` and ``NAME.seed2.exr`` (32-bit linear RGB, ``--spp`` samples each) and
``NAME.cycles.json`` (seconds per render, Blender version, settings) into ``--out`` (default
``$CAUSTICA_CACHE/product_shots`` or ``~/.cache/caustica/product_shots``). The two renders are the halves of
the reference: their mean has twice the samples, and their difference gives its noise floor
(caustica.metrics.floor). Settings: CPU, no denoising, no adaptive sampling, a 1-pixel box filter, no
clamping, no glossy filter, reflective and refractive caustics on, 16 bounces (4 diffuse: ``--diffuse-bounces``), the Standard view
transform (no Filmic/AgX look), exposure 0, gamma 1.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import bpy


def default_out() -> Path:
    root = os.environ.get("CAUSTICA_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "caustica") / "product_shots"


def configure(scene, spp: int, threads: int, diffuse_bounces: int = 4) -> None:
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    scene.render.threads_mode, scene.render.threads = "FIXED", threads
    cycles.samples = spp
    cycles.use_denoising = False
    cycles.use_adaptive_sampling = False
    cycles.pixel_filter_type, cycles.filter_width = "BOX", 1.0
    cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
    cycles.blur_glossy = 0.0
    cycles.max_bounces = cycles.transmission_bounces = cycles.glossy_bounces = cycles.transparent_max_bounces = 16
    cycles.diffuse_bounces = diffuse_bounces
    cycles.caustics_reflective = cycles.caustics_refractive = True
    scene.view_settings.view_transform, scene.view_settings.look = "Standard", "None"
    scene.view_settings.exposure, scene.view_settings.gamma = 0.0, 1.0
    scene.render.film_transparent = False
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGB"


def render(blend: Path, out: Path, spp: int, threads: int, diffuse_bounces: int) -> dict:
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    configure(scene, spp, threads, diffuse_bounces)
    seconds = {}
    for seed in (1, 2):
        scene.cycles.seed = seed
        scene.render.filepath = str(out / f"{blend.stem}.seed{seed}.exr")
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds[seed] = time.perf_counter() - start
        print(f"{blend.stem} seed {seed}: {spp} spp in {seconds[seed]:.1f} s", flush=True)
    info = {"spp_per_seed": spp, "seeds": [1, 2], "seconds": seconds, "threads": threads, "diffuse_bounces": diffuse_bounces,
            "blender": bpy.app.version_string, "size": [scene.render.resolution_x, scene.render.resolution_y]}
    (out / f"{blend.stem}.cycles.json").write_text(json.dumps(info, indent=2))
    return info


def main() -> None:
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blends", type=Path, default=default_out() / "blend")
    parser.add_argument("--out", type=Path, default=default_out())
    parser.add_argument("--spp", type=int, default=512)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--only", default="")
    parser.add_argument("--diffuse-bounces", type=int, default=4,
                        help="0 leaves out light bounced between diffuse surfaces (into another --out)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    only = {name for name in args.only.split(",") if name}
    for blend in sorted(args.blends.glob("*.blend")):
        if not only or blend.stem in only:
            render(blend, args.out.resolve(), args.spp, args.threads, args.diffuse_bounces)


if __name__ == "__main__":
    main()
