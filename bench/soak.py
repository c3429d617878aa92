"""Soak: many frames in one process, memory and GL objects must stay flat after the warm-up (issue 17).

One Renderer draws ``--frames`` frames while the image size changes (every 50 frames, between
the ``--sizes`` bounds), the technique changes every frame (env-map, depth-search, image-space,
photon-splats, caustic-mapping), parameters change (splat radius, map sizes, search steps) and
the scene is reloaded every ``--reload-every`` frames (a preset from disk-free presets, or the
animated pool at a new time, so meshes and environment images are new objects each time).
Every ``--report-every`` frames it prints resident memory (VmRSS), the GL names alive (glIs*)
and the device's pool counts; at the end, the growth per reload after the warm-up.

    .venv/bin/python bench/soak.py [--frames 10000] [--sizes 48,96] [--report-every 500] [--json out.json]

Diagnostics (off by default): ``--malloc`` adds glibc's view (mallinfo2: bytes in use, free bytes
kept in the arenas, the number of arenas) and /proc/self/smaps_rollup's Anonymous; ``--trim``
calls malloc_trim(0) before each RSS reading; ``--tracemalloc A,B`` compares Python allocations
between frames A and B (top 15 by traceback) and counts the numpy arrays alive at both.
"""
from __future__ import annotations

import argparse
import ctypes
import gc
import json
import re
import tempfile
import time
from pathlib import Path

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


class _MallInfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in
                ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]


_LIBC = None


def libc():
    global _LIBC
    if _LIBC is None:
        _LIBC = ctypes.CDLL("libc.so.6")
        _LIBC.mallinfo2.restype = _MallInfo2
        _LIBC.malloc_trim.argtypes = [ctypes.c_size_t]
        _LIBC.fopen.restype = ctypes.c_void_p
        _LIBC.fopen.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
        _LIBC.fclose.argtypes = [ctypes.c_void_p]
        _LIBC.malloc_info.argtypes = [ctypes.c_int, ctypes.c_void_p]
    return _LIBC


def malloc_state() -> dict:
    """glibc's heap (all arenas): MB in use, MB free but kept, MB in mmapped chunks, arenas; smaps Anonymous MB."""
    info = libc().mallinfo2()
    with tempfile.NamedTemporaryFile(suffix=".xml") as xml:  # malloc_info writes to a FILE*
        stream = libc().fopen(xml.name.encode(), b"w")
        libc().malloc_info(0, stream)
        libc().fclose(stream)
        arenas = len(re.findall(r'<heap nr="\d+">', Path(xml.name).read_text()))
    with open("/proc/self/smaps_rollup") as rollup:
        anonymous = next(int(line.split()[1]) for line in rollup if line.startswith("Anonymous:"))
    mb = 1 << 20
    return {"in_use_mb": round(info.uordblks / mb, 1), "free_kept_mb": round(info.fordblks / mb, 1),
            "mmapped_mb": round(info.hblkhd / mb, 1), "arenas": arenas, "anonymous_mb": round(anonymous / 1024, 1)}


def numpy_arrays() -> tuple[int, float]:
    """numpy arrays that own their data and that an object the garbage collector tracks refers to
    (arrays are not tracked themselves): how many, and their MB."""
    import numpy as np

    arrays = {}
    for holder in gc.get_objects():
        for o in gc.get_referents(holder):
            if isinstance(o, np.ndarray) and o.base is None:
                arrays[id(o)] = o
    return len(arrays), sum(a.nbytes for a in arrays.values()) / (1 << 20)


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
    parser.add_argument("--malloc", action="store_true", help="also report glibc's arenas and smaps' Anonymous")
    parser.add_argument("--trim", action="store_true", help="malloc_trim(0) before each RSS reading")
    parser.add_argument("--tracemalloc", help="A,B: compare Python allocations between frames A and B")
    args = parser.parse_args()
    low, high = (int(s) for s in args.sizes.split(","))
    snapshots = [int(f) for f in args.tracemalloc.split(",")] if args.tracemalloc else []
    if snapshots:
        import tracemalloc
        tracemalloc.start(12)

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
        if frame in snapshots:
            gc.collect()
            arrays = numpy_arrays()
            snapshots[snapshots.index(frame)] = (frame, tracemalloc.take_snapshot(), arrays)
            print(f"frame {frame}: Python allocations {tracemalloc.get_traced_memory()[0] / (1 << 20):.1f} MB, "
                  f"{arrays[0]} numpy arrays owning {arrays[1]:.1f} MB", flush=True)
        if frame % args.report_every == 0:
            trim_ms = None
            if args.trim:
                tick = time.perf_counter()
                libc().malloc_trim(0)
                trim_ms = (time.perf_counter() - tick) * 1000.0
            names, counts = live_gl_names(renderer.device.ctx), renderer.device.counts()
            elapsed = time.perf_counter() - start
            row = {"frame": frame, "rss_mb": round(resident_mb(), 1), "gl": names, "pools": counts, "reloads": reloads,
                   "seconds": round(elapsed, 1)}
            if args.malloc:
                row["malloc"] = malloc_state()
            if trim_ms is not None:
                row["trim_ms"] = round(trim_ms, 2)
            rows.append(row)
            print(f"{frame:>6} {row['rss_mb']:>8.1f} {names['total']:>8} {names.get('texture', 0):>4} "
                  f"{names.get('buffer', 0):>4} {names.get('framebuffer', 0):>4} {names.get('program', 0):>4} "
                  f"{names.get('vertexarray', 0):>4} {counts['free_textures']:>9} {counts['framebuffers']:>9} "
                  f"{counts['meshes']:>6} {counts['environments']:>3} {counts['cached']:>6} "
                  f"{elapsed / max(frame, 1):>7.3f}", flush=True)
            if args.malloc:
                print(f"{'':>6} malloc: {row['malloc']}" + (f", malloc_trim {trim_ms:.1f} ms" if args.trim else ""),
                      flush=True)
            if warm is None and frame >= args.warmup:
                warm = (reloads, row["rss_mb"])
        if frame == args.frames:
            break
        technique, params = technique_for(frame)
        renderer.size = size_for(frame, low, high)
        renderer.render(scene, technique, **params)
    renderer.close()
    if len(snapshots) == 2 and all(isinstance(s, tuple) for s in snapshots):
        (a, first, arrays_a), (b, second, arrays_b) = snapshots
        print(f"numpy arrays alive (count, MB): frame {a} {arrays_a[0]}, {arrays_a[1]:.1f}; "
              f"frame {b} {arrays_b[0]}, {arrays_b[1]:.1f}")
        print(f"Python allocations, frame {a} -> {b}, top 15 by traceback:")
        for stat in second.compare_to(first, "traceback")[:15]:
            print(f"  {stat.size_diff / 1024:+10.1f} KiB {stat.count_diff:+6d} blocks")
            for line in stat.traceback.format()[-6:]:
                print("     " + line)

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
