"""Benchmark: what the label layers cost per frame (caustica.labels, docs/labels.md).

For each size, the frame without labels, with every label but the flow, with the flow alone and with
all of them (ms, the best of ``--repeat`` interleaved runs, ctx.finish() and wall clock), the label
pass's own GPU ms (profile_passes) and the flow's CPU ms (Embree: follow_refraction per glass pixel).

    .venv/bin/python bench/bench_labels.py [--preset caustic-sphere] [--technique depth-search+caustic-mapping]
                                           [--sizes 256,512] [--repeat 8]
"""
from __future__ import annotations

import argparse
import json
import time

import caustica
from caustica.labels import LABELS, flow_layers
from caustica.renderer import Renderer


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="caustic-sphere")
    parser.add_argument("--technique", default="depth-search+caustic-mapping")
    parser.add_argument("--sizes", default="256,512")
    parser.add_argument("--repeat", type=int, default=8)
    args = parser.parse_args()
    runs = {"none": None, "all but flow": [n for n in LABELS if n != "flow"], "flow": ["flow"], "all": list(LABELS)}
    rows = []
    for side in (int(s) for s in args.sizes.split(",")):
        scene = caustica.load_scene(args.preset)
        with Renderer((side, side), profile_passes=True) as renderer:
            best = {name: float("inf") for name in runs}
            for name, labels in runs.items():  # warm-up: shaders, caches, the Embree scene
                renderer.render(scene, args.technique, labels=labels)
            for _ in range(args.repeat):
                for name, labels in runs.items():
                    best[name] = min(best[name], renderer.render_timed(scene, args.technique, labels=labels)[1])
            label_pass_ms = float("inf")  # with profile_passes: a finish() before and after the pass
            for _ in range(args.repeat):
                renderer.render(scene, args.technique, labels=list(LABELS))
                label_pass_ms = min(label_pass_ms, renderer.last_pass_ms["LabelSurfaces"])
            _, layers = renderer.render(scene, args.technique, labels=["glass"])
            camera = renderer.camera_for(scene)
            flow_ms = float("inf")
            for _ in range(args.repeat):
                start = time.perf_counter()
                flow_layers(scene, camera, layers["glass"].astype(bool))
                flow_ms = min(flow_ms, (time.perf_counter() - start) * 1000.0)
            rows.append({"size": side, "ms": {k: round(v, 2) for k, v in best.items()},
                         "label_pass_gpu_ms": round(label_pass_ms, 2), "flow_cpu_ms": round(flow_ms, 2),
                         "glass_pixels": int(layers["glass"].sum()), "renderer": renderer.info()["renderer"]})
            print(json.dumps(rows[-1]), flush=True)


if __name__ == "__main__":
    main()
