"""Sweep files: what a batch varies from frame to frame, read and checked before any render (pure data).

A sweep is a TOML file with ``scene = ...`` at its top (docs/batch.md). Every varied key holds a
fixed value (``ior = 1.5``), a range (``{ uniform = [min, max] }``) or a list (``{ list = [...] }``,
drawn at random, or in turn with ``cycle = true``). Frame i draws each key from a numpy Generator
seeded by (seed, i, the key's name), so its values depend on nothing else: not on the worker, the
frames rendered before, nor the other keys of the file.
"""
from __future__ import annotations

import hashlib
import re
import string
import tomllib
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import numpy as np

from ..errors import SceneError, closest_name, first_line, short
from ..labels import FORMATS as LABEL_FORMATS
from ..passes.post.resolve import ANTIALIAS_MODES
from ..scene.io import _KIND_TEXT, _convert, _read_toml

NUMBER, VEC3, RGB, SCALE, STRING, MATERIAL = "number", "vec3", "rgb", "numbers3", "string", "material"
MAX_FRAMES = 10_000_000
MAX_SEED = 2 ** 63 - 1
DEFAULT_OUTPUT = "frame_{index:06d}"
IMAGE_FORMATS = ("png", "exr")

# The keys each table of a sweep file takes, and their kinds.
SETTINGS = {"scene": STRING, "frames": "integer", "seed": "integer", "size": "size", "spp": "integer",
            "antialias": STRING, "technique": STRING, "labels": "names", "labels_format": STRING,
            "image_format": STRING, "output": STRING}
TABLES = ("camera", "objects", "environment", "lights")
CAMERA_KEYS = {"position": VEC3, "look_at": VEC3, "distance": NUMBER, "elevation": NUMBER, "azimuth": NUMBER,
               "fov_y": NUMBER, "orbit": "orbit", "path": "path"}
OBJECT_KEYS = {"position": VEC3, "rotation": VEC3, "scale": SCALE, "material": MATERIAL, "ior": NUMBER,
               "absorption_color": RGB, "absorption_distance": NUMBER, "color": RGB}
ENVIRONMENT_KEYS = {"image": STRING, "rotation": NUMBER, "strength": NUMBER}
LIGHT_KEYS = {"position": VEC3, "direction": VEC3, "intensity": RGB}
_TEXT = {**_KIND_TEXT, MATERIAL: "a material table such as { type = 'glass', ior = 1.5 }"}
_FORMS = ("uniform", "list", "cycle")


@dataclass(frozen=True)
class Variation:
    """One varied key: ``key`` (``objects.ball.ior``), its kind, and how frames draw it: ``mode`` fixed
    (``values`` = (value,)), uniform ((min, max)), list or cycle (the entries), orbit ((degrees,)) or
    path (the points). Values are plain JSON data (numbers, lists, tables, strings)."""

    key: str
    kind: str
    mode: str
    values: tuple

    def value(self, seed: int, index: int, frames: int):
        """Frame ``index``'s value (of ``frames``)."""
        if self.mode == "fixed":
            return self.values[0]
        if self.mode == "cycle":
            return self.values[index % len(self.values)]
        if self.mode == "orbit":
            return self.values[0] * index / frames + 0.0  # + 0.0: no -0.0 in the manifest
        if self.mode == "path":
            return path_point(self.values, 0.0 if frames == 1 else index / (frames - 1))
        rng = np.random.default_rng([seed, index, _key_number(self.key)])
        if self.mode == "list":
            return self.values[int(rng.integers(len(self.values)))]
        low, high = (np.asarray(v, dtype=np.float64) for v in self.values)
        drawn = low + (high - low) * rng.random(low.shape)
        return drawn.tolist() if drawn.ndim else float(drawn)

    def extremes(self) -> tuple:
        """The values checked against the scene before any frame: every entry, or a range's ends."""
        return self.values if self.mode != "orbit" else (0.0,)


def _key_number(key: str) -> int:
    return int.from_bytes(hashlib.blake2b(key.encode(), digest_size=8).digest(), "little")


def path_point(points, t: float) -> list:
    """The point at fraction ``t`` of the polyline's length (its first point when it has none)."""
    points = np.asarray(points, dtype=np.float64)
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    total = float(lengths.sum())
    if total == 0.0:
        return points[0].tolist()
    along = np.concatenate([[0.0], np.cumsum(lengths)]) / total
    return [float(np.interp(t, along, points[:, k])) for k in range(3)]


