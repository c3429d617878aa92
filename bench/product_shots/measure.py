"""Benchmark: the product shots (make_scenes.py) against their Cycles references (cycles_reference.py).

Per scene and technique (``auto``, ``exact`` by default): linear PSNR (peak 1, clipped, caustica.metrics)
against the reference, over the whole image and per material region (metal, plastic, glass, wood: the
objects Blender's ray cast finds first at each pixel centre, NAME.regions.npz), over the pixels lit through
glass (a shadow ray from the first opaque hit, or from the opaque point a glass pixel's refracted path ends
on, meets glass: Cycles cannot find the light of punctual lights there, so those pixels measure the
reference's gap as much as the technique's) and over all the others; the reference's own
noise floor per region (its two seeds as halves, caustica.metrics.floor); ms per frame (median after a
warm-up, the GL work finished: caustica.bench.timing) and the ratio to ``plain`` shading on the same
renderer. The GL renderer string is recorded.

    .venv/bin/python bench/product_shots/measure.py [--size 256] [--techniques auto,exact] [--exact-spp 16]
        [--only a,b] [--json out.json] [--images DIR]
    .venv/bin/python bench/product_shots/measure.py --from-json a.json b.json   # one table of earlier runs
"""
from __future__ import annotations

import argparse
import json
import math
import os
import time
import warnings
from pathlib import Path

import numpy as np

import caustica
from caustica.bench.timing import timed_render
from caustica.images import read_image, write_image
from caustica.metrics.floor import combine_halves, noise_floor
from caustica.metrics.images import psnr_linear

HERE = Path(__file__).resolve().parent
THROUGH_GLASS = "lit through glass"
OUTSIDE = "all but lit through glass"
LAST = (OUTSIDE, THROUGH_GLASS)  # the table's last region columns


def default_references() -> Path:
    root = os.environ.get("CAUSTICA_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "caustica") / "product_shots"


def region_masks(path: Path) -> dict[str, np.ndarray]:
    """{region: (H, W) bool} from make_scenes.py's ray cast: one per material region, and the pixels lit
    through glass."""
    data = np.load(path)
    ids, regions = data["ids"], data["regions"]
    masks = {}
    for region in sorted(set(regions.tolist())):
        masks[region] = np.isin(ids, np.flatnonzero(regions == region))
    gap = data["through_glass"] | data["seen_through_glass"]
    if gap.any():
        masks[THROUGH_GLASS] = gap
        masks[OUTSIDE] = ~gap
    return masks


def reference(folder: Path, name: str) -> tuple[np.ndarray, dict, dict]:
    """(the reference: the mean of its two seeds, their Cycles settings, the halves)."""
    info = json.loads((folder / f"{name}.cycles.json").read_text())
    halves = [read_image(folder / f"{name}.seed{seed}.exr") for seed in info["seeds"]]
    spp = info["spp_per_seed"]
    return combine_halves(halves[0], halves[1], spp, spp), info, {"a": halves[0], "b": halves[1], "spp": spp}


def measure_scene(path: Path, references: Path, size: int, techniques: list[str], exact_spp: int,
                  frames: int, images: Path | None = None) -> dict:
    name = path.stem
    masks = region_masks(path.with_suffix(".regions.npz"))
    truth, info, halves = reference(references, name)
    floor = noise_floor(halves["a"], halves["b"], halves["spp"], halves["spp"], masks)
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = caustica.load_scene(path)
    result = {"scene": name, "size": [size, size], "reference": {"renderer": f"Cycles {info['blender']}",
              "spp": 2 * halves["spp"], "seconds": info["seconds"],
              "seed_psnr": psnr_linear(halves["a"], halves["b"]),
              "floor_psnr": {region: figures["psnr_linear"] for region, figures in floor.items()}},
              "load_warnings": sorted({str(w.message) for w in caught}), "load_s": time.perf_counter() - start,
              "region_pixels": {region: int(mask.sum()) for region, mask in masks.items()}, "techniques": {}}
    if images is not None:
        write_image(images / f"{name}.reference.png", truth)
    with caustica.Renderer((size, size)) as renderer:
        result["gl_renderer"] = renderer.info().get("renderer", "?")
        _, plain_ms = timed_render(renderer, scene, "plain", 1, frames)
        result["plain_ms"] = plain_ms
        for technique in techniques:
            spp = exact_spp if technique == "exact" else 1
            try:
                image, ms = timed_render(renderer, scene, technique, spp, frames)
            except Exception as error:  # a failing technique is a result: record it and go on
                result["techniques"][technique] = {"error": f"{type(error).__name__}: {error}".splitlines()[0]}
                continue
            plan = renderer.last_plan if technique == "auto" else None
            if images is not None:
                write_image(images / f"{name}.{technique}.png", image)
            psnr = {"all": psnr_linear(image, truth)}
            psnr.update({region: psnr_linear(image, truth, mask) for region, mask in masks.items()})
            result["techniques"][technique] = {"spp": spp, "ms": ms, "x_plain": ms / plain_ms, "psnr": psnr,
                                               "picked": getattr(plan, "technique", None)}
    return result


def _db(value) -> str:
    return "n/a" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.1f}"


