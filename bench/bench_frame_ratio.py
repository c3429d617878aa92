"""Frame time of techniques against env-map, timed in turns in one run.

Each round renders every technique once (after one warm-up frame each); a technique's ratio is
the median over rounds of its time over env-map's in the same round, so that load on shared
cores, which drifts over seconds, hits numerator and denominator alike. Prints a markdown table
with the GL renderer.

    .venv/bin/python bench/bench_frame_ratio.py [--scene glass-sphere] [--size 512] [--spp 1]
        [--rounds 15] [--techniques image-space,depth-search] [--ior 0.8]

``--ior`` gives every glass object of the scene that IOR (the IOR 1.75 and 0.8 spheres of
bench_refraction.py are glass-sphere with ``--ior 1.75`` and ``--ior 0.8``).
"""
from __future__ import annotations

import argparse

import caustica
from caustica.bench.timing import timed_in_turns
from caustica.renderer import Renderer
from caustica.scene import Glass


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="glass-sphere")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--spp", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--techniques", default="image-space,depth-search")
    parser.add_argument("--ior", type=float, help="give every glass object this IOR")
    args = parser.parse_args(argv)
    scene = caustica.load_scene(args.scene)
    if args.ior is not None:
        for obj in scene.objects_of("glass"):
            obj.material = Glass(ior=args.ior)
    renderer = Renderer((args.size, args.size))
    techniques = ["env-map"] + [t.strip() for t in args.techniques.split(",") if t.strip() and t.strip() != "env-map"]
    timed = timed_in_turns(renderer, scene, {name: (name, {}) for name in techniques}, args.spp, args.rounds,
                           "env-map", lambda i: print(f"round {i + 1}/{args.rounds}", end="\r", flush=True))
    ior = "" if args.ior is None else f" (glass IOR {args.ior})"
    print(f"GL renderer: {renderer.info()['renderer']}; {args.scene}{ior} at {args.size}x{args.size}, {args.spp} spp, "
          f"{args.rounds} rounds")
    print("| technique | ms (median) | ms (fastest) | ratio to env-map (median of rounds) |")
    print("|---|---|---|---|")
    for name, t in timed.items():
        print(f"| {name} | {t['ms']:.1f} | {t['fastest']:.1f} | {t['ratio']:.2f} |")


if __name__ == "__main__":
    main()
