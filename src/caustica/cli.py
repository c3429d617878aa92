"""Command line: ``caustica render | techniques | info``.

Bad input prints one line, ``caustica: <problem>; <fix>``, and exits with code 2.
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

from .errors import CausticaError, OutputError

OUTPUT_SUFFIXES = (".png", ".exr")


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors in caustica's one-line style (exit code 2)."""

    def error(self, message):
        self.exit(2, f"caustica: {message}; see 'caustica {self.prog.split()[-1]} --help'\n" if " " in self.prog
                  else f"caustica: {message}; see 'caustica --help'\n")


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size '{text}' must look like 512x512") from None
    if width < 1 or height < 1:
        raise argparse.ArgumentTypeError(f"size '{text}' must be at least 1x1")
    return width, height


def _param(text: str) -> tuple[str, object]:
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"parameter '{text}' must look like name=value")
    key, value = text.split("=", 1)
    import tomllib

    try:
        parsed = tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value  # a bare word is a string
    return key.strip().replace("-", "_"), parsed


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="caustica", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    render = sub.add_parser("render", help="render a scene file or preset to PNG or EXR")
    render.add_argument("scene", help="a .toml scene file or a preset name (see 'caustica presets')")
    render.add_argument("-o", "--output", required=True, help="output image, .png (sRGB) or .exr (linear float)")
    render.add_argument("-t", "--technique", default="env-map", help="technique name (see 'caustica techniques')")
    render.add_argument("--size", type=_size, help="image size WxH (default: the scene camera's)")
    render.add_argument("--spp", type=int, default=1, help="samples per pixel as a k x k grid (box filter)")
    render.add_argument("--exposure", type=float, default=0.0, help="exposure in stops for PNG output")
    render.add_argument("--frames", type=int, default=3, help="timed frames after one warm-up (GPU techniques)")
    render.add_argument("-p", "--param", type=_param, action="append", default=[],
                        help="technique parameter name=value (repeatable)")

    sub.add_parser("techniques", help="list the techniques")
    sub.add_parser("presets", help="list the built-in scenes")
    sub.add_parser("info", help="print the OpenGL renderer, version and extensions")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return COMMANDS[args.command](args)
    except CausticaError as exc:
        print(f"caustica: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("caustica: interrupted", file=sys.stderr)
        return 130


def cmd_render(args) -> int:
    from . import load_scene
    from .images import write_image
    from .renderer import Renderer
    from .techniques import get_technique

    output = Path(args.output)
    if output.suffix.lower() not in OUTPUT_SUFFIXES:
        raise OutputError(f"output '{output}' must end in .png or .exr")
    if not output.parent.is_dir():
        raise OutputError(f"output directory '{output.parent}' does not exist; create it first")
    if args.spp < 1 or args.frames < 1:
        raise CausticaError("--spp and --frames must be at least 1")
    technique = get_technique(args.technique)
    scene = load_scene(args.scene)
    renderer = Renderer(args.size)
    params = dict(args.param)
    image, ms = renderer.render_timed(scene, args.technique, args.spp, **params)
    timings = [ms]
    if technique.uses_gl:
        timings = [renderer.render_timed(scene, args.technique, args.spp, **params)[1] for _ in range(args.frames)]
        image = renderer.render(scene, args.technique, args.spp, **params)
    write_image(output, image, exposure=args.exposure)
    height, width = image.shape[:2]
    where = renderer.info()["renderer"] if technique.uses_gl else "CPU (Embree)"
    print(f"wrote {output} ({width}x{height}, {args.technique}, {args.spp} spp): "
          f"{statistics.median(timings):.1f} ms per frame on {where}")
    return 0


def cmd_techniques(args) -> int:
    from .techniques import get_technique, technique_names

    for name in technique_names():
        print(f"{name:16s} {get_technique(name).summary}")
    return 0


def cmd_presets(args) -> int:
    from .scene.presets import PRESETS

    for name, make in sorted(PRESETS.items()):
        doc = (make.__doc__ or "").strip().splitlines()
        print(f"{name:16s} {doc[0] if doc else ''}")
    return 0


def cmd_info(args) -> int:
    from .gpu.context import describe, shared_context

    info = describe(shared_context())
    print(f"renderer:         {info['renderer']}")
    print(f"vendor:           {info['vendor']}")
    print(f"version:          {info['version']}")
    print(f"max texture size: {info['max_texture_size']}")
    print(f"software:         {'yes (time with ctx.finish() and wall clock)' if info['is_software'] else 'no'}")
    print(f"float atomics:    {'yes' if info['float_atomics'] else 'no (caustic splats fall back to blending)'}")
    for name, present in info["extensions"].items():
        print(f"  {name:36s} {'yes' if present else 'no'}")
    return 0


COMMANDS = {"render": cmd_render, "techniques": cmd_techniques, "presets": cmd_presets, "info": cmd_info}

if __name__ == "__main__":
    sys.exit(main())
