"""Benchmark: caustica batch frames per second, and its overhead over a bare Renderer loop.

An orbit of a glass scene (default caustic-sphere, technique auto) at each size, with 1 and 2 spawned
or in-process workers and on a local Ray (2 CPUs), without and with every label layer. ``fps`` is
frames over the run's wall clock, start-up included (processes, GL contexts, shaders, Ray);
``steady fps`` counts the frames after each worker's first, over the time from the first row to the
last (manifest ``time``). The overhead compares the 1-worker run's wall time per frame with a bare
loop in this process over the same frames: ``Renderer.render`` alone, and render + ``write_image``.

    .venv/bin/python bench/bench_batch.py [--scene caustic-sphere] [--sizes 256,512] [--frames 48]
        [--no-ray] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import caustica
from caustica.batch.edits import SceneEditor
from caustica.batch.job import make_job
from caustica.images import write_image
from caustica.labels import LABELS


def bare_loop(scene_name: str, size: int, frames: int, technique: str, folder: Path, labels) -> dict:
    """ms per frame of a plain loop over the orbit's scenes: render only, and render + the files."""
    from caustica.labels import write_labels

    folder.mkdir(parents=True, exist_ok=True)
    job, base = make_job(scene_name, folder, frames=frames, orbit=360, size=(size, size))
    editor = SceneEditor(base)
    scenes = [editor.apply(job.values(i)) for i in range(frames)]
    extra = {"labels": labels} if labels else {}
    with caustica.Renderer((size, size)) as renderer:
        renderer.render(scenes[0], technique, **extra)  # warm-up: shaders, caches
        start = time.perf_counter()
        for s in scenes:
            renderer.render(s, technique, **extra)
        render_ms = (time.perf_counter() - start) * 1000.0 / frames
        start = time.perf_counter()
        for i, s in enumerate(scenes):
            result = renderer.render(s, technique, **extra)
            image, layers = result if labels else (result, None)
            write_image(folder / f"{i}.png", image)
            if labels:
                write_labels(folder / f"{i}.labels.exr", layers, "exr")
        written_ms = (time.perf_counter() - start) * 1000.0 / frames
    return {"render_ms": render_ms, "render_write_ms": written_ms, "renderer": renderer_name()}


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
    return {"fps": frames / wall, "wall_s": wall, "steady_fps": len(later) / span if span > 0 else float("nan"),
            "render_ms": sum(r["ms"] for r in rows) / frames, "write_ms": sum(r["write_ms"] for r in rows) / frames,
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
                print(f"{size}^2 bare loop, labels={'all' if labels else 'none'}: render {bare['render_ms']:.1f} "
                      f"ms/frame, render + files {bare['render_write_ms']:.1f} ms/frame on {bare['renderer']}",
                      flush=True)
                for name, workers, ray in backends:
                    folder = root / f"{size}-{workers}-{ray}-{bool(labels)}"
                    r = batch_run(args.scene, size, args.frames, args.technique, folder, workers, ray, labels)
                    r.update(size=size, backend=name, labels=bool(labels), bare=bare)
                    note = ""
                    if workers == 1 and ray is None:  # steady ms per frame against the bare loop's
                        steady_ms = 1000.0 / r["steady_fps"]
                        r["overhead_vs_render_percent"] = 100.0 * (steady_ms / bare["render_ms"] - 1.0)
                        r["overhead_vs_render_files_percent"] = 100.0 * (steady_ms / bare["render_write_ms"] - 1.0)
                        note = (f", steady {steady_ms:.1f} ms/frame: +{r['overhead_vs_render_percent']:.0f}% over the "
                                f"bare render, {r['overhead_vs_render_files_percent']:+.0f}% over render + files")
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
