"""Benchmark: ms per frame of the presets at 256, 512, 1024 for env-map and plain.

Prints the GL renderer string with every figure; on llvmpipe the clock is wall
time around ctx.finish(). Also reports the env-map / plain ratio (same run),
the exact oracle's rays per second, and the peak memory of a `caustica render`.

    .venv/bin/python bench/bench_presets.py [--sizes 256,512,1024] [--frames 5] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import caustica
from caustica.renderer import Renderer


def time_frames(renderer, scene, technique, frames):
    renderer.render(scene, technique)  # warm-up: shader compile, uploads, shadow maps
    return statistics.median(renderer.render_timed(scene, technique)[1] for _ in range(frames))


def peak_memory_of_cli_render(preset: str) -> float:
    """Peak resident memory (MB) of a separate `caustica render` process."""
    with tempfile.TemporaryDirectory() as tmp:
        code = ("import resource, sys; from caustica.cli import main; rc = main(sys.argv[1:]); "
                "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0); sys.exit(rc)")
        out = subprocess.run([sys.executable, "-c", code, "render", preset, "-o", f"{tmp}/x.png"],
                             capture_output=True, text=True, check=True)
        return float(out.stdout.strip().splitlines()[-1])


def exact_rays_per_second(scene, size=256):
    renderer = Renderer((size, size))
    start = time.perf_counter()
    renderer.render(scene, "exact")
    return size * size / (time.perf_counter() - start)


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
        rate = exact_rays_per_second(caustica.load_scene(preset))
        results[f"exact_primary_rays_per_s_{preset}"] = rate
        print(f"exact oracle, {preset}: {rate / 1e6:.2f} M primary rays/s (full paths, 256^2, CPU)", flush=True)
        mb = peak_memory_of_cli_render(preset)
        results[f"peak_rss_mb_{preset}"] = mb
        print(f"peak memory of 'caustica render {preset}': {mb:.0f} MB", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
