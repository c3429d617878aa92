"""GPU suite: every GPU technique and ``auto`` on every preset (the Stanford bunny's among them) at 512x512
and 1920x1080, within a time budget, for the day a GPU machine is lent. ``bench/gpu_suite.sh`` runs it.

First it finds the EGL device: ``caustica info`` in a child process per ``CAUSTICA_EGL_DEVICE`` index, the
first that is not a software renderer wins (llvmpipe is used, and said so, where none is). Then per
(technique, preset, size): warm-up frames, timed frames (the median: ms per frame and fps, the GPU finished
before the clock stops) and one profiled frame (per-pass ms: GL timer queries on a GPU, ``ctx.finish()`` and
wall clock on llvmpipe). ``results.json`` and ``results.md`` under ``--out`` are rewritten as rows come (every
WRITE_EVERY_S at most), so a run stopped by the budget, or killed, keeps what it measured.

    .venv/bin/python bench/gpu_suite.py [--out DIR] [--budget-s 420] [--quick]
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

SIZES = ((512, 512), (1920, 1080))
QUICK = {"techniques": ["auto", "env-map"], "presets": ["glass-sphere", "caustic-sphere"], "sizes": [(64, 64)],
         "warmup": 1, "frames": 1, "budget_s": 50.0}
FIRST = ("auto", "env-map", "plain", "depth-search", "impostors", "per-vertex")  # measured first: the budget may end
TABLED = ("transport-table", "transport-table-view")  # precompute a table on first use: only where one is cached
BUNNY = "stanford-bunny.obj"
WRITE_EVERY_S = 2.0  # results rewritten at most this often (a killed run loses at most that much)
INFO = "from caustica.cli import main; raise SystemExit(main(['info']))"


def probe_devices(limit: int = 4, log=print) -> dict:
    """``caustica info`` per EGL device index in child processes (one context per process); returns the chosen
    {"device_index", "renderer", "is_software", "probes"}. An index already in ``CAUSTICA_EGL_DEVICE`` is kept."""
    preset = os.environ.get("CAUSTICA_EGL_DEVICE")
    indices = [int(preset)] if preset is not None else range(limit)
    probes, chosen = [], None
    for index in indices:
        env = {**os.environ, "CAUSTICA_EGL_DEVICE": str(index)}
        try:
            done = subprocess.run([sys.executable, "-c", INFO], env=env, capture_output=True, text=True, timeout=120)
            text = (done.stdout + done.stderr).strip()
        except subprocess.TimeoutExpired:
            text, done = "caustica info did not answer within 120 s", None
        renderer = re.search(r"^renderer:\s*(.+)$", text, flags=re.M)
        probe = {"device_index": index, "ok": bool(done and done.returncode == 0 and renderer),
                 "renderer": renderer.group(1).strip() if renderer else None,
                 "is_software": bool(re.search(r"^software:\s*yes", text, flags=re.M)), "info": text}
        probes.append(probe)
        log(f"EGL device {index}: " + (f"{probe['renderer']}" + (" (software)" if probe["is_software"] else "")
                                       if probe["ok"] else f"unusable: {text.splitlines()[-1] if text else '?'}"))
        if probe["ok"] and chosen is None:
            chosen = probe
        if probe["ok"] and not probe["is_software"]:
            chosen = probe
            break
        if not probe["ok"] and re.search(r"found \d+ devices", text):
            break  # past the last device
    if chosen is None:
        return {"device_index": None, "renderer": None, "is_software": True, "probes": probes}
    return {"device_index": chosen["device_index"], "renderer": chosen["renderer"],
            "is_software": chosen["is_software"], "probes": probes}


def gpu_techniques() -> list[str]:
    """``auto`` and every registered technique that rasterizes, the cheap and common ones first."""
    from caustica.techniques import get_technique, technique_names

    names = [n for n in technique_names() if n == "auto" or get_technique(n).uses_gl]
    return sorted(names, key=lambda n: (FIRST.index(n) if n in FIRST else len(FIRST), n))


def load_scenes(names, log=print) -> tuple[dict, dict]:
    """({name: scene}, {name: why skipped}) for the presets; a preset whose shared data is missing is skipped."""
    import caustica

    scenes, skipped = {}, {}
    for name in names:
        try:
            scenes[name] = caustica.load_scene(name)
        except Exception as exc:  # SceneError for missing shared data, or any other failure: noted, not fatal
            skipped[name] = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
            log(f"skipped preset {name}: {skipped[name]}")
    return scenes, skipped


def missing_table(scene) -> str | None:
    """The first glass object of ``scene`` with no cached transport table, or None."""
    from caustica.transport.runtime import has_cached_table, table_mesh

    return next((o.name for o in scene.objects if o.material.kind == "glass"
                 and not has_cached_table(table_mesh(o.mesh), o.material.ior)), None)


def measure(renderer, scene, technique: str, warmup: int, frames: int) -> dict:
    """Warm-up frames, then the median of ``frames`` timed ones (one only when a warm frame takes over a
    second), then one profiled frame for the per-pass ms."""
    started = time.perf_counter()
    warm_ms = [renderer.render_timed(scene, technique, 1)[1] for _ in range(max(1, warmup))]
    count = 1 if warm_ms[-1] > 1000.0 else max(1, frames)
    timed = [renderer.render_timed(scene, technique, 1)[1] for _ in range(count)]
    renderer.profile_passes = True
    try:
        renderer.render(scene, technique, 1)
        pass_ms = dict(renderer.last_pass_ms)
    finally:
        renderer.profile_passes = False
    ms = statistics.median(timed)
    plan = renderer.last_plan.technique if technique == "auto" and renderer.last_plan is not None else None
    return {"ms": ms, "fps": 1000.0 / ms if ms > 0 else None, "frames": count, "first_ms": warm_ms[0],
            "pass_ms": pass_ms, "planned": plan, "seconds": time.perf_counter() - started}


def markdown(data: dict) -> str:
    """The results as a page: header (GL renderer, date, command), fps per technique and size over the
    presets, then one row per (technique, preset, size) with its heaviest passes."""
    rows = [r for r in data["rows"] if "ms" in r]
    sizes = sorted({(r["width"], r["height"]) for r in rows}, key=lambda s: s[0] * s[1])
    out = [f"# GPU suite: {data['renderer'] or 'no GL renderer'}", "",
           f"`{data['command']}`, {data['started']}, {data['elapsed_s']:.0f} s of a {data['budget_s']:.0f} s budget"
           + (" (stopped by the budget: the rows below are what it measured)" if data["stopped_early"] else ""), "",
           f"- GL renderer: `{data['renderer']}` (EGL device {data['device_index']}"
           + (", software: timings are wall clock around ctx.finish()" if data["is_software"] else
              ", per-pass ms from GL timer queries") + ")",
           f"- {data['settings']['warmup']} warm-up frame(s), the median of {data['settings']['frames']} timed "
           "frames (one where a frame takes over a second), 1 spp; techniques keep their maps across frames, so "
           "these are steady-state frames",
           f"- Stanford bunny: {data['bunny']}", ""]
    for what, items in (("skipped presets", data["skipped_presets"]), ("not run", data["not_run"])):
        if items:
            out += [f"{what.capitalize()}:", ""] + [f"- {k}: {v}" for k, v in items.items()] + [""]
    out += ["## Median fps over the presets", "", "| technique | " + " | ".join(f"{w}x{h}" for w, h in sizes) + " |",
            "|---|" + "---|" * len(sizes)]
    for technique in dict.fromkeys(r["technique"] for r in rows):
        cells = []
        for w, h in sizes:
            fps = [r["fps"] for r in rows if r["technique"] == technique and (r["width"], r["height"]) == (w, h)
                   and r["fps"]]
            cells.append(f"{statistics.median(fps):.1f} ({len(fps)})" if fps else "-")
        out.append(f"| `{technique}` | " + " | ".join(cells) + " |")
    out += ["", "## Every run", "", "| technique | preset | size | fps | ms | first frame ms | heaviest passes (ms) |",
            "|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        name = f"`{r['technique']}`" + (f" ({r['planned']})" if r.get("planned") else "")
        if "ms" not in r:
            out.append(f"| {name} | `{r['scene']}` | {r['width']}x{r['height']} | error | | | {r['error']} |")
            continue
        passes = ", ".join(f"{k} {v:.2f}" for k, v in sorted(r["pass_ms"].items(), key=lambda kv: -kv[1])[:4])
        fps = f"{r['fps']:.1f}" if r["fps"] else "-"
        out.append(f"| {name} | `{r['scene']}` | {r['width']}x{r['height']} | {fps} | {r['ms']:.2f} | "
                   f"{r['first_ms']:.1f} | {passes} |")
    return "\n".join(out) + "\n"


def write(data: dict, out: Path) -> None:
    """results.json and results.md, each replaced whole (a reader never sees half a file)."""
    for name, text in (("results.json", json.dumps(data, indent=1)), ("results.md", markdown(data))):
        tmp = out / f".{name}.tmp"
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, out / name)


def run_suite(out: Path, techniques, presets, sizes, warmup: int, frames: int, budget_s: float, command: str,
              device: dict, log=print) -> dict:
    """Measure every (technique, preset, size) until done or the budget is spent; the data written."""
    from caustica import Renderer
    from caustica.scene.preset_parts import shared_data_dir

    start = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    bunny = shared_data_dir() / "models" / BUNNY
    data = {"command": command, "started": datetime.datetime.now().isoformat(timespec="seconds"),
            "renderer": None, "device_index": device["device_index"], "is_software": device["is_software"],
            "egl_probes": device["probes"], "budget_s": budget_s, "elapsed_s": 0.0, "stopped_early": False,
            "settings": {"warmup": warmup, "frames": frames, "sizes": [list(s) for s in sizes], "spp": 1},
            "bunny": (f"{bunny} (its presets: {', '.join(p for p in presets if 'bunny' in p) or 'none selected'})"
                      if bunny.is_file() else f"absent ({bunny} missing: set CAUSTICA_DATA); its presets skipped"),
            "skipped_presets": {}, "not_run": {}, "rows": []}
    scenes, data["skipped_presets"] = load_scenes(presets, log)
    renderers = {size: Renderer(size) for size in sizes}
    try:
        info = renderers[sizes[0]].info()
        data.update(renderer=info["renderer"], vendor=info["vendor"], version=info["version"],
                    is_software=info["is_software"])
        log(f"GL renderer: {info['renderer']} ({info['version']})")
        write(data, out)
        written = time.perf_counter()
        # Preset by preset, every technique on each: a run the budget stops keeps every technique's figures
        # on the presets it reached (technique by technique, it would lose the last techniques entirely).
        jobs = [(t, s, size) for s in scenes for size in sizes for t in techniques]
        for i, (technique, name, size) in enumerate(jobs, 1):
            elapsed = time.perf_counter() - start
            if elapsed > budget_s:
                data["stopped_early"] = True
                data["not_run"]["budget"] = f"{len(jobs) - i + 1} of {len(jobs)} runs left when {budget_s:.0f} s ran out"
                log(f"budget of {budget_s:.0f} s spent: {len(jobs) - i + 1} runs left undone")
                break
            scene = scenes[name]
            if technique in TABLED and (lacking := missing_table(scene)) is not None:
                data["not_run"][f"{technique} on {name}"] = (f"no transport table cached for {lacking} ('caustica "
                                                             "precompute' first; precomputing here takes minutes)")
                continue
            row = {"technique": technique, "scene": name, "width": size[0], "height": size[1]}
            try:
                row.update(measure(renderers[size], scene, technique, warmup, frames))
            except Exception as exc:  # a technique that does not take this scene: the row says why
                row["error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
            data["rows"].append(row)
            data["elapsed_s"] = time.perf_counter() - start
            if time.perf_counter() - written > WRITE_EVERY_S:
                write(data, out)
                written = time.perf_counter()
            log(f"[{i}/{len(jobs)} {data['elapsed_s']:.0f}s] {technique} {name} {size[0]}x{size[1]}: "
                + (f"{row['fps']:.1f} fps ({row['ms']:.2f} ms)" if "ms" in row else row["error"]))
    finally:
        for renderer in renderers.values():
            renderer.close()
    data["elapsed_s"] = time.perf_counter() - start
    write(data, out)
    return data


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(os.environ.get("OUT") or "out/gpu_suite"),
                        help="folder of results.json and results.md (default $OUT, else out/gpu_suite)")
    parser.add_argument("--budget-s", type=float, help="stop starting runs after this many seconds (default 420; "
                                                       "--quick 50)")
    parser.add_argument("--quick", action="store_true", help="2 techniques x 2 presets at 64x64, 1 frame: a check "
                                                             "that runs on llvmpipe in well under a minute")
    parser.add_argument("--techniques", help="comma-separated (default: auto and every GPU technique)")
    parser.add_argument("--presets", help="comma-separated (default: every preset)")
    parser.add_argument("--sizes", help="comma-separated WIDTHxHEIGHT (default 512x512,1920x1080)")
    parser.add_argument("--frames", type=int, default=3, help="timed frames per run (default 3)")
    parser.add_argument("--warmup", type=int, default=1, help="warm-up frames per run (default 1)")
    parser.add_argument("--require-gpu", action="store_true", help="exit 3 when only a software renderer is found")
    began = time.perf_counter()
    args = parser.parse_args(argv)
    from caustica.scene.presets import preset_names

    command = " ".join(["bench/gpu_suite.py", *(sys.argv[1:] if argv is None else argv)])
    if args.quick:
        techniques, presets, sizes = QUICK["techniques"], QUICK["presets"], QUICK["sizes"]
        warmup, frames, budget = QUICK["warmup"], QUICK["frames"], QUICK["budget_s"]
    else:
        techniques, presets, sizes = gpu_techniques(), preset_names(), list(SIZES)
        warmup, frames, budget = args.warmup, args.frames, 420.0
    techniques = args.techniques.split(",") if args.techniques else techniques
    presets = args.presets.split(",") if args.presets else presets
    if args.sizes:
        sizes = [tuple(int(v) for v in size.lower().split("x")) for size in args.sizes.split(",")]
    budget = args.budget_s if args.budget_s is not None else budget
    device = probe_devices()
    if device["device_index"] is None:
        print("gpu_suite: no EGL device gives an OpenGL 4.3 context (see the probes above); nothing measured",
              file=sys.stderr)
        return 2
    if device["is_software"]:
        print(f"gpu_suite: WARNING: only a software renderer ({device['renderer']}): the NVIDIA EGL driver is not in "
              "use (is libEGL_nvidia installed, with /usr/share/glvnd/egl_vendor.d/10_nvidia.json?)", file=sys.stderr,
              flush=True)
        if args.require_gpu:
            return 3
    print(next(p["info"] for p in device["probes"] if p["device_index"] == device["device_index"]))
    os.environ["CAUSTICA_EGL_DEVICE"] = str(device["device_index"])
    left = budget - (time.perf_counter() - began)  # the budget counts from the start, the probes included
    data = run_suite(args.out, techniques, presets, sizes, warmup, frames, left, command, device)
    measured = sum("ms" in r for r in data["rows"])
    print(f"wrote {args.out / 'results.json'} and {args.out / 'results.md'}: {measured} runs measured, "
          f"{len(data['rows']) - measured} failed, in {data['elapsed_s']:.0f} s on {data['renderer']}")
    return 0 if measured else 1


if __name__ == "__main__":
    sys.exit(main())
