"""Benchmark: ``auto`` against every view technique and the view+caustics pairs, per preset, against Mitsuba.

For each preset: the Mitsuba reference (path + ptracer composite, cached on disk), then each
technique's PSNR (linear) overall and per region (refractor, caustic, rest) and its ms per frame,
all in one run; ``auto``'s margin to the best other technique and its cost over ``plain``.
Prints a markdown table with the GL renderer; ``--json`` keeps every figure.

    .venv/bin/python bench/bench_auto.py [--presets caustic-sphere,glass-sphere] [--size 128x96]
        [--spp 4] [--reference-spp 256] [--frames 3] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import sys

import caustica
from caustica.bench.compare import compare

TECHNIQUES = ["auto", "plain", "env-map", "image-space", "depth-search", "impostors", "per-vertex",
              "depth-search+caustic-mapping", "impostors+caustic-mapping", "per-vertex+caustic-mapping",
              "impostors+impostor-caustics"]
PRESETS = ["glass-sphere", "caustic-sphere", "tvcg-fig10", "caustics-point", "caustics-spot", "caustics-ring",
           "caustics-two-lights", "door-mirror", "mirror-concave", "spectacle-convex", "tvcg-fig14", "tvcg-fig24"]


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default=",".join(PRESETS))
    parser.add_argument("--techniques", default=",".join(TECHNIQUES))
    parser.add_argument("--size", default="128x96")
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--reference-spp", type=int, default=256)
    parser.add_argument("--frames", type=int, default=3)
    parser.add_argument("--json")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    techniques = [t for t in args.techniques.split(",") if t]
    rows, figures, renderer_name = [], {}, ""
    for preset in [p for p in args.presets.split(",") if p]:
        try:
            scene = caustica.load_scene(preset)
        except caustica.SceneError as exc:
            log(f"skipped {preset}: {exc}")
            continue
        result = compare(scene, techniques, size=size, spp=args.spp, frames=args.frames,
                         reference_spp=args.reference_spp, progress=False, log=log)
        data = result.to_json()
        renderer_name = data["renderer"]
        figures[preset] = data
        by_name = {t["technique"]: t for t in data["techniques"]}
        psnr = {name: float(t["regions"]["all"]["psnr_linear"]) for name, t in by_name.items()}
        others = {n: v for n, v in psnr.items() if n not in ("auto", "plain")}
        best = max(others, key=others.get)
        auto_ms, plain_ms = by_name["auto"]["ms_per_frame"], by_name["plain"]["ms_per_frame"]
        regions = {r: float(by_name["auto"]["regions"][r]["psnr_linear"]) for r in ("refractor", "caustic", "rest")}
        caustic_relmse = float(by_name["auto"]["regions"]["caustic"]["relmse"])
        rows.append(f"| {preset} | {caustica.plan(scene).technique} | {psnr['auto']:.1f} | "
                    f"{regions['refractor']:.1f} / {regions['caustic']:.1f} / {regions['rest']:.1f} | "
                    f"{caustic_relmse:.3f} | {best} {others[best]:.1f} | {psnr['auto'] - others[best]:+.1f} | "
                    f"{auto_ms / plain_ms:.2f} |")
        log(rows[-1])
    print(f"{args.size}, {args.spp} spp, Mitsuba reference {args.reference_spp} spp, GL: {renderer_name}\n")
    print("| preset | auto plans | auto PSNR all | refractor / caustic / rest | caustic relMSE | best other | "
          "auto - best (dB) | auto ms / plain ms |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    if args.json:
        with open(args.json, "w") as out:
            json.dump(figures, out, indent=1)


if __name__ == "__main__":
    main()
