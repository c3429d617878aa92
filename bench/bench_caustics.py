"""Caustic techniques measured: caustic-region error against Mitsuba, caustic-map and frame milliseconds.

At 512x512 on ``caustic-sphere`` (and ``caustics-bunny`` when ../shared/data
holds the bunny), for ``depth-search+caustic-mapping`` and
``depth-search+photon-splats``: relMSE and PSNR of the caustic region
(diffuse pixels in a refractor's geometric shadow) against the Mitsuba
reference (``caustica.bench.compare``), the milliseconds to build the caustic
map (the CachedPasses of the caustic technique on a forced rebuild, profiled
per pass; median of ``--frames``), the full frame with the map cached (median
of ``--frames`` after a warm-up) and its ratio to ``plain`` (every object
diffuse, shadow-mapped). Prints a markdown table and writes the contact sheet
docs/images/caustics-sphere.png (each technique, its FLIP error map, Mitsuba).

    .venv/bin/python bench/bench_caustics.py [--size 512] [--reference-spp 512] [--frames 5]
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import caustica
from caustica.bench.compare import compare
from caustica.bench.sheet import contact_sheet, save_sheet
from caustica.bench.timing import timed_render
from caustica.render.graph import evict
from caustica.renderer import Renderer

TECHNIQUES = ["depth-search+caustic-mapping", "depth-search+photon-splats"]
DOCS = Path(__file__).resolve().parents[1] / "docs" / "images"


def log(message: str) -> None:
    print(message, file=sys.stderr)


def caustic_map_ms(renderer: Renderer, scene, technique: str, frames: int) -> tuple[float, dict]:
    """Median ms of the caustic technique's CachedPasses on a rebuild, and its inner passes' ms (last rebuild)."""
    tag = technique.split("+")[1]
    renderer.render(scene, technique)  # compile shaders, upload d_N
    totals, inner = [], {}
    for _ in range(max(1, frames)):
        evict(renderer.device.cache, f"CachedPasses({tag})")
        renderer.render(scene, technique)
        ms = renderer.last_pass_ms
        totals.append(ms[f"CachedPasses({tag})"])
        inner = {k: v for k, v in ms.items() if not k.startswith((
            "CachedPasses", "ShadowMaps", "EnvironmentLobeMaps", "EnvironmentLightMaps", "ShadeSurfaces",
            "RefractorSurfaces", "FrontDistance"))}
    return statistics.median(totals), inner


def scenes():
    yield "caustic-sphere", caustica.load_scene("caustic-sphere"), "caustics-sphere.png"
    try:
        yield "caustics-bunny", caustica.load_scene("caustics-bunny"), None
    except caustica.SceneError as exc:
        log(f"skipped caustics-bunny: {exc}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--reference-spp", type=int, default=512)
    parser.add_argument("--frames", type=int, default=5)
    args = parser.parse_args()
    size = (args.size, args.size)
    rows, notes, gl = [], [], None
    for name, scene, sheet in scenes():
        try:
            result = compare(scene, TECHNIQUES, size=size, spp=1, frames=args.frames,
                             reference_spp=args.reference_spp, progress=False, log=log)
        except Exception as exc:  # noqa: BLE001 - the reference renderer may reject a scene
            notes.append(f"{name}: no Mitsuba reference ({type(exc).__name__}: {str(exc).splitlines()[0][:160]})")
            result = None
        timer = Renderer(size)
        profiler = Renderer(size, profile_passes=True)
        _, plain_ms = timed_render(timer, scene, "plain", 1, args.frames)
        gl = timer.info()["renderer"]
        for technique in TECHNIQUES:
            build_ms, inner = caustic_map_ms(profiler, scene, technique, args.frames)
            _, frame_ms = timed_render(timer, scene, technique, 1, args.frames)
            metrics = None
            if result is not None:
                metrics = next(r for r in result.results if r.technique == technique).metrics["caustic"]
            rows.append((name, technique, metrics, build_ms, frame_ms, plain_ms))
            slowest = sorted(inner.items(), key=lambda kv: -kv[1])[:4]
            log(f"{name} {technique}: caustic map {build_ms:.1f} ms; slowest inner passes: "
                + ", ".join(f"{k} {v:.1f}" for k, v in slowest))
        if sheet and result is not None:
            DOCS.mkdir(parents=True, exist_ok=True)
            sheet_rows = [(r.technique, r.image, r.error_map) for r in result.results]
            save_sheet(contact_sheet(sheet_rows, result.reference_image, "reference: mitsuba"), DOCS / sheet)
            notes.append(f"contact sheet: docs/images/{sheet}")
        if result is not None:
            notes.append(f"{name}: reference {result.reference}; caustic region {result.region_pixels['caustic']} pixels")
    print(f"\n{args.size}x{args.size}, 1 spp, ms: median of {args.frames} frames; GL: {gl}\n")
    print("| scene | technique | caustic relMSE | caustic PSNR (dB) | caustic map (ms) | frame (ms) | plain (ms) "
          "| frame / plain |")
    print("|---|---|---|---|---|---|---|---|")
    for name, technique, metrics, build_ms, frame_ms, plain_ms in rows:
        error = "-" if metrics is None else f"{metrics['relmse']:.4f}"
        psnr = "-" if metrics is None else f"{metrics['psnr_linear']:.2f}"
        print(f"| {name} | {technique} | {error} | {psnr} | {build_ms:.1f} | {frame_ms:.1f} | {plain_ms:.1f} "
              f"| {frame_ms / plain_ms:.2f} |")
    for note in notes:
        print(f"\n{note}")


if __name__ == "__main__":
    main()
