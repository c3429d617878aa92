"""Command line: ``caustica render | view | compare | bench | batch | export | precompute | techniques | plan | graph |
presets | info | completion`` (docs/cli.md).

Bad input prints one line, ``caustica: <problem>; <fix>``, and exits with code 2. ``-q`` prints nothing on
success, ``-v`` adds detail on stderr (caustica.progress holds the policy, progress bars included).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

from .atomic import folders_made
from .errors import CausticaError, OutputError, TechniqueError, first_line
from .frame_limits import MAX_SPP
from .images import TONEMAPS
from .passes.post.resolve import ANTIALIAS_MODES
from .planning.rules import QUALITY
from .progress import NORMAL, QUIET, VERBOSE, detail, is_quiet, note, output_policy, progress
from .scene.rules import IOR_RANGE

QUALITIES = tuple(QUALITY)  # auto's quality levels

OUTPUT_SUFFIXES = (".png", ".exr")


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors in caustica's one-line style (exit code 2)."""

    def error(self, message):
        self.exit(2, f"caustica: {message}; see 'caustica {self.prog.split()[-1]} --help'\n" if " " in self.prog
                  else f"caustica: {message}; see 'caustica --help'\n")


def _size(text: str) -> tuple[int, int]:
    from .scene.io import MAX_IMAGE_SIZE

    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size '{_shown(text)}' must look like 512x512") from None
    if width < 1 or height < 1:
        raise argparse.ArgumentTypeError(f"size '{text}' must be at least 1x1")
    if max(width, height) > MAX_IMAGE_SIZE:
        raise argparse.ArgumentTypeError(f"size '{text}' is above the limit of {MAX_IMAGE_SIZE} pixels a side; use a smaller size")
    return width, height


