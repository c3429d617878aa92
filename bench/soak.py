"""Soak: many frames in one process, memory and GL objects must stay flat after the warm-up (issue 17).

One Renderer draws ``--frames`` frames while the image size changes (every 50 frames, between
the ``--sizes`` bounds), the technique changes every frame (env-map, depth-search, image-space,
photon-splats, caustic-mapping), parameters change (splat radius, map sizes, search steps) and
the scene is reloaded every ``--reload-every`` frames (a preset from disk-free presets, or the
animated pool at a new time, so meshes and environment images are new objects each time).
Every ``--report-every`` frames it prints resident memory (VmRSS), the GL names alive (glIs*)
and the device's pool counts; at the end, the growth per reload after the warm-up.

    .venv/bin/python bench/soak.py [--frames 10000] [--sizes 48,96] [--report-every 500] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import time

from caustica.gpu.census import live_gl_names
from caustica.gpu.context import describe
from caustica.renderer import Renderer
from caustica.scene.io import load_scene
from caustica.scene.presets import pool_scene

PRESETS = ("caustics-point", "glass-sphere", "caustics-spot", "caustics-pool")


def resident_mb() -> float:
    """VmRSS of this process in MB."""
    with open("/proc/self/status") as status:
        line = next(line for line in status if line.startswith("VmRSS"))
    return int(line.split()[1]) / 1024.0


def technique_for(frame: int) -> tuple[str, dict]:
    """The frame's technique and parameters: five techniques in turn, parameters varying slowly."""
    k = frame // 5
    choices = (
        ("env-map", {"shadow_map_size": (128, 256)[k % 2]}),
        ("depth-search", {"shadow_map_size": 128, "search_steps": (4, 8)[k % 2]}),
        ("image-space", {"shadow_map_size": 128, "tir_mode": ("clamp", "keep-t1")[k % 2]}),
        ("photon-splats", {"shadow_map_size": 128, "photon_buffer_size": 64, "caustic_map_size": (32, 64)[k % 2],
                           "splat_radius": (1.0, 1.5, 2.0)[k % 3]}),
        ("caustic-mapping", {"shadow_map_size": 128, "map_size": (48, 64)[k % 2], "photon_grid": 64,
                             "splat_radius": (1.0, 1.5)[k % 2]}),
    )
    return choices[frame % len(choices)]


def size_for(frame: int, low: int, high: int) -> tuple[int, int]:
    """Square and non-square sizes between ``low`` and ``high``, a new one every 50 frames."""
    steps = [low + (high - low) * i // 3 for i in range(4)]
    width = steps[(frame // 50) % 4]
    height = steps[(frame // 200) % 4]
    return width, height


def scene_for(reload: int):
    """Every fourth reload the animated pool at a new time; the others a preset loaded anew."""
    if reload % 4 == 3:
        return pool_scene(0.04 * reload)
    return load_scene(PRESETS[reload % 3])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=10_000)
    parser.add_argument("--sizes", default="48,96", help="smallest,largest image side")
    parser.add_argument("--reload-every", type=int, default=10)
    parser.add_argument("--report-every", type=int, default=500)
    parser.add_argument("--warmup", type=int, default=1000,
                        help="frames before the growth is measured (every size is drawn by frame 800)")
    parser.add_argument("--json", help="write the rows and the summary here")
    args = parser.parse_args()
    low, high = (int(s) for s in args.sizes.split(","))

    renderer = Renderer()
    rows, reloads, scene, start = [], 0, None, time.perf_counter()
    warm = None  # (reloads, RSS MB) at the end of the warm-up
    gl_renderer = describe(renderer.device.ctx)["renderer"]
    print(f"GL renderer: {gl_renderer}")
    print(f"{'frame':>6} {'RSS MB':>8} {'GL names':>8} {'tex':>4} {'buf':>4} {'fbo':>4} {'prog':>4} {'vao':>4} "
          f"{'pool free':>9} {'fbo cache':>9} {'meshes':>6} {'env':>3} {'cached':>6} {'s/frame':>7}")
    for frame in range(args.frames + 1):
        if frame % args.reload_every == 0:
            scene, reloads = scene_for(reloads), reloads + 1
        if frame % args.report_every == 0:
            names, counts = live_gl_names(renderer.device.ctx), renderer.device.counts()
            elapsed = time.perf_counter() - start
            row = {"frame": frame, "rss_mb": round(resident_mb(), 1), "gl": names, "pools": counts, "reloads": reloads,
                   "seconds": round(elapsed, 1)}
            rows.append(row)
            print(f"{frame:>6} {row['rss_mb']:>8.1f} {names['total']:>8} {names.get('texture', 0):>4} "
                  f"{names.get('buffer', 0):>4} {names.get('framebuffer', 0):>4} {names.get('program', 0):>4} "
                  f"{names.get('vertexarray', 0):>4} {counts['free_textures']:>9} {counts['framebuffers']:>9} "
                  f"{counts['meshes']:>6} {counts['environments']:>3} {counts['cached']:>6} "
                  f"{elapsed / max(frame, 1):>7.3f}", flush=True)
            if warm is None and frame >= args.warmup:
                warm = (reloads, row["rss_mb"])
        if frame == args.frames:
            break
        technique, params = technique_for(frame)
        renderer.size = size_for(frame, low, high)
        renderer.render(scene, technique, **params)
    renderer.close()

    summary = {"frames": args.frames, "reloads": reloads, "renderer": gl_renderer}
    if warm is not None and reloads > warm[0]:
        growth = (rows[-1]["rss_mb"] - warm[1]) / (reloads - warm[0])
        summary.update(warmup_frames=args.warmup, rss_after_warmup_mb=warm[1], rss_end_mb=rows[-1]["rss_mb"],
                       growth_mb_per_reload=round(growth, 4))
        print(f"RSS after warm-up {warm[1]:.1f} MB, at the end {rows[-1]['rss_mb']:.1f} MB: "
              f"{growth:+.4f} MB per reload over {reloads - warm[0]} reloads (target: under 0.5)")
    if args.json:
        with open(args.json, "w") as out:
            json.dump({"rows": rows, "summary": summary}, out, indent=1)


if __name__ == "__main__":
    main()
