"""Throughput of the photon oracle (``caustica.raytrace.photons.trace_photons``): photons per second.

Usage: ``.venv/bin/python bench/bench_photons.py [--photons N]``. Scenes: the
``caustics-point`` preset (analytic glass sphere) and ``caustics-bunny`` (69K
triangles, from ../shared/data; skipped when missing). Photons are counted as
emitted (per channel pass); a photon splits at glass, so the rays traced per
photon are printed too. Wall clock on the CPU; the machine is printed with them.
"""
from __future__ import annotations

import argparse
import os
import platform
import time

from caustica.errors import SceneError
from caustica.raytrace.embree_scene import ray_scene_for
from caustica.raytrace.photons import trace_photons
from caustica.scene.presets import PRESETS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photons", type=int, default=1_000_000)
    args = parser.parse_args()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, {args.photons} photons")
    for name in ("caustics-point", "caustics-bunny"):
        try:
            scene = PRESETS[name]()
        except SceneError as exc:
            print(f"{name}: skipped ({exc})")
            continue
        ray_scene = ray_scene_for(scene)  # built outside the timing
        trace_photons(scene, count=10_000)
        before = ray_scene.rays_traced
        start = time.perf_counter()
        hits = trace_photons(scene, count=args.photons)
        seconds = time.perf_counter() - start
        rays = ray_scene.rays_traced - before
        print(f"{name}: {args.photons / seconds:,.0f} photons/s ({seconds:.2f} s, {rays / args.photons:.2f} rays "
              f"per photon, {rays / seconds:,.0f} rays/s, {len(hits)} caustic hits)")


if __name__ == "__main__":
    main()