def _shown(text: str, limit: int = 40) -> str:
    """``text`` cut to ``limit`` characters for a one-line message."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _bounded(convert, low, high, unreadable: str, out_of_range: str):
    """An argparse type: ``convert(text)`` in [low, high]. The messages are ``str.format`` templates over
    ``text`` (cut by :func:`_shown`), ``value``, ``low`` and ``high``."""

    def parse(text: str):
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(unreadable.format(text=_shown(text), low=low, high=high)) from None
        if not low <= value <= high:  # NaN fails the comparison
            raise argparse.ArgumentTypeError(out_of_range.format(text=_shown(text), value=value, low=low, high=high))
        return value

    return parse


def _integer(low: int, high: int):
    """An argparse type: an integer in [low, high]."""
    return _bounded(int, low, high, "'{text}' is not an integer; give one in [{low}, {high}]",
                    "{value} is out of range; give an integer in [{low}, {high}]")


def _number(low: float, high: float):
    """An argparse type: a finite number in [low, high]."""
    return _bounded(float, low, high, "'{text}' is not a number",
                    "{text} is out of range; give a finite number in [{low:g}, {high:g}]")


# Bounds of the numeric options: what a frame, a reference or a table can sensibly ask for.
MAX_FRAMES = 100_000
MAX_REFERENCE_SPP = 1 << 16
MAX_EXPOSURE = 64.0
SPP = _integer(1, MAX_SPP)  # the renderer's own bound (frame_limits), said at parse time
FRAMES = _integer(1, MAX_FRAMES)
EXPOSURE = _number(-MAX_EXPOSURE, MAX_EXPOSURE)
BUDGET = _number(0.001, 1e6)  # auto's frame-time budget, milliseconds (0 or less is no budget: refused)
# Options whose value may begin with '-' (a negative number, '-5x5'), joined to them before parsing
# so argparse does not read the value as an option.
_VALUE_OPTIONS = {"--size", "--exposure", "--spp", "--frames", "--timing-frames", "--reference-spp", "--quality-size",
                  "--reference-floor",
                  "--max-spp", "--ior", "--directions", "--max-depth", "--sizes", "--orbit", "--workers",
                  "--devices"}


def _join_negative_values(argv: list[str]) -> list[str]:
    out: list[str] = []
    for token in argv:
        if out and out[-1] in _VALUE_OPTIONS and token[:1] == "-" and token[1:2] in set("0123456789.in"):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def _names(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError("give at least one name, comma-separated")
    return names


def _device_indices(text: str) -> list[int]:
    try:
        indices = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"devices '{_shown(text)}' must be EGL device indices like 0,1") from None
    if not indices or min(indices) < 0:
        raise argparse.ArgumentTypeError(f"devices '{_shown(text)}' must be EGL device indices (0 or more) like 0,1")
    return indices


def _sizes(text: str) -> list[int]:
    from .scene.io import MAX_IMAGE_SIZE

    try:
        sizes = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"sizes '{_shown(text)}' must look like 256,512,1024") from None
    if not sizes or min(sizes) < 1 or max(sizes) > MAX_IMAGE_SIZE:
        raise argparse.ArgumentTypeError(f"sizes '{_shown(text)}' must be integers in [1, {MAX_IMAGE_SIZE}]")
    return sizes


def _param(text: str) -> tuple[str, object]:
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"parameter '{text}' must look like name=value")
    key, value = text.split("=", 1)
    import math
    import tomllib

    # name, or technique.name where two techniques of a combination both have one (caustic-mapping.map_size).
    key = key.strip().replace("-", "_")
    if not all(part.isidentifier() for part in key.split(".")):
        raise argparse.ArgumentTypeError(f"parameter name '{_shown(key)}' is not a name; write name=value or "
                                         "technique.name=value")
    try:
        parsed = tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value  # a bare word is a string
    if isinstance(parsed, float) and not math.isfinite(parsed):
        raise argparse.ArgumentTypeError(f"parameter {key} = {value.strip()} must be a finite number")
    return key, parsed


class _Deprecated(argparse.Action):
    """A hidden old spelling of an option: stores its value (a flag: True) where the new one does and leaves
    the note ``hint`` (printed unless -q) in ``namespace.deprecated``."""

    def __init__(self, option_strings, dest, hint: str = "", **kwargs):
        super().__init__(option_strings, dest, help=argparse.SUPPRESS, default=argparse.SUPPRESS, **kwargs)
        self.hint = hint

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, True if self.nargs == 0 else values)
        namespace.deprecated = [*getattr(namespace, "deprecated", []), f"{option_string} is deprecated; {self.hint}"]


def _timing_frames_option(parser: argparse.ArgumentParser, default: int, what: str) -> None:
    """``--timing-frames N``: frames timed after a warm-up; ``--frames``, its old name, still works (with a note)."""
    parser.add_argument("--timing-frames", type=FRAMES, default=default, metavar="N",
                        help=f"frames timed after one warm-up {what} (default {default}); only the reported time "
                             "changes, not the image (not an animation frame count)")
    parser.add_argument("--frames", type=FRAMES, dest="timing_frames", action=_Deprecated,
                        hint="use --timing-frames (frames timed, not an animation frame count)")


def _output_options(parser: argparse.ArgumentParser, main: bool, quiet=("-q", "--quiet")) -> None:
    """-q/--quiet, -v/--verbose and --no-progress, taken before the command (``main``) or after it (where
    they do not override the first)."""
    default = False if main else argparse.SUPPRESS
    parser.add_argument(*quiet, dest="quiet", action="store_true", default=default,
                        help="print nothing on success: no notes, progress, warnings or reports (errors still print)")
    parser.add_argument("-v", "--verbose", action="store_true", default=default,
                        help="more detail on stderr: the GL renderer, the plan, every timing")
    parser.add_argument("--no-progress", action="store_true", default=default,
                        help="no progress bars or progress lines (the rest prints as usual)")


def _environment_option(parser: argparse.ArgumentParser) -> None:
    from .scene.environment import PROCEDURAL_ENVIRONMENTS

    parser.add_argument("--environment", metavar="FILE|NAME",
                        help=f"replace the scene's environment: an image file (.exr, .hdr, .png, .jpg) or one of "
                             f"{', '.join(PROCEDURAL_ENVIRONMENTS)}")


def _camera_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--camera", metavar="NAME", help="a glTF camera by its name or its node's (default: the "
                                                         "file's first)")


def _labels_options(parser: argparse.ArgumentParser, where: str) -> None:
    """``--labels LIST`` and ``--labels-format exr|npz`` (docs/labels.md), for render and batch."""
    from .labels import FORMATS, LABELS

    parser.add_argument("--labels", type=_names, metavar="LIST",
                        help=f"label layers {where}, comma-separated: {', '.join(LABELS)}")
    parser.add_argument("--labels-format", choices=FORMATS, help="labels file: exr (multi-layer, default) or npz")


def _scenes(names: list[str], args) -> list:
    """The scenes ``names`` load, each with ``--environment`` in place of its own when given."""
    from . import load_scene
    from .scene.environment import environment_option

    environment = environment_option(args.environment) if args.environment is not None else None
    scenes = [load_scene(name, getattr(args, "camera", None)) for name in names]
    for scene in scenes:
        if environment is not None:
            scene.environment = environment
    return scenes


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = _Parser(prog="caustica", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"caustica {__version__}")
    _output_options(parser, main=True)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    render = sub.add_parser("render", help="render a scene file or preset to PNG or EXR")
    render.add_argument("scene", help="a .toml or glTF (.glb, .gltf) scene file, or a preset name (see 'caustica presets')")
    render.add_argument("-o", "--output", required=True, help="output image, .png (sRGB) or .exr (linear float)")
    render.add_argument("-t", "--technique", default="auto",
                        help="technique name (see 'caustica techniques'; default auto: planned for the scene)")
    render.add_argument("--quality", choices=QUALITIES, help="auto's quality (default balanced)")
    render.add_argument("--budget", type=BUDGET, metavar="MS",
                        help="auto: the highest quality whose frame time here fits MS milliseconds (measured, cached)")
    render.add_argument("--explain", action="store_true", help="print auto's plan: each object's technique and why")
    render.add_argument("--size", type=_size, help="image size WxH (default: the scene camera's)")
    render.add_argument("--spp", type=SPP, default=1, help="samples per pixel, a square (1, 4, 9, ...): a k x k grid (box filter)")
    render.add_argument("--antialias", choices=ANTIALIAS_MODES, default="none",
                        help="none (default); edge: a post-process blend across edges, about 1.2x the cost of a "
                             "frame, for jagged outlines at 1 spp; msaa: outlines resolved from 4 geometry samples "
                             "per pixel, shading once; adaptive: 1 spp, and 4 spp at the pixels whose neighbours "
                             "differ (--spp 1; docs/antialiasing.md; --spp is more accurate)")
    render.add_argument("--exposure", type=EXPOSURE, default=0.0, help="exposure in stops for PNG output")
    render.add_argument("--tonemap", choices=TONEMAPS, default="clip",
                        help="PNG tone curve after the exposure: clip (default) or filmic (ACES fit: highlights roll "
                             "off towards white, mid-grey kept); EXR ignores it (linear float)")
    _timing_frames_option(render, 3, "(GPU techniques)")
    _environment_option(render)
    _camera_option(render)
    render.add_argument("-p", "--param", type=_param, action="append", default=[],
                        help="technique parameter name=value (repeatable)")
    _labels_options(render, "written beside the image (OUT's name, suffix .labels.exr or .labels.npz)")

    view = sub.add_parser("view", help="interactive window: orbit, switch techniques, edit parameters, inspect passes")
    view.add_argument("scene", help="a .toml or glTF (.glb, .gltf) scene file, or a preset name (see 'caustica presets')")
    view.add_argument("-t", "--technique", default="auto",
                      help="technique name (see 'caustica techniques'; default auto: planned for the scene)")
    view.add_argument("--quality", choices=QUALITIES, help="auto's quality (default balanced)")
    view.add_argument("--budget", type=BUDGET, metavar="MS",
                      help="auto: the highest quality whose frame time here fits MS milliseconds (measured, cached)")
    view.add_argument("--size", type=_size, help="view size WxH (default: the scene camera's)")
    view.add_argument("--spp", type=SPP, default=1, help="samples per pixel, a square (1, 4, 9, ...): a k x k grid (box filter)")
    view.add_argument("--antialias", choices=ANTIALIAS_MODES, default="none",
                      help="as 'render --antialias' except adaptive, which is for still images (the A key and the "
                           "panel switch it)")
    view.add_argument("--exposure", type=EXPOSURE, default=0.0, help="exposure in stops")
    view.add_argument("--tonemap", choices=TONEMAPS, default="clip",
                      help="tone curve after the exposure, of the view and PNG screenshots: clip (default) or filmic "
                           "(as 'render --tonemap'; the panel switches it too)")
    view.add_argument("-p", "--param", type=_param, action="append", default=[],
                      help="technique parameter name=value (repeatable)")
    view.add_argument("--frames", type=FRAMES, help="quit after this many frames (scripted runs)")
    view.add_argument("--screenshot", help="write the last frame here (.png sRGB or .exr linear)")
    view.add_argument("--window-screenshot", help="write the whole last window, panel included, here (.png)")
    view.add_argument("--script", metavar="FILE",
                      help="a JSON file holding a list of [event, args...] lists, applied in order, one a frame "
                           "([\"wait\", N] takes N frames), e.g. [[\"orbit\", 40, 0], [\"technique\", \"depth-search\"], "
                           "[\"param\", \"iterations\", 3], [\"wait\", 10], [\"screenshot\", \"a.png\"]]; events: antialias, close, "
                           "drag_light, exposure, frame, inspect, light, material, object_technique, orbit, overlay, pan, "
                           "panel, param, play, reset, screenshot, screenshot_window, side_by_side, spp, technique, time, "
                           "tonemap, wait, zoom; the window closes once the script and --frames are both done "
                           "(without --frames it stays open)")
    view.add_argument("--no-panel", action="store_true", help="start with the panel hidden (Tab toggles it)")
    view.add_argument("--play", action="store_true", help="start the animation of an animated preset (caustics-pool)")
    _environment_option(view)
    _camera_option(view)

    comp = sub.add_parser("compare", help="every technique against the reference: time, PSNR, relMSE, SSIM, FLIP per region")
    comp.add_argument("scene", help="a .toml or glTF (.glb, .gltf) scene file, or a preset name")
    comp.add_argument("--techniques", type=_names, default=["auto", "exact"], help="comma-separated (default auto,exact)")
    comp.add_argument("--size", type=_size, help="image size WxH (default: the scene camera's)")
    comp.add_argument("--spp", type=SPP, default=4, help="samples per pixel of the techniques, a square (default 4)")
    comp.add_argument("--reference-spp", type=_integer(1, MAX_REFERENCE_SPP), default=None,
                      help="Mitsuba samples per pixel (cached; default 256), rendered as two halves whose difference "
                           "gives its noise floor")
    comp.add_argument("--reference-floor", type=_number(10.0, 80.0), metavar="DB",
                      help="instead of --reference-spp: the samples for this whole-image sRGB PSNR noise floor, "
                           "estimated from a 32 spp pilot (at most 4096 spp; said when capped)")
    _timing_frames_option(comp, 5, "per technique")
    _environment_option(comp)
    _camera_option(comp)
    comp.add_argument("--json", help="write the figures as JSON here")
    comp.add_argument("--sheet", help="write a contact sheet PNG here: a title (scene, size, spp, GL renderer), the "
                                      "reference and the FLIP colour bar, then each technique's image with its ms, PSNR "
                                      "and FLIP beside its FLIP error map")
    comp.add_argument("--tonemap", choices=TONEMAPS, default="clip",
                      help="the sheet's tone curve: clip (default) or filmic (as 'render --tonemap'); the figures do not change")

    bench = sub.add_parser("bench", help="ms per frame, per-pass ms, ratio to plain shading, time-to-quality vs Mitsuba")
    bench.add_argument("--scenes", type=_names, default=["glass-sphere", "caustic-sphere"], help="comma-separated scenes or presets")
    bench.add_argument("--techniques", type=_names, default=["auto", "env-map", "exact"],
                       help="comma-separated techniques (default auto,env-map,exact)")
    bench.add_argument("--sizes", type=_sizes, default=[256, 512, 1024], help="comma-separated image sides (default 256,512,1024)")
    _timing_frames_option(bench, 5, "per scene, technique and size")
    _environment_option(bench)
    bench.add_argument("--quality-size", type=_integer(1, 4096), default=256, help="image side of the time-to-quality runs (default 256)")
    bench.add_argument("--reference-spp", type=_integer(1, MAX_REFERENCE_SPP), default=1024, help="spp of the reference for time-to-quality (cached)")
    bench.add_argument("--max-spp", type=_integer(1, MAX_REFERENCE_SPP), default=256, help="largest Mitsuba spp tried for time-to-quality")
    bench.add_argument("--no-mitsuba", action="store_true", help="skip the time-to-quality comparison")
    bench.add_argument("--json", help="write the figures as JSON here")
    bench.add_argument("--plot", help="write ms-vs-resolution and error-vs-time plots (PNG) here")

    _batch_parser(sub)

    export = sub.add_parser("export", help="write a scene as glTF 2.0 (.glb, .gltf) or Mitsuba 3 XML (.xml)")
    export.add_argument("scene", help="a .toml or glTF (.glb, .gltf) scene file, or a preset name")
    export.add_argument("-o", "--output", required=True,
                        help="out.glb (binary glTF), out.gltf (JSON, data embedded) or out.xml (Mitsuba 3)")
    _environment_option(export)
    _camera_option(export)

    pre = sub.add_parser("precompute", help="light transport table of a glass mesh (Iwasaki et al.), quantized, to .npz")
    pre.add_argument("mesh", help="a mesh file (.obj, .ply, .stl, .glb, .gltf, .off), in object space")
    pre.add_argument("--ior", type=_number(*IOR_RANGE), required=True,
                     help="index of refraction of the glass (e.g. 1.5), in the range scenes take")
    pre.add_argument("-o", "--output", help="also write the table here, .npz (it is always cached, where renders "
                                            "and auto's plan find it)")
    pre.add_argument("--directions", type=_integer(1, 1 << 20), default=129, help="sampled incident directions, 2 r^2 + 1 (default 129)")
    pre.add_argument("--max-depth", type=_integer(1, 64), default=8, help="glass interfaces followed per ray (default 8)")

    techniques = sub.add_parser("techniques", help="list the techniques; NAME: its parameters")
    techniques.add_argument("name", nargs="?", help="a technique (or view+caustics): its parameters as a table")
    techniques.add_argument("--json", action="store_true", help="every technique (or NAME) with its parameters as JSON")
    plan = sub.add_parser("plan", help="what auto renders a scene with: each object's technique, parameters and why")
    plan.add_argument("scene", help="a .toml scene file or a preset name")
    plan.add_argument("--quality", choices=QUALITIES, default="balanced", help="draft, balanced (default) or high")
    plan.add_argument("--size", type=_size, help="the image size WxH it plans for (default: the scene camera's; "
                                                 "the caustic map follows it)")
    plan.add_argument("--budget", type=BUDGET, metavar="MS",
                      help="the highest quality whose frame time here fits MS milliseconds (measured on this "
                           "device at --size and --spp, cached); instead of --quality")
    plan.add_argument("--spp", type=SPP, default=1, help="the samples per pixel a --budget's frames render (default 1)")
    plan.add_argument("--json", action="store_true", help="the plan as JSON")
    _environment_option(plan)  # the scene the render will have: plan what render plans
    _camera_option(plan)
    graph = sub.add_parser("graph", help="a technique's render graph: passes, channels, formats, caching")
    graph.add_argument("name", help="a technique (or view+caustics)")
    graph.add_argument("-p", "--param", type=_param, action="append", default=[],
                       help="technique parameter name=value (repeatable): the graph for those parameters")
    graph.add_argument("--scene", help="auto: the scene it plans for (a .toml file or a preset)")
    graph.add_argument("--dot", metavar="FILE", help="write the graph as Graphviz to FILE ('-': print it)")
    _environment_option(graph)
    _camera_option(graph)
    sub.add_parser("presets", help="list the built-in scenes")
    sub.add_parser("info", help="print the OpenGL renderer, version and extensions")
    completion = sub.add_parser("completion", help="print a shell completion script (docs/cli.md): "
                                                   "eval \"$(caustica completion bash)\"")
    completion.add_argument("shell", choices=SHELLS, help="bash or zsh")
    for name, command in sub.choices.items():
        _output_options(command, main=False, quiet=("-q",) if name == "precompute" else ("-q", "--quiet"))
    pre.add_argument("--quiet", dest="no_progress", action=_Deprecated, nargs=0,  # its meaning before -q
                     hint="it hides the progress bar only, as before: use --no-progress for that, or -q to print "
                          "nothing")
    return parser


def _batch_parser(sub) -> None:
    from .batch.sweep import MAX_FRAMES as MAX_BATCH_FRAMES

    batch = sub.add_parser("batch", help="render a dataset: many frames of a scene or sweep file, with a manifest "
                                         "(resumable; spawned workers or Ray)")
    batch.add_argument("scene", help="a sweep file (.toml with scene = ...; docs/batch.md), a .toml or glTF scene "
                                     "file, or a preset name")
    batch.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder: one file set per frame "
                                                                            "and manifest.jsonl")
    batch.add_argument("--frames", type=_integer(1, MAX_BATCH_FRAMES), help="number of frames (default: the "
                                                                              "sweep's, else 1)")
    batch.add_argument("--orbit", type=_number(-1e6, 1e6), metavar="DEG",
                       help="turn the camera about its look_at point, +Y up: frame i of N at i * DEG / N degrees")
    batch.add_argument("--size", type=_size, help="image size WxH (default: the sweep's, else the scene camera's)")
    batch.add_argument("--spp", type=SPP, help="samples per pixel, a square (default: the sweep's, else 1)")
    batch.add_argument("--antialias", choices=ANTIALIAS_MODES,
                       help="as 'render --antialias' (default: the sweep's, else none)")
    batch.add_argument("-t", "--technique", help="technique name (default: the sweep's, else auto)")
    _labels_options(batch, "per frame")
    batch.add_argument("--workers", type=_integer(1, 256), help="spawned worker processes, one GL context each, "
                                                                "round robin on the EGL devices (default 1: this "
                                                                "process; with --devices one per device)")
    batch.add_argument("--devices", type=_device_indices, metavar="LIST",
                       help="EGL device indices the workers take turns on, e.g. 0,1 (default: every GPU EGL lists; "
                            "docs/batch.md)")
    batch.add_argument("--ray", metavar="ADDRESS|local", help="render as Ray tasks on the cluster at ADDRESS, or on "
                                                               "a local Ray (pip install 'caustica[batch]')")
    batch.add_argument("--force", action="store_true", help="start over in a folder that holds another job's "
                                                            "(or this job's) frames")
    _environment_option(batch)
    _camera_option(batch)


def main(argv: list[str] | None = None) -> int:
    import warnings

    argv = _join_negative_values(list(sys.argv[1:] if argv is None else argv))
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as stop:  # --help, --version, or a bad argument (already reported in one line)
        return stop.code if isinstance(stop.code, int) else 2
    if args.quiet and args.verbose:
        return _fail("give -q (quiet) or -v (verbose), not both", 2)
    # Library warnings and deprecation notes are held back: an error prints its one line alone; a success
    # shows them after.
    with output_policy(QUIET if args.quiet else VERBOSE if args.verbose else NORMAL, not args.no_progress), \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        from .atomic import Terminated, signals_raise

        start = time.perf_counter()
        try:
            with signals_raise():  # SIGTERM and SIGHUP unwind like Ctrl-C: no temporary file left behind
                code = COMMANDS[args.command](args)
        except CausticaError as exc:
            return _fail(first_line(exc), 2)
        except MemoryError:
            return _fail("out of memory; use a smaller --size, fewer --spp or smaller maps", 2)
        except KeyboardInterrupt as stop:  # batch adds what it kept: "interrupted: kept 3 of 10 frames ..."
            return _fail(str(stop) or "interrupted", 130)
        except Terminated as stop:
            return _fail(f"{stop}", 128 + stop.signum)
        except BrokenPipeError:  # the reader of stdout left (| head): stop quietly, as a SIGPIPE would
            import os

            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit's flush
            return 128 + 13
        for message in getattr(args, "deprecated", []):
            note(message)
        for warning in caught:
            note(f"warning: {_shown(first_line(warning.message), MAX_MESSAGE)}")
        detail(f"{args.command} took {time.perf_counter() - start:.2f} s")
    return code


MAX_MESSAGE = 400  # characters of an error line; a longer message is cut


def _fail(message: str, code: int) -> int:
    print(f"caustica: {_shown(message, MAX_MESSAGE)}", file=sys.stderr)
    return code


def _say(text: str, end: str = "\n") -> None:
    """A command's report on stdout, unless -q."""
    if not is_quiet():
        print(text, end=end)


