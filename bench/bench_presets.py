"""Benchmark: ms per frame of the presets at 256, 512, 1024 for env-map and plain.

Prints the GL renderer string with every figure; on llvmpipe the clock is wall
time around ctx.finish(). Also reports the env-map / plain ratio (same run),
the exact oracle's rays per second, and the peak memory of a `caustica render`.

    .venv/bin/python bench/bench_presets.py [--sizes 256,512,1024] [--frames 5] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import caustica
from caustica.bench.timing import timed_render
from caustica.renderer import Renderer


def time_frames(renderer, scene, technique, frames):
    """Median ms of ``frames`` frames after a warm-up (shader compile, uploads, shadow maps)."""
    return timed_render(renderer, scene, technique, 1, frames)[1]


def peak_memory_of_cli_render(preset: str) -> float:
    """Peak resident memory (MB) of a separate `caustica render` process.

    Read from /proc/self/status (VmHWM): ru_maxrss would include the forking
    parent's peak on Linux.
    """
    with tempfile.TemporaryDirectory() as tmp:
        code = ("import sys; from caustica.cli import main; rc = main(sys.argv[1:]); "
                "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0]; "
                "print(int(hwm.split()[1]) / 1024.0); sys.exit(rc)")
        out = subprocess.run([sys.executable, "-c", code, "render", preset, "-o", f"{tmp}/x.png"],
                             capture_output=True, text=True, check=True)
        return float(out.stdout.strip().splitlines()[-1])


def exact_rays_per_second(scene, size=256):
    """(primary rays/s, all rays/s) of a full ``exact`` render: every intersect and shadow ray counts."""
    from caustica.raytrace.embree_scene import ray_scene_for

    renderer = Renderer((size, size))
    renderer.render(scene, "exact")  # warm-up: builds the Embree scene
    ray_scene = ray_scene_for(scene)
    before = ray_scene.rays_traced
    start = time.perf_counter()
    renderer.render(scene, "exact")
    seconds = time.perf_counter() - start
    return size * size / seconds, (ray_scene.rays_traced - before) / seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="256,512,1024")
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    results = {"renderer": None, "frames": []}
    for preset in ("glass-sphere", "caustic-sphere"):
        scene = caustica.load_scene(preset)
        for size in sizes:
            renderer = Renderer((size, size))
            env_ms = time_frames(renderer, scene, "env-map", args.frames)
            plain_ms = time_frames(renderer, scene, "plain", args.frames)
            gl = renderer.info()["renderer"]
            results["renderer"] = gl
            row = {"preset": preset, "size": size, "env_map_ms": env_ms, "plain_ms": plain_ms,
                   "ratio": env_ms / plain_ms, "renderer": gl}
            results["frames"].append(row)
            print(f"{preset:15s} {size:5d}^2  env-map {env_ms:8.2f} ms  plain {plain_ms:8.2f} ms  "
                  f"ratio {env_ms / plain_ms:4.2f}  [{gl}]", flush=True)
    for preset in ("glass-sphere", "caustic-sphere"):
        primary, total = exact_rays_per_second(caustica.load_scene(preset))
        results[f"exact_primary_rays_per_s_{preset}"] = primary
        results[f"exact_rays_per_s_{preset}"] = total
        print(f"exact oracle, {preset}: {total / 1e6:.2f} M rays/s all rays, {primary / 1e6:.2f} M pixels/s "
              f"(256^2, 1 spp, CPU)", flush=True)
        mb = peak_memory_of_cli_render(preset)
        results[f"peak_rss_mb_{preset}"] = mb
        print(f"peak memory of 'caustica render {preset}': {mb:.0f} MB", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