@dataclass(frozen=True)
class Sweep:
    """A parsed sweep file: the scene it starts from, the settings it gives and what it varies."""

    scene: str
    base_dir: str
    settings: dict = field(default_factory=dict)
    variations: tuple = ()


def is_sweep_file(path) -> bool:
    """Whether ``path`` is a TOML file with a top-level ``scene`` key or a setting only sweeps take
    (``frames``, ``seed``...: a sweep that forgot ``scene``); a scene file has none of them."""
    path = Path(path)
    if path.suffix.lower() != ".toml" or not path.is_file():
        return False
    try:
        return any(key in SETTINGS for key in tomllib.loads(path.read_text(encoding="utf-8")))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False  # the scene loader reports it


def read_sweep(path) -> Sweep:
    """The sweep in ``path``; SceneError in one line naming the key for anything wrong in it."""
    path = Path(path)
    return parse_sweep(_read_toml(path), path.parent, path.name)


def parse_sweep(data: dict, base_dir=".", name: str = "sweep") -> Sweep:
    """A Sweep from a parsed TOML document; ``scene`` and files resolve against ``base_dir``."""
    _known(data, {**SETTINGS, **dict.fromkeys(TABLES)}, name, "the top level")
    if "scene" not in data:
        given = ", ".join(key for key in data if key in SETTINGS)
        raise SceneError(f"{name}: a sweep needs scene = ... at its top, the preset or scene file it starts from "
                         f"(it has {short(given)} but no scene); add e.g. scene = 'caustic-sphere'")
    settings = {key: _setting(key, kind, data[key], name) for key, kind in SETTINGS.items() if key in data}
    scene = settings.pop("scene")
    if Path(scene).suffix:  # a file, relative to the sweep; a preset is a bare name
        scene = str(Path(base_dir) / scene)
    variations = []
    for table, keys in (("camera", CAMERA_KEYS), ("environment", ENVIRONMENT_KEYS)):
        variations += _table(_sub(data, table, name), table, keys, name)
    for kind, keys in (("objects", OBJECT_KEYS), ("lights", LIGHT_KEYS)):
        for item, entries in _sub(data, kind, name).items():
            _dotted_name(entries, kind, item, keys, name)
            variations += _table(entries, f"{kind}.{item}", keys, name)
    check_output(settings.get("output", DEFAULT_OUTPUT))
    return Sweep(scene, str(base_dir), settings, tuple(variations))


def _known(data, keys, name: str, where: str) -> None:
    for key in data:
        if key not in keys:
            raise SceneError(f"{name}: unknown key {short(key)} in {where}{closest_name(str(key), keys)}; "
                             f"allowed keys: {', '.join(keys)}")


def _dotted_name(entries: dict, kind: str, item: str, keys, name: str) -> None:
    """TOML reads [objects.Sphere.001] (an exporter's name, Blender's) as object 'Sphere' with a table
    '001': say how to quote the name rather than call '001' an unknown key."""
    for key, value in entries.items():
        if key not in keys and isinstance(value, dict):
            raise SceneError(f"{name}: [{kind}.{item}.{key}] is read as {kind[:-1]} {item!r} with a table {key!r}; "
                             f"a name with a dot goes in quotes: [{kind}.\"{item}.{key}\"]")


def _sub(data: dict, key: str, name: str) -> dict:
    value = data.get(key, {})
    nested = key in ("objects", "lights")
    if not isinstance(value, dict) or nested and any(not isinstance(v, dict) for v in value.values()):
        example = "[objects.ball] ior = ..." if key == "objects" else "[lights.0] position = ..." if key == "lights" \
            else f"[{key}]"
        raise SceneError(f"{name}: {key} must be a table{' of tables' if nested else ''}, e.g. {example}")
    return value


