"""Time to quality of depth-search against Mitsuba over internal bounces and samples per pixel.

For each (internal_bounces, spp) pair: depth-search's relMSE against the Mitsuba reference and its
frame time (median of ``--frames``), the fewest Mitsuba spp (powers of two, timed on the same
machine after a JIT warm-up) whose image is at least as close, and the ratio of the two times.
Prints a markdown table with the GL renderer.

    .venv/bin/python bench/bench_time_to_quality.py [--scene glass-sphere] [--size 256]
        [--reference-spp 512] [--max-spp 1024] [--bounces 0,1,2,3] [--spp 1,4,9] [--frames 7]
"""
from __future__ import annotations

import argparse

import caustica
from caustica.bench.harness import time_to_quality
from caustica.bench.timing import timed_render
from caustica.metrics import relmse
from caustica.reference.render import render_reference
from caustica.renderer import Renderer


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="glass-sphere")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--reference-spp", type=int, default=512)
    parser.add_argument("--max-spp", type=int, default=1024)
    parser.add_argument("--bounces", default="0,1,2,3")
    parser.add_argument("--spp", default="1,4,9")
    parser.add_argument("--frames", type=int, default=7)
    args = parser.parse_args(argv)
    scene = caustica.load_scene(args.scene)
    curve = time_to_quality(scene, [], args.size, args.reference_spp, max_spp=args.max_spp)["mitsuba_curve"]
    reference = render_reference(scene, size=(args.size, args.size), spp=args.reference_spp, progress=False)
    renderer = Renderer((args.size, args.size))
    print(f"GL renderer: {renderer.info()['renderer']}; {args.scene} at {args.size}x{args.size}, "
          f"reference {args.reference_spp} spp")
    print("| internal_bounces | spp | relMSE | ms | Mitsuba spp to match | Mitsuba s | ratio |")
    print("|---|---|---|---|---|---|---|")
    for bounces in (int(b) for b in args.bounces.split(",")):
        for spp in (int(s) for s in args.spp.split(",")):
            image, ms = timed_render(renderer, scene, "depth-search", spp, args.frames, {"internal_bounces": bounces})
            error = float(relmse(image, reference))
            reached = next((c for c in curve if c["relmse"] <= error), None)
            if reached is None:
                print(f"| {bounces} | {spp} | {error:.5f} | {ms:.1f} | > {args.max_spp} | - | - |")
            else:
                print(f"| {bounces} | {spp} | {error:.5f} | {ms:.1f} | {reached['spp']} | {reached['seconds']:.2f} | "
                      f"{reached['seconds'] * 1000.0 / ms:.1f} |")


if __name__ == "__main__":
    main()