def table(results: list[dict]) -> str:
    """Markdown: one row per scene and technique, PSNR overall and per region with the reference's floor."""
    regions = sorted({r for result in results for r in result["region_pixels"]}, key=lambda r: (r in LAST, LAST.index(r) if r in LAST else 0, r))
    lines = ["| scene | technique | all | " + " | ".join(regions) + " | ms/frame | x plain |",
             "|---|---|---|" + "---|" * len(regions) + "---|---|"]
    for result in results:
        floor = result["reference"]["floor_psnr"]
        lines.append(f"| {result['scene']} | reference floor ({result['reference']['spp']} spp) | {_db(floor['all'])} | "
                     + " | ".join(_db(floor.get(r)) for r in regions) + " | | |")
        for technique, row in result["techniques"].items():
            if "error" in row:
                lines.append(f"| {result['scene']} | {technique} | failed: {row['error']} |" + " |" * (len(regions) + 2))
                continue
            label = technique + (f" ({row['picked']})" if row.get("picked") else "") + \
                (f", {row['spp']} spp" if row["spp"] > 1 else "")
            lines.append(f"| {result['scene']} | {label} | {_db(row['psnr']['all'])} | "
                         + " | ".join(_db(row["psnr"].get(r)) for r in regions)
                         + f" | {row['ms']:.1f} | {row['x_plain']:.1f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=Path, default=HERE / "scenes")
    parser.add_argument("--references", type=Path, default=default_references())
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--techniques", default="auto,exact")
    parser.add_argument("--exact-spp", type=int, default=16)
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("--only", default="")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--images", type=Path, help="a folder for each image as sRGB PNG (NAME.TECHNIQUE.png)")
    parser.add_argument("--from-json", type=Path, nargs="+", help="print the table of earlier --json files")
    args = parser.parse_args()
    if args.from_json:
        results = [result for path in args.from_json for result in json.loads(path.read_text())]
        print(f"caustica from {', '.join(sorted({r['caustica'] for r in results}))}; "
              f"GL renderer: {', '.join(sorted({r['gl_renderer'] for r in results}))}\n")
        print(table(results))
        return
    only = {name for name in args.only.split(",") if name}
    if args.images is not None:
        args.images.mkdir(parents=True, exist_ok=True)
    results = []
    for path in sorted(args.scenes.glob("*.toml")):
        if only and path.stem not in only:
            continue
        start = time.perf_counter()
        result = measure_scene(path, args.references, args.size, args.techniques.split(","), args.exact_spp,
                               args.frames, args.images)
        result["wall_s"] = time.perf_counter() - start
        result["caustica"] = str(Path(caustica.__file__).parent)
        results.append(result)
        print(f"{path.stem}: measured in {result['wall_s']:.0f} s", flush=True)
        for message in result["load_warnings"]:
            print(f"  load warning: {message}")
    renderers = sorted({result["gl_renderer"] for result in results})
    print(f"\ncaustica from {Path(caustica.__file__).parent}")
    print(f"{args.size}x{args.size}, GL renderer: {', '.join(renderers)}; PSNR linear (dB, peak 1); "
          f"reference floor: PSNR between the two Cycles seeds + 6.02 dB\n")
    print(table(results))
    if args.json:
        args.json.write_text(json.dumps(results, indent=2, default=float))


if __name__ == "__main__":
    main()