def _setting(key: str, kind: str, value, name: str):
    if kind == "integer":
        if not isinstance(value, int) or isinstance(value, bool):
            raise SceneError(f"{name}: {key} must be an integer (got {short(value)})")
        if key == "frames" and not 1 <= value <= MAX_FRAMES:
            raise SceneError(f"{name}: frames must be in [1, {MAX_FRAMES}] (got {value}); give a positive count")
        if key == "seed":
            check_seed(value, f"{name}: seed")
        if key == "spp" and value < 1:
            raise SceneError(f"{name}: spp must be at least 1 (got {value})")
        return value
    if kind == "size":
        if not (isinstance(value, list) and len(value) == 2 and all(_convert(v, "integer") is not None for v in value)):
            raise SceneError(f"{name}: size must be two integers [width, height] (got {short(value)})")
        from ..scene import rules

        return rules.image_size(value, f"{name}: size")
    if kind == "names":
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise SceneError(f"{name}: labels must be a list of names, e.g. ['depth', 'id'] (got {short(value)})")
        return tuple(value)
    if not isinstance(value, str):
        raise SceneError(f"{name}: {key} must be a string (got {short(value)})")
    for option, choices in (("labels_format", LABEL_FORMATS), ("image_format", IMAGE_FORMATS),
                            ("antialias", ANTIALIAS_MODES)):
        if key == option and value not in choices:
            raise SceneError(f"{name}: {key} {short(value)} is unknown{closest_name(value, choices)}; "
                             f"choose one of {', '.join(choices)}")
    return value


def _table(entries: dict, where: str, keys: dict, name: str) -> list[Variation]:
    _known(entries, keys, name, where)
    return [_variation(f"{where}.{key}", keys[key], value, name) for key, value in entries.items()]


def _variation(key: str, kind: str, value, name: str) -> Variation:
    if kind == "orbit":
        return Variation(key, NUMBER, "orbit", (_value(value, NUMBER, key, name),))
    if kind == "path":
        if not isinstance(value, list) or len(value) < 2:
            raise SceneError(f"{name}: {key} must be a list of at least two positions [[x, y, z], ...]")
        return Variation(key, VEC3, "path", tuple(_value(p, VEC3, f"{key}[{i}]", name) for i, p in enumerate(value)))
    form = [f for f in _FORMS if isinstance(value, dict) and f in value]
    if not form or kind == MATERIAL and isinstance(value, dict) and "type" in value:
        return Variation(key, kind, "fixed", (_value(value, kind, key, name),))
    _known(value, ("uniform", "list", "cycle"), name, key)
    if "cycle" in value and not isinstance(value["cycle"], bool):
        raise SceneError(f"{name}: {key}.cycle must be true or false (got {short(value['cycle'])})")
    if "uniform" in value:
        if "list" in value or "cycle" in value:
            raise SceneError(f"{name}: {key} has uniform with list or cycle; give either uniform = [min, max] "
                             "or list = [...]")
        return _uniform(key, kind, value["uniform"], name)
    if "list" not in value:
        raise SceneError(f"{name}: {key}.cycle needs a list = [...] of values beside it")
    entries = value["list"]
    if not isinstance(entries, list) or not entries:
        raise SceneError(f"{name}: {key}.list must be a non-empty list of {_TEXT[kind]} (got {short(entries)})")
    values = tuple(_value(v, kind, f"{key}.list[{i}]", name) for i, v in enumerate(entries))
    return Variation(key, kind, "cycle" if value.get("cycle") else "list", values)


def _uniform(key: str, kind: str, ends, name: str) -> Variation:
    if kind not in (NUMBER, VEC3, RGB, SCALE):
        raise SceneError(f"{name}: {key} is {_TEXT[kind]} and has no range; give list = [...] instead")
    if not isinstance(ends, list) or len(ends) != 2:
        raise SceneError(f"{name}: {key}.uniform must be [min, max] (got {short(ends)})")
    low, high = (_value(v, kind, f"{key}.uniform", name) for v in ends)
    if isinstance(low, float) != isinstance(high, float):
        raise SceneError(f"{name}: {key}.uniform mixes a number and a vector; give two numbers or two vectors")
    if np.any(np.asarray(low) > np.asarray(high)):
        raise SceneError(f"{name}: {key}.uniform min {short(low)} is above max {short(high)}; write [min, max]")
    return Variation(key, kind, "uniform", (low, high))