def cmd_render(args) -> int:
    from .images import write_image
    from .renderer import Renderer
    from .techniques import get_technique
    from .techniques.base import check_spp

    output = _check_output(args.output, OUTPUT_SUFFIXES)
    technique = get_technique(args.technique)
    check_spp(technique, args.spp)
    names, labels_out = _labels_output(args, output)
    scene, = _scenes([args.scene], args)
    renderer = Renderer(args.size)
    params = _with_quality(args)

    def frame(labels):
        """((image, layers or None), ms) of one render, with the layers ``labels`` (None: none)."""
        result, ms = renderer.render_timed(scene, args.technique, args.spp, labels=labels, antialias=args.antialias,
                                           **params)
        return (result if labels is not None else (result, None)), ms

    (image, layers), ms = frame(None if technique.uses_gl else names)  # a CPU technique renders once
    plan = (renderer.last_plan.describe() if renderer.last_plan is not None else
            f"technique: {args.technique} (named; 'caustica plan' shows what auto would choose)")
    if args.explain:
        _say(plan)
    else:
        detail(plan)
    timings = [ms]
    if technique.uses_gl:
        info = renderer.info()
        detail(f"GL: {info['renderer']} ({info['vendor']}), {info['version']}")
        timings = []
        with progress(args.timing_frames, "timing", unit="frames") as bar:  # the timed frames, without labels
            for _ in range(args.timing_frames):
                timings.append(frame(None)[1])
                bar.update()
        (image, layers), _ = frame(names)
    detail(f"frame times: {ms:.1f} ms" + (f" (warm-up), then {', '.join(f'{t:.1f}' for t in timings)} ms (timed)"
                                           if technique.uses_gl else ""))
    with folders_made(output):  # the quick start's out/: made once the render succeeded
        if layers is not None:
            from .labels import write_labels

            write_labels(labels_out, layers, args.labels_format or "exr")
        write_image(output, image, exposure=args.exposure, tonemap=args.tonemap)
    height, width = image.shape[:2]
    where = renderer.info()["renderer"] if technique.uses_gl else "CPU (Embree)"
    fraction = renderer.last_adaptive_fraction
    spp = f"{args.spp} spp" if fraction is None else f"adaptive: 4 spp at {100.0 * fraction:.1f} % of the pixels"
    used = args.technique if renderer.last_plan is None else f"{args.technique}: {renderer.last_plan.technique}"
    _say(f"wrote {output} ({width}x{height}, {used}, {spp}): "
         f"{statistics.median(timings):.1f} ms per frame on {where}"
         + (f"; labels {', '.join(names)} in {labels_out}" if layers is not None else ""))
    return 0


