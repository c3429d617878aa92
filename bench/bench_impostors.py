"""Hu and Qin's fig. 24 stages measured: ms per frame, ratio to stage (a), PSNR / relMSE against Mitsuba.

Stages (``caustica.scene.presets_impostors.FIG24_STAGES``) on the ``tvcg-fig24`` scene: (a) depth-search,
(b) + nearby geometry (impostors, uncorrected), (c) + depth correction, (d) + caustics (128^2 photon
buffer), (e) + 256^2 photon buffer, (f) + reflection of nearby geometry, (g) + recursion (depth 1).
The paper's ratios to (a): 2.1, 2.6, 4.7, 5.3, 6.5, 9.0. Prints a markdown table.

    .venv/bin/python bench/bench_impostors.py [--size 512] [--frames 3] [--rounds 3] [--reference-spp 256] [--no-reference]

Each round times every stage in turn (a warm-up frame, then the median of ``--frames``); a stage's
ratio is the median over rounds of its time over stage (a)'s in the same round, so that load on
the shared cores, which drifts over seconds, hits numerator and denominator alike.
"""
from __future__ import annotations

import argparse
import statistics

from caustica.bench.compare import reference_image
from caustica.bench.timing import timed_render
from caustica.metrics import psnr_linear, relmse
from caustica.renderer import Renderer
from caustica.scene.presets import PRESETS
from caustica.scene.presets_impostors import FIG24_STAGES

PAPER_RATIOS = {"a": 1.0, "b": 2.1, "c": 2.6, "d": 4.7, "e": 5.3, "f": 6.5, "g": 9.0}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--frames", type=int, default=3)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--reference-spp", type=int, default=256)
    parser.add_argument("--no-reference", action="store_true", help="timings only")
    args = parser.parse_args(argv)
    scene = PRESETS["tvcg-fig24"]()
    size = (args.size, args.size)
    reference = None
    if not args.no_reference:
        reference, description = reference_image(scene, size, args.reference_spp)
        print(f"reference: {description}")
    renderer = Renderer(size)
    times = {stage: [] for stage in FIG24_STAGES}
    images = {}
    for _ in range(max(1, args.rounds)):
        for stage, (technique, params) in FIG24_STAGES.items():
            images[stage], ms = timed_render(renderer, scene, technique, 1, args.frames, params)
            times[stage].append(ms)
    rows = []
    for stage, (technique, params) in FIG24_STAGES.items():
        ratio = statistics.median(t / a for t, a in zip(times[stage], times["a"]))
        quality = ("-", "-") if reference is None else (f"{psnr_linear(images[stage], reference):.2f}",
                                                        f"{relmse(images[stage], reference):.4f}")
        rows.append((stage, technique, params, statistics.median(times[stage]), ratio, PAPER_RATIOS[stage], *quality))
    print(f"GL renderer: {renderer.info()['renderer']}, {args.size}x{args.size}, 1 spp, {args.rounds} rounds of "
          f"{args.frames} frames (ms: median over rounds; ratio: median of each round's ratio)")
    print("| stage | technique | parameters | ms/frame | ratio to (a) | paper's ratio | PSNR dB | relMSE |")
    print("|---|---|---|---|---|---|---|---|")
    for stage, technique, params, ms, ratio, paper, psnr, rel in rows:
        settings = ", ".join(f"{k}={v}" for k, v in params.items()) or "-"
        print(f"| {stage} | {technique} | {settings} | {ms:.1f} | {ratio:.2f} | {paper:.1f} | {psnr} | {rel} |")


if __name__ == "__main__":
    main()