def _value(value, kind: str, key: str, name: str):
    """``value`` checked as ``kind``, as plain data: a float, a list of floats, a string or a table."""
    if kind == MATERIAL:
        if not isinstance(value, dict) or "type" not in value:
            raise SceneError(f"{name}: {key} must be {_TEXT[kind]} (got {short(value)})")
        return value
    converted = _convert(value, kind)
    if converted is None:
        raise SceneError(f"{name}: {key} must be {_TEXT[kind]} (got {short(value)})")
    if kind in (RGB, SCALE) and not isinstance(value, list):
        return float(value)  # one number for every component
    return converted.tolist() if isinstance(converted, np.ndarray) else converted


def check_seed(seed, where: str = "seed") -> int:
    """``seed`` when it is an integer in [0, MAX_SEED] (what numpy's SeedSequence takes); SceneError otherwise."""
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise SceneError(f"{where} must be an integer in [0, {MAX_SEED}] (got {short(seed)}); give e.g. seed = 0")
    return seed


def _not_a_format(where: str, exc: Exception) -> SceneError:
    return SceneError(f"{where} is not a format string ({first_line(exc)}); write e.g. {DEFAULT_OUTPUT!r}")


# An {index} field's format spec: [[fill]align][sign][#][0][width][grouping][type], an integer type only.
_INDEX_SPEC = re.compile(r"(?:.?[<>=^])?[-+ ]?#?0?(?P<width>\d*)[,_]?[bdoxXn]?", re.DOTALL)
MAX_INDEX_WIDTH = 32  # digits a frame number is padded to at most
MAX_STEM_PART = 200  # bytes (UTF-8) of one folder or file name of a frame (room for '.labels.exr' within 255)
MAX_STEM = 1000  # bytes of a frame's whole relative name


def check_output(pattern: str) -> str:
    """``pattern`` when it names one file stem per frame inside the output folder: only ``{index}``
    fields, at least one, each with an integer format spec at most MAX_INDEX_WIDTH wide, names within
    MAX_STEM_PART (each part) and MAX_STEM bytes for any frame, a relative path without '..';
    SceneError otherwise, checked before anything is formatted."""
    where = f"output pattern {short(pattern)}"
    if not isinstance(pattern, str):
        raise SceneError(f"{where} must be a string, e.g. {DEFAULT_OUTPUT!r}")
    try:
        fields = [(f, spec, conversion) for _, f, spec, conversion in string.Formatter().parse(pattern)
                  if f is not None]
    except ValueError as exc:
        raise _not_a_format(where, exc) from None
    if not fields or any(f != "index" for f, _, _ in fields):
        raise SceneError(f"{where} must use {{index}} and no other field, e.g. {DEFAULT_OUTPUT!r}")
    for _, spec, conversion in fields:
        match = _INDEX_SPEC.fullmatch(spec or "")
        if conversion is not None or match is None:
            field_text = "{index" + (f"!{conversion}" if conversion else "") + (f":{spec}" if spec else "") + "}"
            raise SceneError(f"{where}: {field_text} is not an integer format; write e.g. {{index:06d}} (fill, "
                             "align, width and d, x, o or b only)")
        if match["width"] and int(match["width"]) > MAX_INDEX_WIDTH:
            raise SceneError(f"{where} pads the frame number to {int(match['width'])} characters, above "
                             f"{MAX_INDEX_WIDTH}; give a width such as {{index:06d}}")
    try:
        stem, longest = pattern.format(index=0), pattern.format(index=MAX_FRAMES - 1)
    except ValueError as exc:  # e.g. {index:,x}
        raise _not_a_format(where, exc) from None
    size = len(longest.encode("utf-8", "surrogatepass"))
    if size > MAX_STEM or any(len(p.encode("utf-8", "surrogatepass")) > MAX_STEM_PART for p in longest.split("/")):
        raise SceneError(f"{where} makes names of up to {size} bytes; keep each file or folder name within "
                         f"{MAX_STEM_PART} bytes and the whole within {MAX_STEM}")
    parts = PurePosixPath(stem).parts
    if "\\" in stem or "\x00" in stem or not parts or stem.startswith("/") or any(p in ("..", ".") for p in parts) \
            or stem.endswith("/"):
        raise SceneError(f"{where} would write outside the output folder; give a relative name without '..', "
                         f"e.g. {DEFAULT_OUTPUT!r}")
    return pattern