def _labels_output(args, output: Path) -> tuple:
    """render's label names (checked: one line naming the nearest) and the file they go to, checked
    writable; (None, None) without ``--labels``."""
    if args.labels is None:
        if args.labels_format is not None:
            raise CausticaError("--labels-format needs --labels (the layers to write, e.g. --labels id,depth)")
        return None, None
    from .atomic import check_writable
    from .labels import check_labels, labels_file

    names = check_labels(args.labels)
    return names, check_writable(output.with_name(labels_file(output.stem, args.labels_format or "exr")), True)


def cmd_batch(args) -> int:
    """Exit code 0 when every frame rendered, 1 when some failed (their manifest rows say why)."""
    from .batch import batch
    from .batch.progress import ProgressDisplay

    display = ProgressDisplay()
    try:
        rows = batch(args.scene, args.output, args.frames, orbit=args.orbit, size=args.size, spp=args.spp,
                     antialias=args.antialias, technique=args.technique, labels=args.labels, labels_format=args.labels_format,
                     environment=args.environment, camera=args.camera, workers=args.workers, ray=args.ray,
                     devices=args.devices, force=args.force, progress=display)
    finally:
        display.close()
    failed = [row for row in rows if "error" in row]
    _say(f"{len(rows) - len(failed)} of {len(rows)} frames in {args.output} (manifest.jsonl)"
         + (f"; {len(failed)} failed, e.g. frame {failed[0]['index']}: {failed[0]['error']}" if failed else ""))
    return 1 if failed else 0


