"""Two-interface refraction measured: angular error, PSNR against exact and Mitsuba, ms per frame.

For the unit glass sphere at IOR 1.5, 1.75 and 0.8, the glass teapot and the
glass bunny (the last two need ../shared/data), renders env-map, image-space,
depth-search and exact at 512x512 and prints a markdown table; writes contact
sheets of the sphere (IOR 1.5) and the bunny to docs/images/. Rows
"depth-search +k" use our extension ``internal_bounces=k`` (not in the paper).
The ms column: the GPU techniques and the +k rows timed in turns (``--rounds``
rounds of one frame each after a warm-up), the ratio the median over rounds of
each frame over env-map's in the same round, so that the machine's drift hits
both alike; exact (CPU) is timed once. ``--quality`` adds the time-to-quality
ratio against Mitsuba on glass-sphere (``caustica bench``'s, with the bounce
variants).

    .venv/bin/python bench/bench_refraction.py [--size 512] [--reference-spp 512] [--spp 4] [--bounces 1,2]
        [--rounds 7] [--quality] [--scenes sphere]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import caustica
from caustica.bench.compare import compare
from caustica.bench.harness import time_to_quality
from caustica.bench.sheet import contact_sheet, save_sheet
from caustica.bench.timing import timed_in_turns, timed_render
from caustica.metrics import compare_images, psnr_linear, region_masks, relmse
from caustica.reference.render import render_reference
from caustica.renderer import Renderer
from caustica.scene import Glass

TECHNIQUES = ["env-map", "image-space", "depth-search", "exact"]
DOCS = Path(__file__).resolve().parents[1] / "docs" / "images"


def sphere_with_ior(ior: float):
    scene = caustica.load_scene("glass-sphere")
    scene.objects[0].material = Glass(ior=ior)
    scene.name = f"sphere-ior-{ior}"
    return scene


def scenes():
    yield "sphere, IOR 1.5", sphere_with_ior(1.5), "sphere"
    yield "sphere, IOR 1.75", sphere_with_ior(1.75), None
    yield "sphere, IOR 0.8", sphere_with_ior(0.8), None
    for preset, label in (("glass-teapot", "teapot, IOR 1.5"), ("glass-bunny", "bunny, IOR 1.5")):
        try:
            yield label, caustica.load_scene(preset), ("bunny" if preset == "glass-bunny" else None)
        except caustica.SceneError as exc:
            print(f"skipped {preset}: {exc}", file=sys.stderr)


def bounce_rows(scene, result, bounces, spp):
    """Rows for depth-search with ``internal_bounces`` = each of ``bounces`` (our extension), rendered
    after ``result`` (same scene, size, reference); their ms come from frame_times."""
    renderer = Renderer(result.size)
    camera = renderer.camera_for(scene)
    masks = region_masks(scene, camera, spp=max(1, spp))
    exact = next(r.image for r in result.results if r.technique == "exact")
    plain = next(r for r in result.results if r.technique == "depth-search")
    rows = []
    for k in bounces:
        image = renderer.render(scene, "depth-search", spp, internal_bounces=k)
        metrics = compare_images(image, result.reference_image, masks)
        rows.append((f"depth-search +{k}", plain.angular or {}, psnr_linear(image, exact), metrics["all"]["psnr_linear"],
                     metrics["refractor"]["psnr_linear"]))
    return rows


def frame_times(scene, size, spp, rounds, bounces) -> dict:
    """The GPU techniques (and depth-search +k) timed in turns: {name: (median ms, ratio to env-map)}."""
    variants = {name: (name, {}) for name in TECHNIQUES if name != "exact"}
    variants.update({f"depth-search +{k}": ("depth-search", {"internal_bounces": k}) for k in bounces})
    timed = timed_in_turns(Renderer((size, size)), scene, variants, spp, rounds, "env-map")
    return {name: (t["ms"], t["ratio"]) for name, t in timed.items()}


def quality_with_bounces(bounces, size=256, reference_spp=512):
    """``caustica bench``'s time to quality on glass-sphere, with depth-search's bounce variants added."""
    scene = caustica.load_scene("glass-sphere")
    result = time_to_quality(scene, ["env-map", "depth-search"], size, reference_spp, max_spp=1024,
                             log=lambda m: print(m, file=sys.stderr))
    reference = render_reference(scene, size=(size, size), spp=reference_spp, progress=False)
    renderer = Renderer((size, size))
    for k in bounces:
        image, ms = timed_render(renderer, scene, "depth-search", 1, 3, {"internal_bounces": k})
        result["techniques"][f"depth-search +{k}"] = {"ms": ms, "relmse": float(relmse(image, reference))}
    print(f"\ntime to quality, glass-sphere {size}^2 (1 spp; reference {reference_spp} spp):\n")
    print("| technique | relMSE | ms | Mitsuba spp to match | Mitsuba s | ratio |")
    print("|---|---|---|---|---|---|")
    for name, entry in result["techniques"].items():
        reached = next((c for c in result["mitsuba_curve"] if c["relmse"] <= entry["relmse"]), None)
        cells = (f"{reached['spp']} | {reached['seconds']:.2f} | {reached['seconds'] * 1000 / entry['ms']:.1f}"
                 if reached else "not reached | - | -")
        print(f"| {name} | {entry['relmse']:.5f} | {entry['ms']:.1f} | {cells} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--reference-spp", type=int, default=512)
    parser.add_argument("--frames", type=int, default=5, help="frames per technique in compare (images, metrics)")
    parser.add_argument("--rounds", type=int, default=7,
                        help="rounds of the GPU techniques timed in turns (the ms and ms / env-map columns)")
    parser.add_argument("--bounces", default="1,2", help="depth-search internal_bounces rows on the spheres ('' for none)")
    parser.add_argument("--quality", action="store_true", help="also the time-to-quality ratio on glass-sphere")
    parser.add_argument("--scenes", default="", help="only scenes whose label starts with this (e.g. 'sphere, IOR 1.5')")
    args = parser.parse_args()
    bounces = [int(k) for k in args.bounces.split(",") if k]
    rows = []
    renderer_name = None
    for label, scene, sheet_name in scenes():
        if not label.startswith(args.scenes):
            continue
        result = compare(scene, TECHNIQUES, size=(args.size, args.size), spp=args.spp, frames=args.frames,
                         reference_spp=args.reference_spp, log=lambda m: print(m, file=sys.stderr))
        renderer_name = result.renderer
        exact = next(r.image for r in result.results if r.technique == "exact")
        scene_bounces = bounces if label.startswith("sphere") else []
        print(f"timing {label} in {args.rounds} rounds ...", file=sys.stderr)
        times = frame_times(scene, args.size, args.spp, args.rounds, scene_bounces)
        env_ms = times["env-map"][0]
        times["exact"] = (next(r.ms for r in result.results if r.technique == "exact"), None)  # CPU: timed once
        for r in result.results:
            angular = r.angular or {}
            ms, ratio = times[r.technique]
            rows.append((label, r.technique, angular.get("mean_deg", np.nan), angular.get("p95_deg", np.nan),
                         psnr_linear(r.image, exact), r.metrics["all"]["psnr_linear"],
                         r.metrics["refractor"]["psnr_linear"], ms, ms / env_ms if ratio is None else ratio))
        for name, angular, vs_exact, vs_ref, vs_ref_refr in bounce_rows(scene, result, scene_bounces, args.spp):
            rows.insert(-1, (label, name, angular.get("mean_deg", np.nan), angular.get("p95_deg", np.nan),
                             vs_exact, vs_ref, vs_ref_refr, *times[name]))
        if sheet_name:
            DOCS.mkdir(parents=True, exist_ok=True)
            sheet_rows = [(r.technique, r.image, r.error_map) for r in result.results]
            save_sheet(contact_sheet(sheet_rows, result.reference_image, "reference: mitsuba"),
                       DOCS / f"refraction-{sheet_name}.png")
    print(f"\n{args.size}x{args.size}, techniques at {args.spp} spp, Mitsuba reference at {args.reference_spp} spp; "
          f"GL: {renderer_name}\n")
    print("| scene | technique | angle mean (deg) | angle p95 (deg) | PSNR vs exact | PSNR vs Mitsuba | "
          "PSNR vs Mitsuba, refractor | ms | ms / env-map |")
    print("|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        label, name, mean, p95, vs_exact, vs_ref, vs_ref_refr, ms, ratio = row
        exact_cell = "-" if name == "exact" else f"{vs_exact:.2f}"
        print(f"| {label} | {name} | {mean:.3f} | {p95:.3f} | {exact_cell} | {vs_ref:.2f} | {vs_ref_refr:.2f} | "
              f"{ms:.1f} | {ratio:.2f} |")
    if args.quality:
        quality_with_bounces(bounces)


if __name__ == "__main__":
    main()
