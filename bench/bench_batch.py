"""Benchmark: caustica batch frames per second, and its overhead over a bare Renderer loop.

An orbit of a glass scene (default caustic-sphere, technique auto) at each size, with 1 and 2 spawned
or in-process workers and on a local Ray (2 CPUs), without and with every label layer. ``fps`` is
frames over the run's wall clock, start-up included (processes, GL contexts, shaders, Ray);
``steady fps`` counts the frames after each worker's first, over the time from the first row to the
last (manifest ``time``). The batch overhead is, in the 1-worker run, the median per frame of the
time between rows less the row's render and file times (scene edits, checks, manifest, progress),
less what a bare ``Renderer.render_timed`` loop over the same frames spends outside its clock,
as a share of that loop's median render call. Measured frame by frame, it does not drift with the
load of a shared machine as a comparison of two runs' totals would.

    .venv/bin/python bench/bench_batch.py [--scene caustic-sphere] [--sizes 256,512] [--frames 48]
        [--no-ray] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import caustica
from caustica.batch.edits import SceneEditor
from caustica.batch.job import make_job
from caustica.images import write_image
from caustica.labels import LABELS


def bare_loop(scene_name: str, size: int, frames: int, technique: str, folder: Path, labels) -> dict:
    """A plain loop over the orbit's scenes: each frame's render (ms as the batch measures it, and the
    call's wall time) and its files' writing."""
    from caustica.labels import write_labels

    folder.mkdir(parents=True, exist_ok=True)
    job, base = make_job(scene_name, folder, frames=frames, orbit=360, size=(size, size))
    editor = SceneEditor(base)
    scenes = [editor.apply(job.values(i)) for i in range(frames)]
    calls, untimed, writes = [], [], []
    with caustica.Renderer((size, size)) as renderer:
        renderer.render(scenes[0], technique, **({"labels": labels} if labels else {}))  # warm-up
        for i, s in enumerate(scenes):
            start = time.perf_counter()
            if labels:
                image, layers = renderer.render(s, technique, labels=labels)
                ms = (time.perf_counter() - start) * 1000.0
            else:
                image, ms = renderer.render_timed(s, technique)
            rendered = time.perf_counter()
            write_image(folder / f"{i}.png", image)
            if labels:
                write_labels(folder / f"{i}.labels.exr", layers, "exr")
            calls.append((rendered - start) * 1000.0)
            untimed.append(calls[-1] - ms)
            writes.append((time.perf_counter() - rendered) * 1000.0)
    return {"render_ms": statistics.median(calls), "untimed_ms": statistics.median(untimed),
            "write_ms": statistics.median(writes), "renderer": renderer_name()}


def renderer_name() -> str:
    from caustica.gpu.context import describe, shared_context

    return describe(shared_context())["renderer"]


def batch_run(scene_name: str, size: int, frames: int, technique: str, folder: Path, workers: int, ray,
              labels) -> dict:
    start = time.perf_counter()
    rows = caustica.batch(scene_name, folder, frames, orbit=360, size=(size, size), technique=technique,
                          labels=labels, workers=workers, ray=ray)
    wall = time.perf_counter() - start
    assert all("error" not in r for r in rows), [r["error"] for r in rows if "error" in r][:1]
    firsts = {}
    for r in sorted(rows, key=lambda r: r["time"]):
        firsts.setdefault(r["worker"], r["time"])
    times = sorted(r["time"] for r in rows)
    later = [r for r in rows if r["time"] > firsts[r["worker"]]]
    span = times[-1] - min(firsts.values())
    ordered = sorted(rows, key=lambda r: r["time"])
    # Per frame, what is neither the render (ms) nor the files (write_ms): edits, checks, manifest, progress.
    other = [(b["time"] - a["time"]) * 1000.0 - b["ms"] - b["write_ms"] for a, b in zip(ordered, ordered[1:])
             if a["worker"] == b["worker"]]
    return {"fps": frames / wall, "wall_s": wall, "steady_fps": len(later) / span if span > 0 else float("nan"),
            "render_ms": sum(r["ms"] for r in rows) / frames, "write_ms": sum(r["write_ms"] for r in rows) / frames,
            "other_ms": statistics.median(other) if other else float("nan"),
            "technique": rows[0]["technique"], "renderer": rows[0]["renderer"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="caustic-sphere")
    parser.add_argument("--technique", default="auto")
    parser.add_argument("--sizes", default="256,512")
    parser.add_argument("--frames", type=int, default=48)
    parser.add_argument("--no-ray", action="store_true")
    parser.add_argument("--json")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench_batch_"))
    results = []
    try:
        for size in (int(s) for s in args.sizes.split(",")):
            backends = [("1 worker", 1, None), ("2 workers", 2, None)] + ([] if args.no_ray else [("Ray local", 1, "local")])
            for labels in (None, list(LABELS)):
                bare = bare_loop(args.scene, size, args.frames, args.technique, root / f"bare{size}", labels)
                print(f"{size}^2 bare loop, labels={'all' if labels else 'none'}: render {bare['render_ms']:.1f} ms "
                      f"(of which {bare['untimed_ms']:.1f} before the render's clock), files {bare['write_ms']:.1f} ms "
                      f"per frame (medians) on {bare['renderer']}", flush=True)
                for name, workers, ray in backends:
                    folder = root / f"{size}-{workers}-{ray}-{bool(labels)}"
                    r = batch_run(args.scene, size, args.frames, args.technique, folder, workers, ray, labels)
                    r.update(size=size, backend=name, labels=bool(labels), bare=bare)
                    note = ""
                    if workers == 1 and ray is None:  # the batch's own time per frame, beyond the bare loop's
                        extra = r["other_ms"] - bare["untimed_ms"]
                        r["overhead_ms"], r["overhead_percent"] = extra, 100.0 * extra / bare["render_ms"]
                        note = (f", batch overhead {extra:.2f} ms/frame = {r['overhead_percent']:.1f}% of the bare "
                                "render")
                    results.append(r)
                    print(f"{size}^2 {name:9s} labels={'all' if labels else 'none':4s}: {r['fps']:.2f} fps "
                          f"({r['steady_fps']:.2f} steady), {r['wall_s']:.1f} s, render {r['render_ms']:.1f} ms, "
                          f"write {r['write_ms']:.1f} ms{note} [{r['technique']}]", flush=True)
                    shutil.rmtree(folder, ignore_errors=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
