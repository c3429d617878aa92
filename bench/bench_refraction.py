"""Two-interface refraction measured: angular error, PSNR against exact and Mitsuba, ms per frame.

For the unit glass sphere at IOR 1.5, 1.75 and 0.8, the glass teapot and the
glass bunny (the last two need ../shared/data), renders env-map, image-space,
depth-search and exact at 512x512 and prints a markdown table; writes contact
sheets of the sphere (IOR 1.5) and the bunny to docs/images/.

    .venv/bin/python bench/bench_refraction.py [--size 512] [--reference-spp 512] [--spp 4]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import caustica
from caustica.bench.compare import compare
from caustica.bench.sheet import contact_sheet, save_sheet
from caustica.metrics import psnr_linear
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--reference-spp", type=int, default=512)
    parser.add_argument("--frames", type=int, default=5)
    args = parser.parse_args()
    rows = []
    renderer_name = None
    for label, scene, sheet_name in scenes():
        result = compare(scene, TECHNIQUES, size=(args.size, args.size), spp=args.spp, frames=args.frames,
                         reference_spp=args.reference_spp, log=lambda m: print(m, file=sys.stderr))
        renderer_name = result.renderer
        exact = next(r.image for r in result.results if r.technique == "exact")
        env_ms = next(r.ms for r in result.results if r.technique == "env-map")
        for r in result.results:
            angular = r.angular or {}
            rows.append((label, r.technique, angular.get("mean_deg", np.nan), angular.get("p95_deg", np.nan),
                         psnr_linear(r.image, exact), r.metrics["all"]["psnr_linear"],
                         r.metrics["refractor"]["psnr_linear"], r.ms, r.ms / env_ms))
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


if __name__ == "__main__":
    main()
