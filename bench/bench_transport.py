"""Benchmark of the light transport table (Iwasaki et al., Table 1): precompute time, table size, frame time.

    .venv/bin/python bench/bench_transport.py [--json out/transport.json] [--no-frames] [--size 512]

Precompute (129 directions, 2 cores) and table sizes raw / quantized / file for the sphere, torus,
teapot and bunny; then ms per frame of every ``transport-*`` preset with ``depth-search+transport-table``,
both the frame that rebuilds the caustic maps and the cached frame, against ``plain``.
Timing on llvmpipe is wall clock after ctx.finish(), reported with the GL renderer.
"""
from __future__ import annotations

import argparse
import io
import json
import sys
import time
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "models"


def meshes():
    from caustica.scene.mesh_files import load_mesh
    from caustica.scene.shapes import sphere, torus

    yield "sphere", sphere(0.5, subdivisions=5)
    yield "torus", torus(0.6, 0.22, segments=96, sides=48)
    for name in ("teapot", "stanford-bunny"):
        if (SHARED / f"{name}.obj").exists():
            yield name, load_mesh(SHARED / f"{name}.obj")


def bench_precompute() -> list[dict]:
    from caustica.transport.compress import quantization_errors, quantize, table_bytes
    from caustica.transport.precompute import precompute_table

    rows = []
    for name, mesh in meshes():
        table = precompute_table(mesh, 1.5, 129, progress=False)
        q = quantize(table)
        e = quantization_errors(table, q)
        row = {"mesh": name, "vertices": table.vertex_count, "seconds": round(table.stats["seconds"], 2),
               "raw_mb": e["raw_bytes"] / 1e6, "quantized_mb": e["quantized_bytes"] / 1e6,
               "file_mb": len(table_bytes(q)) / 1e6, "bytes_per_sample": e["bytes_per_sample"],
               "position_error_percent": e["position_error_percent"], "direction_error_percent": e["direction_error_percent"]}
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


def bench_frames(size: int, only: list[str] | None = None) -> list[dict]:
    from caustica import load_scene
    from caustica.renderer import Renderer
    from caustica.scene.presets_transport import TRANSPORT_PRESETS

    renderer = Renderer((size, size))
    rows = []
    for preset in only or TRANSPORT_PRESETS:
        try:
            scene = load_scene(preset)
        except Exception as exc:  # missing shared data
            print(f"skip {preset}: {exc}", file=sys.stderr)
            continue
        renderer.render(scene, "depth-search+transport-table")  # precompute / load the tables
        t = {}
        for technique in ("plain", "depth-search", "depth-search+transport-table"):
            renderer.render(scene, technique)
            start = time.perf_counter()
            for _ in range(3):
                renderer.render(scene, technique)
            t[technique] = (time.perf_counter() - start) / 3 * 1e3
        # A frame whose light moved: the caustic maps are rebuilt.
        light = scene.lights[0]
        start = time.perf_counter()
        for k in range(3):
            if hasattr(light, "start"):
                light.start, light.end = np.asarray(light.start) + [0.01, 0, 0], np.asarray(light.end) + [0.01, 0, 0]
            elif hasattr(light, "position"):
                light.position = np.asarray(light.position) + [0.01, 0.0, 0.0]
            else:
                light.direction = light.direction + np.array([0.001, 0.0, 0.0])
                light.direction /= np.linalg.norm(light.direction)
            renderer.render(scene, "depth-search+transport-table")
        rebuild = (time.perf_counter() - start) / 3 * 1e3
        row = {"preset": preset, "plain_ms": t["plain"], "depth_search_ms": t["depth-search"],
               "cached_ms": t["depth-search+transport-table"], "rebuild_ms": rebuild,
               "cached_over_plain": t["depth-search+transport-table"] / t["plain"], "rebuild_over_plain": rebuild / t["plain"]}
        print(json.dumps({k: round(v, 2) if isinstance(v, float) else v for k, v in row.items()}), flush=True)
        rows.append(row)
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--no-frames", action="store_true")
    parser.add_argument("--no-precompute", action="store_true")
    parser.add_argument("--presets", help="comma-separated transport presets (default: all)")
    args = parser.parse_args()
    from caustica.gpu.context import describe, shared_context

    out = {"renderer": describe(shared_context())["renderer"]}
    print(out["renderer"])
    if not args.no_precompute:
        out["precompute"] = bench_precompute()
    if not args.no_frames:
        out["frames"] = bench_frames(args.size, args.presets.split(",") if args.presets else None)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
