"""Hu and Qin's fig. 24 stages measured: ms per frame, ratio to stage (a), PSNR / relMSE against Mitsuba.

Stages (``caustica.scene.presets_impostors.FIG24_STAGES``) on the ``tvcg-fig24`` scene: (a) depth-search,
(b) + nearby geometry (impostors, uncorrected), (c) + depth correction, (d) + caustics (128^2 photon
buffer), (e) + 256^2 photon buffer, (f) + reflection of nearby geometry, (g) + recursion (depth 1).
The paper's ratios to (a): 2.1, 2.6, 4.7, 5.3, 6.5, 9.0. Prints a markdown table.

    .venv/bin/python bench/bench_impostors.py [--size 512] [--pairs 5] [--rounds 5] [--reference-spp 256] [--no-reference]

Each round visits every stage (b)-(g) in turn: a warm-up frame (it rebuilds the impostor textures
when the previous stage kept other ones), then ``--pairs`` pairs of one stage-(a) frame and one
frame of the stage, alternating which comes first. A stage's ratio is the median over all its pairs
of frame time over the paired (a) frame's, with a 95% bootstrap interval: load on the shared cores
drifts over seconds and hits both frames of a pair alike, which a ratio of separately timed
medians does not cancel.
"""
from __future__ import annotations

import argparse
import statistics

import numpy as np

from caustica.bench.compare import reference_image
from caustica.metrics import psnr_linear, relmse
from caustica.renderer import Renderer
from caustica.scene.presets import PRESETS
from caustica.scene.presets_impostors import FIG24_STAGES

PAPER_RATIOS = {"a": 1.0, "b": 2.1, "c": 2.6, "d": 4.7, "e": 5.3, "f": 6.5, "g": 9.0}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--pairs", type=int, default=5, help="(a, stage) frame pairs per stage and round")
    parser.add_argument("--rounds", type=int, default=5)
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
    base_technique, base_params = FIG24_STAGES["a"]
    times = {stage: [] for stage in FIG24_STAGES}
    ratios = {stage: [] for stage in FIG24_STAGES}
    images = {"a": renderer.render(scene, base_technique, 1, **base_params)}
    for _ in range(max(1, args.rounds)):
        for stage, (technique, params) in FIG24_STAGES.items():
            if stage == "a":
                continue
            images[stage] = renderer.render(scene, technique, 1, **params)  # warm-up
            runs = {"a": (base_technique, base_params), stage: (technique, params)}
            for pair in range(max(1, args.pairs)):
                ms = {}
                for name in (("a", stage) if pair % 2 == 0 else (stage, "a")):
                    ms[name] = renderer.render_timed(scene, runs[name][0], 1, **runs[name][1])[1]
                    times[name].append(ms[name])
                ratios[stage].append(ms[stage] / ms["a"])
    rows = []
    for stage, (technique, params) in FIG24_STAGES.items():
        ratio, low, high = (1.0, 1.0, 1.0) if stage == "a" else median_interval(ratios[stage])
        quality = ("-", "-") if reference is None else (f"{psnr_linear(images[stage], reference):.2f}",
                                                        f"{relmse(images[stage], reference):.4f}")
        rows.append((stage, technique, params, statistics.median(times[stage]), ratio, low, high, PAPER_RATIOS[stage],
                     *quality))
    print(f"GL renderer: {renderer.info()['renderer']}, {args.size}x{args.size}, 1 spp, {args.rounds} rounds of "
          f"{args.pairs} (a, stage) pairs (ms: median frame; ratio: median of pair ratios, 95% bootstrap interval)")
    print("| stage | technique | parameters | ms/frame | ratio to (a) | 95% interval | paper's ratio | PSNR dB | relMSE |")
    print("|---|---|---|---|---|---|---|---|---|")
    for stage, technique, params, ms, ratio, low, high, paper, psnr, rel in rows:
        settings = ", ".join(f"{k}={v}" for k, v in params.items()) or "-"
        print(f"| {stage} | {technique} | {settings} | {ms:.1f} | {ratio:.3f} | {low:.3f}-{high:.3f} | {paper:.1f} "
              f"| {psnr} | {rel} |")


def median_interval(samples, resamples: int = 2000, seed: int = 0) -> tuple[float, float, float]:
    """Median of ``samples`` and its 95% percentile-bootstrap interval."""
    values = np.asarray(samples, np.float64)
    rng = np.random.default_rng(seed)
    medians = np.median(values[rng.integers(0, len(values), (resamples, len(values)))], axis=1)
    return float(np.median(values)), float(np.percentile(medians, 2.5)), float(np.percentile(medians, 97.5))


if __name__ == "__main__":
    main()
