"""Benchmark: caustica against Blender Cycles (bpy) on the same scene, machine and Mitsuba reference.

The scene is exported with caustica's glTF exporter and imported into Blender (its glTF importer);
the environment, which glTF cannot hold, is the same image turned to Blender's equirectangular
convention (Cycles: u = 0.5 - atan2(y, x) / 2pi, v = 1 - acos(z) / pi, Z up; caustica / Mitsuba:
u = atan2(x, -z) / 2pi, Y up; with the importer's Y-up to Z-up turn, Blender's u is caustica's
+ 0.25). Cycles renders on the CPU with a 1-pixel box filter, no denoising, no adaptive sampling,
no clamping or glossy filter, 16 bounces, the Standard view (linear EXR). Each Cycles spp is timed
(the render call, best of ``--repeats``; caustica's best of 7) and its relMSE taken against a Mitsuba
reference of the same mesh (analytic spheres off: Cycles sees the triangles), caustica's technique
the same way. The table gives the fewest Cycles spp at least as close as caustica, and the ratio of
frame times.

Needs a Python with bpy (``python -m venv /tmp/bpyvenv && /tmp/bpyvenv/bin/pip install bpy``):

    .venv/bin/python bench/bench_cycles.py [--scene glass-sphere] [--size 256] [--technique auto]
        [--blender-python /tmp/bpyvenv/bin/python] [--spp 1,2,4,...,256] [--reference-spp 1024]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import caustica
from caustica.images import read_image, write_image
from caustica.metrics import relmse
from caustica.reference.render import render_reference
from caustica.scene.io import export_scene

BLENDER_SCRIPT = r'''
import json, sys, time
import bpy

glb, env, out, width, height, spps, repeats, threads, settings_dir = sys.argv[-9:]
sys.path.insert(0, settings_dir)
from cycles_reference import configure  # the product shots' Cycles settings: one place for both
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=glb)
scene = bpy.context.scene
scene.camera = next(o for o in scene.objects if o.type == "CAMERA")
configure(scene, 1, int(threads))
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = int(width), int(height), 100
c = scene.cycles
for material in bpy.data.materials:  # the importer's glass: keep it a smooth dielectric
    bsdf = material.node_tree and material.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None and bsdf.inputs["Transmission Weight"].default_value > 0.5:
        bsdf.inputs["Roughness"].default_value = 0.0
        bsdf.inputs["Metallic"].default_value = 0.0
world = bpy.data.worlds.new("env")
scene.world = world
world.use_nodes = True
nodes = world.node_tree.nodes
texture = nodes.new("ShaderNodeTexEnvironment")
texture.image = bpy.data.images.load(env)
texture.image.colorspace_settings.name = "Linear Rec.709"
texture.interpolation = "Linear"
world.node_tree.links.new(texture.outputs["Color"], nodes["Background"].inputs["Color"])
nodes["Background"].inputs["Strength"].default_value = 1.0
times = {}
for spp in (int(s) for s in spps.split(",")):
    c.samples = spp
    c.seed = spp
    runs = []
    for _ in range(int(repeats)):
        scene.render.filepath = f"{out}/cycles_{spp}.exr"
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        runs.append(time.perf_counter() - start)
    times[spp] = runs
    print(f"cycles {spp} spp: {min(runs):.2f} s", flush=True)
json.dump({"times": times, "version": bpy.app.version_string}, open(f"{out}/times.json", "w"))
'''


def blender_environment(scene, path: Path) -> None:
    """The scene's environment in Blender's convention (columns turned by a quarter), as linear EXR."""
    image = scene.environment.image
    write_image(path, np.roll(image, image.shape[1] // 4, axis=1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="glass-sphere")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--technique", default="auto")
    parser.add_argument("--blender-python", default="/tmp/bpyvenv/bin/python")
    parser.add_argument("--spp", default="1,2,4,8,16,32,64,128,256")
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json")
    args = parser.parse_args()
    scene = caustica.load_scene(args.scene)
    size = (args.size, args.size)
    folder = Path(tempfile.mkdtemp(prefix="bench_cycles_"))
    export_scene(scene, folder / "scene.glb")
    blender_environment(scene, folder / "env.exr")
    script = folder / "render.py"
    script.write_text(BLENDER_SCRIPT)
    subprocess.run([args.blender_python, str(script), str(folder / "scene.glb"), str(folder / "env.exr"), str(folder),
                    str(size[0]), str(size[1]), args.spp, str(args.repeats), str(args.threads),
                    str(Path(__file__).resolve().parent / "product_shots")], check=True)
    cycles = json.loads((folder / "times.json").read_text())
    reference = render_reference(scene, size=size, spp=args.reference_spp, progress=False, analytic_spheres=False)
    with caustica.Renderer(size) as renderer:
        image, layers = renderer.render(scene, args.technique, labels=["id"])
        sky = layers["id"] < 0  # the environment seen directly: checks the conventions agree
        times = []
        for _ in range(7):
            start = time.perf_counter()
            renderer.render(scene, args.technique)
            times.append(time.perf_counter() - start)
        ours_s, where, plan = min(times), renderer.info()["renderer"], renderer.last_plan
    ours = relmse(image, reference)
    rows = []
    for spp, runs in cycles["times"].items():
        picture = read_image(folder / f"cycles_{spp}.exr")
        rows.append({"spp": int(spp), "s": min(runs), "relmse": relmse(picture, reference),
                     "sky_relmse": relmse(picture, reference, sky) if sky.any() else float("nan")})
    name = plan.technique if plan is not None else args.technique
    print(f"{args.scene} {size[0]}x{size[1]}: caustica {args.technique} ({name}) relMSE {ours:.4g}, "
          f"{ours_s * 1000:.1f} ms/frame on {where}; Cycles {cycles['version']} CPU, {args.threads} threads; "
          f"Mitsuba reference {args.reference_spp} spp")
    print(f"caustica's relMSE on the sky pixels (environment seen directly): {relmse(image, reference, sky):.3g}")
    print("| Cycles spp | s per frame | relMSE | relMSE, sky pixels | caustica fps / Cycles fps |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['spp']} | {r['s']:.2f} | {r['relmse']:.4g} | {r['sky_relmse']:.3g} | {r['s'] / ours_s:.0f}x |")
    match = next((r for r in rows if r["relmse"] <= ours), None)
    print(f"fewest Cycles spp at least as close as caustica: "
          f"{match['spp'] if match else 'none of those tried'}" +
          (f" ({match['s'] / ours_s:.0f}x caustica's frame time)" if match else ""))
    if args.json:
        Path(args.json).write_text(json.dumps({"caustica": {"relmse": ours, "s": ours_s, "technique": name,
                                                            "renderer": where}, "cycles": rows,
                                               "version": cycles["version"]}, indent=2))


if __name__ == "__main__":
    main()
