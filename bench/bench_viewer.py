"""Viewer frame time against a headless render of the same scene, technique and size.

    .venv/bin/python bench/bench_viewer.py [--scene glass-sphere] [--technique env-map] [--size 512] [--frames 30]

Needs a display (starts ``Xvfb :99`` itself when DISPLAY is unset and Xvfb is
installed). Prints the headless ms per frame (Renderer.render_timed: passes,
readback), the viewer's ms per frame (frame to frame: passes, drawing the
texture, the panel, swap) with the panel open and hidden, their ratio, and fps.
Headless and viewer runs alternate in rounds so that load on the machine hits both;
the headless renders run in a child process (an EGL context and a GLX window
cannot both be current in one process).
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import time


def ensure_display() -> subprocess.Popen | None:
    if os.environ.get("DISPLAY"):
        return None
    if not shutil.which("Xvfb"):
        sys.exit("bench_viewer: no DISPLAY and no Xvfb; apt-get install -y xvfb")
    server = subprocess.Popen(["Xvfb", ":99", "-screen", "0", "1920x1080x24", "-nolisten", "tcp"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.environ["DISPLAY"] = ":99"
    time.sleep(1.0)
    return server


HEADLESS = """
import json, sys, caustica
scene, technique, size, frames = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
renderer = caustica.Renderer((size, size))
scene = caustica.load_scene(scene)
renderer.render(scene, technique)
print(json.dumps({"ms": [renderer.render_timed(scene, technique)[1] for _ in range(frames)],
                  "renderer": renderer.info()["renderer"]}))
"""


def headless_ms(args) -> tuple[list[float], str]:
    import json

    out = subprocess.run([sys.executable, "-c", HEADLESS, args.scene, args.technique, str(args.size), str(args.frames)],
                         check=True, capture_output=True, text=True, env={**os.environ, "DISPLAY": ""}).stdout
    result = json.loads(out.strip().splitlines()[-1])
    return result["ms"], result["renderer"]


def viewer_ms(viewer, frames: int) -> list[float]:
    viewer.run(viewer.frame_index + 3)  # warm-up (shaders, shadow maps)
    viewer.frame_ms.clear()
    viewer.frame_ms = type(viewer.frame_ms)(maxlen=frames)
    viewer.run(viewer.frame_index + frames)
    return list(viewer.frame_ms)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="glass-sphere")
    parser.add_argument("--technique", default="env-map")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    server = ensure_display()
    try:
        import caustica
        from caustica.viewer import Viewer

        scene = caustica.load_scene(args.scene)
        size = (args.size, args.size)
        viewer = Viewer(scene, args.technique, size=size)
        headless, with_panel, without_panel = [], [], []
        for _ in range(args.rounds):
            ms, gl_renderer = headless_ms(args)
            headless += ms
            if not viewer.show_panel:
                viewer.toggle_panel()
            with_panel += viewer_ms(viewer, args.frames)
            viewer.toggle_panel()
            without_panel += viewer_ms(viewer, args.frames)
        report = viewer.close()
        h = statistics.median(headless)
        print(f"{args.scene}, {args.technique}, {args.size}x{args.size} on {gl_renderer}, "
              f"{args.rounds} rounds x {args.frames} frames, medians:")
        print(f"  headless render:      {h:7.1f} ms per frame ({1000 / h:5.1f} fps)")
        for label, values in (("viewer, panel open", with_panel), ("viewer, panel hidden", without_panel)):
            v = statistics.median(values)
            print(f"  {label + ':':21s} {v:7.1f} ms per frame ({1000 / v:5.1f} fps), "
                  f"ratio to headless {v / h:.3f} ({100 * (v / h - 1):+.1f}%)")
        print(f"  closed: GL error {report.gl_error}, GL objects left {sum(map(len, report.live_objects.values()))}")
    finally:
        if server is not None:
            server.terminate()
    return 0


if __name__ == "__main__":
    sys.exit(main())