def cmd_view(args) -> int:
    from .viewer.app import check_display

    check_display()
    screenshot = _check_output(args.screenshot, OUTPUT_SUFFIXES, make_folders=False)
    window_shot = _check_output(args.window_screenshot, (".png",), make_folders=False)
    script = _read_script(args.script)
    scene, = _scenes([args.scene], args)
    from .viewer import Viewer

    viewer = Viewer(scene, args.technique, _with_quality(args), size=args.size, spp=args.spp, exposure=args.exposure,
                    panel=not args.no_panel, fixed_step=args.frames is not None, tonemap=args.tonemap,
                    antialias=args.antialias)
    try:
        viewer.play(args.play)
        viewer.run(args.frames, script)
        frames = sorted(viewer.frame_ms)
        if frames:
            median = frames[len(frames) // 2]
            _say(f"{viewer.frame_index} frames, {median:.1f} ms per frame ({1000.0 / median:.1f} fps) "
                 f"on {viewer.device.info['renderer']}")
        if screenshot:
            _say(f"wrote {viewer.screenshot(screenshot)}")
        if window_shot:
            _say(f"wrote {viewer.screenshot_window(window_shot)}")
    finally:
        viewer.close()
    return 0


def _read_script(path: str | None) -> list:
    """Events from a JSON file: a list of [name, args...] lists."""
    if path is None:
        return []
    import json

    try:
        events = json.loads(Path(path).read_text())
    except OSError as exc:
        raise CausticaError(f"cannot read script '{path}' ({exc.strerror}); give a JSON file of events") from None
    except json.JSONDecodeError as exc:
        raise CausticaError(f"script '{path}' is not JSON ({exc.msg} at line {exc.lineno}); fix the file") from None
    if not isinstance(events, list) or not all(isinstance(e, list) and e and isinstance(e[0], str) for e in events):
        raise CausticaError(f"script '{path}' must be a list of [name, args...] lists, e.g. [[\"orbit\", 40, 0]]")
    return [tuple(e) for e in events]


def _check_output(path: str | None, suffixes: tuple[str, ...], make_folders: bool = True) -> Path | None:
    """Fail before any work when an output cannot be written; its missing folders are fine where they can be
    created (``make_folders``: the command writes it inside :func:`caustica.atomic.folders_made`)."""
    if path is None:
        return None
    from .atomic import check_writable

    out = Path(path)
    if out.suffix.lower() not in suffixes:
        raise OutputError(f"output '{out}' must end in {' or '.join(suffixes)}")
    return check_writable(out, make_folders)  # a read-only or virtual place, a directory in the way, a name too long


def _write_json(path: Path, data) -> None:
    import json

    from .atomic import folders_made, write_atomic

    with folders_made(path):
        write_atomic(path, lambda tmp: Path(tmp).write_text(json.dumps(data, indent=2)))


def cmd_compare(args) -> int:
    from .bench.compare import compare, format_table
    from .bench.sheet import compare_sheet, save_sheet
    from .techniques import get_technique
    from .techniques.base import check_spp

    if args.reference_floor is not None and args.reference_spp is not None:
        raise CausticaError("--reference-floor picks the reference's samples itself; give it or --reference-spp, "
                            "not both")
    json_path = _check_output(args.json, (".json",))
    sheet_path = _check_output(args.sheet, (".png",))
    from .metrics.checks import optional_module

    optional_module("skimage.metrics", "scikit-image")  # SSIM and FLIP of every row: fail before any render
    optional_module("flip_evaluator", "flip-evaluator")
    for name in args.techniques:
        check_spp(get_technique(name), args.spp)
    scene, = _scenes([args.scene], args)
    result = compare(scene, args.techniques, size=args.size, spp=args.spp, frames=args.timing_frames,
                     reference_spp=args.reference_spp or 256, reference_floor=args.reference_floor, log=note)
    _say(format_table(result))
    if json_path:
        _write_json(json_path, result.to_json())
        _say(f"wrote {json_path}")
    if sheet_path:
        with folders_made(sheet_path):
            save_sheet(compare_sheet(result, args.tonemap), sheet_path)
        _say(f"wrote {sheet_path}")
    return 0


def cmd_bench(args) -> int:
    from .bench.harness import plot, speed_rows, time_to_quality
    from .techniques import get_technique

    json_path = _check_output(args.json, (".json",))
    plot_path = _check_output(args.plot, (".png",))
    for name in args.techniques:
        get_technique(name)
    scenes = _scenes(args.scenes, args)
    rows, quality = [], []
    mitsuba = not args.no_mitsuba and _has_mitsuba()
    pace = _bench_pace(scenes, args, mitsuba)
    pace.start()
    for scene in scenes:
        rows += speed_rows(scene, args.techniques, args.sizes, args.timing_frames)
        pace.done()
    for scene in scenes if mitsuba else []:
        quality.append(time_to_quality(scene, args.techniques, args.quality_size, args.reference_spp,
                                       args.max_spp, args.timing_frames))
        pace.done()
    if json_path:
        _write_json(json_path, {"frames": rows, "time_to_quality": quality})
        _say(f"wrote {json_path}")
    if plot_path:
        with folders_made(plot_path):
            plot(rows, quality, plot_path)
        _say(f"wrote {plot_path}")
    return 0


def _has_mitsuba() -> bool:
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        note("time-to-quality skipped: Mitsuba is not installed (pip install 'caustica[reference]')")
        return False
    return True


def _bench_pace(scenes, args, mitsuba: bool):
    """bench's parts, each scene's speed rows then its time to quality, with their estimated seconds."""
    from .bench.estimate import Pace, quality_seconds, speed_seconds

    parts = [(f"speed {s.name}", speed_seconds(s, args.techniques, args.sizes, args.timing_frames)) for s in scenes]
    parts += [(f"time to quality {s.name}", quality_seconds(s, args.techniques, args.quality_size, args.reference_spp,
                                                            args.max_spp, args.timing_frames))
              for s in scenes if mitsuba]
    return Pace(parts)


def cmd_export(args) -> int:
    from .scene.io import EXPORT_SUFFIXES, export_scene

    output = _check_output(args.output, EXPORT_SUFFIXES)
    scene, = _scenes([args.scene], args)
    with folders_made(output):
        export_scene(scene, output)
    _say(f"wrote {output} ({len(scene.objects)} objects, {len(scene.lights)} lights)")
    return 0


def cmd_precompute(args) -> int:
    from .scene.mesh_files import load_mesh
    from .transport.compress import quantization_errors, quantize, save_table, table_bytes
    from .transport.precompute import DirectionGrid, precompute_table
    from .transport.runtime import table_mesh, table_path

    output = _check_output(args.output, (".npz",)) if args.output is not None else None
    try:
        DirectionGrid.of_count(args.directions)
    except ValueError as exc:
        raise CausticaError(f"--directions: {exc}") from None
    mesh = table_mesh(load_mesh(args.mesh))  # large flat faces split, as renders look the table up
    table = precompute_table(mesh, args.ior, args.directions, args.max_depth)
    q = quantize(table)
    cached = table_path(mesh, args.ior, args.directions, args.max_depth)
    data = table_bytes(q)  # once, for both files
    save_table(cached, data)  # where table_for finds it: renders of this mesh at this IOR take it from here
    if output is not None:
        with folders_made(output):
            save_table(output, data)
    e = quantization_errors(table, q)
    written = output or cached
    _say(f"wrote {written}{f' and cached it as {cached}' if output is not None else ''}: {table.vertex_count} vertices x {table.grid.count} directions in "
         f"{table.stats['seconds']:.1f} s; {e['raw_bytes'] / 1e6:.1f} MB raw, {e['quantized_bytes'] / 1e6:.1f} MB quantized "
         f"({e['size_ratio_percent']:.0f}%, {e['bytes_per_sample']:.0f} B/sample), file {written.stat().st_size / 1e6:.1f} MB; "
         f"max error position {e['position_error_percent']:.4f}%, direction {e['direction_error_percent']:.4f}%")
    stats = table.stats
    detail(f"{stats['rays']} rays traced; samples leaving the glass {100 * stats['valid_fraction']:.1f}%, "
           f"self-occluded {100 * stats['occluded_fraction']:.1f}%")
    return 0


def cmd_techniques(args) -> int:
    from .docs_techniques import catalogue, table, technique_info, to_json
    from .techniques import get_technique, technique_names

    if args.json:
        _say(to_json(technique_info(args.name) if args.name else catalogue()))
    elif args.name:
        _say(table(technique_info(args.name)))
    else:
        for name in technique_names():
            _say(f"{name:16s} {get_technique(name).summary}")
    return 0


def cmd_plan(args) -> int:
    from .planning.rules import plan

    scene, = _scenes([args.scene], args)
    if args.budget is None:
        from .gpu.readback import supersampling_factor

        k = supersampling_factor(args.spp)
        width, height = args.size or scene.camera.size
        chosen = plan(scene, args.quality, (width * k, height * k))
    else:
        from .renderer import Renderer

        with Renderer(args.size) as renderer:
            chosen = renderer.plan(scene, budget_ms=args.budget, spp=args.spp)
    _say(chosen.to_json() if args.json else chosen.describe())
    return 0


def _with_quality(args) -> dict:
    """The -p parameters, with --quality and --budget for auto (an error for any other technique)."""
    params = dict(args.param)
    for option, name in (("quality", "quality"), ("budget", "budget_ms")):
        value = getattr(args, option)
        if value is None:
            continue
        if args.technique != "auto":
            raise TechniqueError(f"--{option} applies to the auto technique, not '{args.technique}'; "
                                 "drop it or use -t auto")
        params[name] = value
    return params


def cmd_graph(args) -> int:
    from .render.graph import RenderGraph
    from .techniques import get_technique

    technique = get_technique(args.name)
    if not technique.uses_gl:
        raise TechniqueError(f"'{technique.name}' runs on the CPU and has no render graph; "
                             "try a rasterized technique such as depth-search")
    params = technique.make_params(**dict(args.param))
    if args.scene is not None or not hasattr(technique, "build_passes"):  # a planner (auto) needs its scene
        if args.scene is None:
            raise TechniqueError(f"'{technique.name}' plans its graph from the scene; add --scene SCENE "
                                 "(a .toml file or a preset)")
        scene, = _scenes([args.scene], args)
        technique, params = technique.for_scene(scene, params)
    graph = RenderGraph(technique.build_passes(params))
    if args.dot is None:
        _say(f"{technique.name}: {technique.summary}")
        _say(graph.describe())
    elif args.dot == "-":
        print(graph.dot(technique.name), end="")
    else:
        from .atomic import write_atomic

        text = graph.dot(technique.name)
        write_atomic(args.dot, lambda tmp: Path(tmp).write_text(text))
        _say(f"wrote {args.dot}")
    return 0


def cmd_presets(args) -> int:
    from .scene.presets import PRESETS
    from .text import summary

    width = max(map(len, PRESETS))
    for name, make in sorted(PRESETS.items()):
        _say(f"{name:{width}s} {summary(make.__doc__)}")
    return 0


def cmd_info(args) -> int:
    from .gpu.context import describe, shared_context

    info = describe(shared_context())
    _say(f"renderer:         {info['renderer']}")
    _say(f"vendor:           {info['vendor']}")
    _say(f"version:          {info['version']}")
    _say(f"max texture size: {info['max_texture_size']}")
    _say(f"software:         {'yes (time with ctx.finish() and wall clock)' if info['is_software'] else 'no'}")
    _say(f"float atomics:    {'yes' if info['float_atomics'] else 'no (caustic splats fall back to blending)'}")
    for name, present in info["extensions"].items():
        _say(f"  {name:36s} {'yes' if present else 'no'}")
    return 0


def cmd_completion(args) -> int:
    _say(completion_script(args.shell), end="")
    return 0


SHELLS = ("bash", "zsh")


def completion_script(shell: str) -> str:
    """A bash (or zsh, through bashcompinit) completion script for every command, option and choice of
    :func:`build_parser`, with preset, technique and environment names where a value takes one."""
    from .scene.environment import PROCEDURAL_ENVIRONMENTS
    from .scene.presets import PRESETS
    from .techniques import technique_names

    names = {"scene": sorted(PRESETS), "scenes": sorted(PRESETS), "technique": technique_names(),
             "techniques": technique_names(), "name": technique_names(), "environment": list(PROCEDURAL_ENVIRONMENTS)}
    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    arms = []
    for command, sub in commands.items():
        values, free, options, positional = [], [], [], []
        for action in sub._actions:
            if action.help == argparse.SUPPRESS:
                continue
            words = " ".join(action.choices or names.get(action.dest, []))
            if not action.option_strings:
                positional.append(words)
            elif action.nargs != 0:  # an option that takes a value: its words, else files (bash's default)
                if words:
                    values.append(f'        {"|".join(action.option_strings)}) _caustica_words "{words}"; return ;;\n')
                else:
                    free += action.option_strings
            options += action.option_strings
        if free:
            values.append(f'        {"|".join(free)}) COMPREPLY=(); return ;;\n')
        arms.append(f'    {command})\n        case "$prev" in\n{"".join(values)}        esac\n'
                    f'        _caustica_words "{" ".join(options)}" "{" ".join(positional)}" ;;\n')
    top = [*commands, *(o for a in parser._actions if a.option_strings for o in a.option_strings)]
    script = _COMPLETION.replace("@TOP@", " ".join(top)).replace("@ARMS@", "".join(arms))
    return ("autoload -U +X bashcompinit && bashcompinit\n" if shell == "zsh" else "") + script


_COMPLETION = """# caustica shell completion: eval "$(caustica completion bash)" (docs/cli.md)
_caustica_words() {
    # $1: the words for an option ("-" first) or, with $2, the options and the positional words
    if [[ "$cur" == -* || $# -eq 1 ]]; then
        COMPREPLY=($(compgen -W "$1" -- "$cur"))
    else
        COMPREPLY=($(compgen -W "$2" -- "$cur"))
    fi
}
_caustica() {
    local cur="${COMP_WORDS[COMP_CWORD]}" prev="${COMP_WORDS[COMP_CWORD-1]}" command="" i
    for ((i = 1; i < COMP_CWORD; i++)); do
        if [[ "${COMP_WORDS[i]}" != -* ]]; then command="${COMP_WORDS[i]}"; break; fi
    done
    case "$command" in
    "") _caustica_words "@TOP@" ;;
@ARMS@    esac
}
complete -o default -F _caustica caustica
"""


COMMANDS = {"render": cmd_render, "view": cmd_view, "compare": cmd_compare, "bench": cmd_bench,
            "export": cmd_export, "batch": cmd_batch, "precompute": cmd_precompute, "techniques": cmd_techniques,
            "plan": cmd_plan, "graph": cmd_graph, "presets": cmd_presets, "info": cmd_info,
            "completion": cmd_completion}

if __name__ == "__main__":
    sys.exit(main())
