"""TOML scene files (and built-in presets) to :class:`Scene`.

Every key is checked: an unknown key, a wrong type or an out-of-range value
raises :class:`SceneError` (or its mesh/environment subclasses) with one line
that names the key as ``table[index].key`` and says how to fix it. The format:

    name = "demo"                  # optional
    intensity_scale = 1.0
    [camera]                       # position, look_at, up, fov_y or fov_x (degrees), near, far, size
    [environment]                  # file = "env.exr" (relative to the scene file) or procedural = "sky-checker"
    [[lights]]                     # type = "point" | "directional" | "spot" | "line"
    [[objects]]                    # shape = "sphere" (+ its parameters) or mesh = "file.obj";
                                   # position (alias center), rotation (degrees), scale, material = {type = ...}
                                   # (diffuse, mirror, glass, water or principled: docs/materials.md)
                                   # or gltf = "model.glb" (its objects and lights; position, rotation, scale, lights)

``.glb``/``.gltf`` files load as whole scenes (scene/gltf, docs/gltf.md); :func:`export_scene` writes
a scene as glTF or Mitsuba XML by the output's suffix.
"""
from __future__ import annotations

import errno
import functools
import inspect
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np

from ..errors import SceneError, closest_name, short
from . import budget, rules
from .camera import Camera, fov_y_from_fov_x
from .environment import PROCEDURAL_ENVIRONMENTS, Environment, load_environment, procedural_environment
from .gltf import GLTF_SUFFIXES
from .lights import DirectionalLight, LineLight, PointLight, SpotLight
from .materials import Diffuse, Glass, Mirror, Principled, water
from .mesh import Mesh
from .mesh_files import load_mesh
from .scene import Scene, SceneObject
from .shapes import SHAPES
from .textures import PROCEDURAL_TEXTURES, load_texture, procedural_texture
from .transform import Transform

MAX_IMAGE_SIZE = rules.MAX_IMAGE_SIZE
_REQUIRED = object()

# Value kinds a key can hold, each with the phrase used in error messages.
NUMBER, INTEGER, BOOLEAN, STRING, VEC3, RGB = "number", "integer", "boolean", "string", "vec3", "rgb"
_KIND_TEXT = {
    NUMBER: "a finite number", INTEGER: "an integer", BOOLEAN: "true or false", STRING: "a string",
    VEC3: "three numbers [x, y, z]", RGB: "a number or three numbers [r, g, b]",
    "numbers2": "a number or two numbers", "numbers3": "a number or three numbers",
}

CAMERA_KEYS = {"position": VEC3, "look_at": VEC3, "up": VEC3, "fov_x": NUMBER, "fov_y": NUMBER,
               "near": NUMBER, "far": NUMBER, "size": "size"}
LIGHT_KEYS = {
    "point": {"position": VEC3, "intensity": RGB},
    "directional": {"direction": VEC3, "intensity": RGB},
    "spot": {"position": VEC3, "direction": VEC3, "look_at": VEC3, "intensity": RGB,
             "inner_angle": NUMBER, "outer_angle": NUMBER},
    "line": {"start": VEC3, "end": VEC3, "intensity": RGB, "samples": INTEGER},
}
_GLASS_KEYS = {"ior": NUMBER, "absorption_color": RGB, "absorption_distance": NUMBER, "abbe": NUMBER}
PRINCIPLED_KEYS = {"base_color": RGB, "base_color_texture": STRING, "metallic": NUMBER, "roughness": NUMBER,
                   "metallic_roughness_texture": STRING, "normal_texture": STRING, "normal_scale": NUMBER,
                   "occlusion_texture": STRING, "occlusion_strength": NUMBER, "emission": RGB,
                   "emission_texture": STRING, "specular": NUMBER, "specular_color": RGB, "transmission": NUMBER,
                   "ior": NUMBER, "attenuation_color": RGB, "attenuation_distance": NUMBER, "thickness": NUMBER,
                   "dispersion": NUMBER}
MATERIALS = {
    "glass": (Glass, _GLASS_KEYS),
    "water": (water, _GLASS_KEYS),
    "diffuse": (Diffuse, {"color": RGB, "texture": STRING}),
    "mirror": (Mirror, {"color": RGB}),
    "principled": (Principled, PRINCIPLED_KEYS),
}
TEXTURE_KEYS = ("texture",) + Principled.TEXTURES  # image files (or procedural textures) of the materials
DATA_TEXTURES = ("metallic_roughness_texture", "normal_texture", "occlusion_texture")  # linear, not sRGB
OBJECT_KEYS = {"name": STRING, "shape": STRING, "mesh": STRING, "center": VEC3, "position": VEC3,
               "rotation": VEC3, "scale": "scale", "material": "material"}
GLTF_OBJECT_KEYS = {"gltf": STRING, "position": VEC3, "rotation": VEC3, "scale": "scale", "lights": BOOLEAN}
EXPORT_SUFFIXES = GLTF_SUFFIXES + (".xml",)
_OBJECT_HEADER = re.compile(r"^[ \t]*\[\[[ \t]*objects[ \t]*\]\]", re.MULTILINE)


def load_scene(source: str | Path, camera: str | None = None) -> Scene:
    """A built-in preset by name, a TOML scene file or a glTF 2.0 file (``.glb``, ``.gltf``); ``camera``
    names one of the scene's glTF cameras (a glTF file's, or those of a TOML's ``gltf`` entries)."""
    from .presets import PRESETS

    if camera is not None and not isinstance(camera, str):
        raise SceneError(f"camera {short(camera)} must be the name of a glTF camera (a string)")
    if camera is not None and isinstance(source, str) and source in PRESETS:
        raise SceneError(f"preset {source!r} has no glTF cameras to choose from; drop the camera name")

    if not isinstance(source, (str, Path)):
        raise SceneError(f"a scene is a preset name or a .toml file path, not {short(source)}; "
                         "run 'caustica presets' for the built-in scenes")
    if isinstance(source, str) and source in PRESETS:
        return PRESETS[source]()
    if not str(source).strip():
        raise SceneError("the scene name is empty; give a preset name (see 'caustica presets') or a .toml file")
    path = _path(source, "scene file")
    if not _exists(path, "scene file"):
        if path.suffix == "" and path.parent == Path("."):
            raise SceneError(f"unknown preset {short(str(source))}{closest_name(str(source), PRESETS)}; "
                             "run 'caustica presets' to list them, or give a .toml scene file")
        raise SceneError(f"scene file not found: {path}; check the path, or run 'caustica presets' for the built-in scenes")
    if not path.is_file():
        raise SceneError(f"scene path {path} is not a file; give a .toml scene file")
    if path.suffix.lower() in GLTF_SUFFIXES:
        return _load_gltf(path, camera)
    return parse_scene(_read_toml(path), base_dir=path.parent, default_name=path.stem, camera=camera)


def _load_gltf(path: str | Path, camera: str | None = None):
    """A Scene from a ``.glb``/``.gltf`` file: its objects and lights, the camera called ``camera`` (else
    the first; without any, one framing the scene) and the environment caustica's export kept in
    ``extras.caustica`` (else caustica's default one). ``scene.gltf`` records what export writes back."""
    from .gltf.read import choose_camera, read_gltf

    path = Path(path)
    imported = read_gltf(path)
    scene = Scene(objects=imported.objects, lights=imported.lights, name=imported.name, gltf=imported.origin)
    if imported.environment is not None:
        scene.environment = _kept_environment(imported.environment, path)
    scene.camera = choose_camera([imported], camera, scene.bounds())
    return scene


def _kept_environment(table: dict, path: Path):
    """The environment of caustica's ``extras.caustica.environment`` in a glTF document: a TOML
    [environment] table, its file inside the glTF's folder."""
    file = table.get("file")
    folder = path.parent.resolve()
    if isinstance(file, str) and not _inside(folder, file):
        raise SceneError(f"{path.name}: extras.caustica.environment.file {file!r} leaves the glTF's folder; copy "
                         "the image beside the glTF and name it by a relative path")
    try:
        return _environment(table, path.parent)
    except SceneError as exc:
        raise type(exc)(f"{path.name}: in extras.caustica: {exc}") from None


def _inside(folder: Path, relative: str) -> bool:
    """Whether ``relative`` names a path inside ``folder`` (False for one that cannot be resolved)."""
    try:
        return (folder / relative).resolve().is_relative_to(folder)
    except (OSError, ValueError, RuntimeError):
        return False


def export_scene(scene: Scene, path: str | Path) -> Path:
    """Write ``scene`` by the suffix of ``path``: ``.glb``/``.gltf`` (glTF 2.0, scene/gltf) or ``.xml``
    (Mitsuba 3, reference/mitsuba_export); OutputError for another suffix."""
    from ..errors import OutputError

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in GLTF_SUFFIXES:
        from .gltf import write_gltf

        return write_gltf(scene, path)
    if suffix == ".xml":
        from ..reference.mitsuba_export import write_mitsuba_xml

        write_mitsuba_xml(scene, path)
        return path
    raise OutputError(f"cannot export to '{path.name}': the output must end in {', '.join(EXPORT_SUFFIXES)}")


def _path(name, what: str) -> Path:
    """``name`` as a Path; SceneError for a name the OS cannot take (a NUL byte)."""
    if "\x00" in str(name):
        raise SceneError(f"{what} name {short(str(name))} holds a NUL byte; give a valid file name")
    return Path(name)


def _exists(path: Path, what: str) -> bool:
    """Whether ``path`` exists (a name too long for the OS does not); SceneError for a name the OS refuses."""
    try:
        return path.exists()
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            return False
        raise SceneError(f"cannot look up {what} {short(str(path))}: {exc.strerror or exc}; give a valid file name") \
            from None


def _read_toml(path: Path) -> dict:
    """The TOML document in ``path``, or SceneError with the parser's line and column."""
    try:
        data = path.read_bytes()
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        if data[:4] == b"glTF":
            raise SceneError(f"scene file {path} is a binary glTF; name it .glb to load it as one") from None
        raise SceneError(f"scene file {path} is not UTF-8 text; save it as UTF-8 TOML") from None
    except OSError as exc:
        raise SceneError(f"cannot read scene file {path}: {exc.strerror or exc}; check its permissions") from None
    # The object budget before the parse, which takes about 50 microseconds an object.
    budget.check_objects(len(_OBJECT_HEADER.findall(text)), f"scene file {path} has")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"TOML syntax error in {path}: {str(exc).splitlines()[0]}; fix the scene file") from None
    except RecursionError:  # tomllib recurses once per level of nested arrays or inline tables
        raise SceneError(f"scene file {path} nests arrays or inline tables too deeply for the TOML parser; "
                         "flatten the scene file (scenes need at most a few levels)") from None


def parse_scene(data: dict, base_dir: str | Path = ".", default_name: str = "scene",
                camera: str | None = None) -> Scene:
    """A Scene from a parsed TOML document; relative file paths resolve against ``base_dir``.

    ``gltf`` entries of ``[[objects]]`` add their file's objects and (unless ``lights = false``) lights.
    The camera is the ``[camera]`` table; without one, or when ``camera`` names a glTF camera, the glTF
    entries' camera (the first, or the one named; without any, one framing the scene)."""
    from .gltf.read import choose_camera

    top = _Table(data, "", {"name": STRING, "intensity_scale": NUMBER, "camera": "table", "environment": "table",
                            "lights": "array", "objects": "array"})
    base_dir = Path(base_dir)
    imports = []
    scene = Scene(
        camera=_camera(top.table("camera")),
        objects=_objects(top.tables("objects"), base_dir, imports),
        lights=[_light(t, f"lights[{i}]") for i, t in enumerate(top.tables("lights"))],
        environment=_environment(top.table("environment"), base_dir),
        intensity_scale=rules.intensity_scale(top.get("intensity_scale", NUMBER, 1.0)),
        name=top.get("name", STRING, default_name),
    )
    for imported, with_lights in imports:
        if with_lights:
            scene.lights += imported.lights
    if camera is not None and not imports:
        raise SceneError(f"camera {short(camera)} names a glTF camera, and this scene has no gltf objects; "
                         "drop the camera name or set [camera] in the scene")
    if imports and (camera is not None or "camera" not in top):
        scene.camera = choose_camera([g for g, _ in imports], camera, scene.bounds())
    if imports:  # what export writes back of the glTF files' parts (scene/gltf/origin.py)
        scene.gltf = functools.reduce(lambda a, b: a.merged(b), [g.origin for g, _ in imports])
    return scene


class _Table:
    """One TOML table being read: strict key check and typed getters naming ``where.key`` on error."""

    def __init__(self, data, where: str, keys: dict):
        if not isinstance(data, dict):
            raise SceneError(f"{where} must be a table (e.g. [{where}] or {where} = {{...}})")
        self.data, self.where, self.keys = data, where, keys
        for key in data:
            if key not in keys:
                place = where or "the scene's top level"
                raise SceneError(f"unknown key {short(key)} in {place}{closest_name(str(key), keys)}; "
                                 f"allowed keys: {', '.join(keys)}")

    def name(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def __contains__(self, key: str) -> bool:
        return key in self.data

    def get(self, key: str, kind: str, default=_REQUIRED):
        """The value of ``key`` converted to ``kind``; ``default`` when absent (SceneError if required)."""
        if key not in self.data:
            if default is _REQUIRED:
                raise SceneError(f"{self.where} needs '{key}'; add {key} = <{_KIND_TEXT.get(kind, kind)}>")
            return default
        value = _convert(self.data[key], kind)
        if value is None:
            raise SceneError(f"{self.name(key)} must be {_KIND_TEXT[kind]} (got {short(self.data[key])})")
        return value

    def table(self, key: str) -> dict:
        """A sub-table (empty when absent)."""
        return self.data.get(key, {})

    def tables(self, key: str) -> list[dict]:
        """An array of tables ([[key]]), empty when absent."""
        value = self.data.get(key, [])
        if not isinstance(value, list) or not all(isinstance(t, dict) for t in value):
            raise SceneError(f"{key} must be an array of tables: write each entry under [[{key}]]")
        return value


def _is_number(x) -> bool:
    """A TOML int or float that is finite as a float (rules.finite: an int too big for a float is not)."""
    return isinstance(x, (int, float)) and rules.finite(x)


def _convert(value, kind: str):
    """``value`` as ``kind`` (float, int, bool, str, or a float64 array), or None when it does not fit."""
    if kind == NUMBER:
        return float(value) if _is_number(value) else None
    if kind == INTEGER:
        return value if isinstance(value, int) and not isinstance(value, bool) else None
    if kind == BOOLEAN:
        return value if isinstance(value, bool) else None
    if kind == STRING:
        return value if isinstance(value, str) else None
    if kind in (VEC3, RGB) or kind.startswith("numbers"):
        count = 3 if kind in (VEC3, RGB) else int(kind[len("numbers"):])
        if kind != VEC3 and _is_number(value):
            return np.full(count, float(value))
        ok = isinstance(value, list) and len(value) == count and all(_is_number(v) for v in value)
        return np.array(value, dtype=np.float64) if ok else None
    raise AssertionError(f"unknown value kind {kind}")


def _numbers(count: int) -> str:
    """The kind 'a number or ``count`` numbers' (a single number is repeated)."""
    kind = f"numbers{count}"
    assert kind in _KIND_TEXT, f"no message for {kind}"
    return kind


# Tables ------------------------------------------------------------------------


def _camera(data: dict) -> Camera:
    table = _Table(data, "camera", CAMERA_KEYS)
    size = _image_size(table)
    if "fov_x" in table and "fov_y" in table:
        raise SceneError("camera has both fov_x and fov_y; give only one of them")
    fov_y = table.get("fov_y", NUMBER, 40.0)
    if "fov_x" in table:
        fov_x = table.get("fov_x", NUMBER)
        if not 0.0 < fov_x < 180.0:
            raise SceneError(f"camera.fov_x {fov_x} must lie strictly between 0 and 180 degrees")
        fov_y = fov_y_from_fov_x(fov_x, *size)
    with rules.context("camera", CAMERA_KEYS):
        return Camera(
            position=table.get("position", VEC3, [0.0, 0.0, 4.0]),
            look_at=table.get("look_at", VEC3, [0.0, 0.0, 0.0]),
            up=table.get("up", VEC3, [0.0, 1.0, 0.0]),
            fov_y=fov_y,
            near=table.get("near", NUMBER, 0.05),
            far=table.get("far", NUMBER, 100.0),
            size=size,
        )


def _image_size(table: _Table) -> tuple[int, int]:
    value = table.data.get("size", [512, 512])
    if not (isinstance(value, list) and len(value) == 2 and all(_convert(v, INTEGER) is not None for v in value)):
        raise SceneError(f"camera.size must be two integers [width, height] (got {short(value)})")
    return rules.image_size(value, "camera.size")


def _environment(data: dict, base_dir: Path) -> Environment:
    table = _Table(data, "environment", {"file": STRING, "procedural": STRING, "rotation": NUMBER,
                                         "strength": NUMBER, "filter": STRING})
    if "file" in table and "procedural" in table:
        raise SceneError("environment has both file and procedural; give only one of them")
    rotation, strength = table.get("rotation", NUMBER, 0.0), table.get("strength", NUMBER, 1.0)
    with rules.context("environment", ("file", "procedural", "rotation", "strength", "filter")):
        if "file" in table:
            env = load_environment(base_dir / _path(table.get("file", STRING), "environment.file"))
        else:
            name = table.get("procedural", STRING, "sky-checker")
            if name not in PROCEDURAL_ENVIRONMENTS:
                raise SceneError(f"procedural {short(name)} is unknown{closest_name(name, PROCEDURAL_ENVIRONMENTS)}; "
                                 f"choose one of {', '.join(PROCEDURAL_ENVIRONMENTS)}")
            env = procedural_environment(name)
        # Only what the table asks for touches the image: a scene without these keys renders as before.
        if rotation != 0.0:
            env = env.rotated(rotation)
        if strength != 1.0:
            env = env.scaled(strength)
        if "filter" in table:
            env.filter = table.get("filter", STRING)
            env.validate()
        return env


def _typed(data: dict, where: str, kinds: dict, role: str) -> tuple[str, dict]:
    """The ``type`` of a light or material table, checked against ``kinds``, and the keys for it."""
    if not isinstance(data, dict):
        raise SceneError(f"{where} must be a table with a type, e.g. {{ type = '{next(iter(kinds))}' }}")
    kind = data.get("type")
    if not isinstance(kind, str) or kind not in kinds:
        hint = closest_name(kind, kinds) if isinstance(kind, str) else ""
        what = f"type {short(kind)} is unknown{hint}" if "type" in data else "needs a type"
        raise SceneError(f"{where} {what}; choose a {role} type from {', '.join(kinds)}")
    return kind, {"type": STRING, **kinds[kind]}


def _light(data: dict, where: str):
    kind, keys = _typed(data, where, LIGHT_KEYS, "light")
    table = _Table(data, where, keys)
    intensity = table.get("intensity", RGB, np.full(3, 10.0 if kind != "directional" else 3.0))
    with rules.context(where, keys):
        if kind == "point":
            return PointLight(table.get("position", VEC3), intensity)
        if kind == "directional":
            return DirectionalLight(table.get("direction", VEC3), intensity)
        if kind == "line":
            return LineLight(table.get("start", VEC3), table.get("end", VEC3), intensity,
                             table.get("samples", INTEGER, 8))
        position = table.get("position", VEC3)
        if ("direction" in table) == ("look_at" in table):
            raise SceneError("a spot light needs exactly one of direction or look_at")
        direction = table.get("direction", VEC3) if "direction" in table else table.get("look_at", VEC3) - position
        return SpotLight(position, direction, intensity, table.get("inner_angle", NUMBER, 20.0),
                         table.get("outer_angle", NUMBER, 30.0))


def _material(data, where: str, base_dir: Path = Path(".")):
    """A material table (or just its type name as a string); diffuse grey when absent. A texture key
    (a diffuse ``texture``, a principled ``*_texture``) is a PNG/JPEG file relative to ``base_dir`` or a
    procedural texture's name; colour textures are sRGB-decoded, the DATA_TEXTURES read as linear values."""
    if data is None:
        return Diffuse()
    if isinstance(data, str):
        data = {"type": data}
    kind, keys = _typed(data, where, {k: v[1] for k, v in MATERIALS.items()}, "material")
    table = _Table(data, where, keys)
    values = {key: table.get(key, keys[key]) for key in data if key != "type"}
    for key in TEXTURE_KEYS:
        if key in values:
            values[key] = _texture(values[key], base_dir, table.name(key), srgb=key not in DATA_TEXTURES)
    with rules.context(where, keys):
        return MATERIALS[kind][0](**values)


def _texture(value: str, base_dir: Path, where: str, srgb: bool = True):
    """A texture key's image: a procedural texture's name, else a file relative to ``base_dir`` (decoded
    from sRGB, or with ``srgb`` False read as linear data)."""
    if value in PROCEDURAL_TEXTURES:
        return procedural_texture(value)
    if Path(value).suffix == "":
        raise SceneError(f"{where} {short(value)} is no procedural texture{closest_name(value, PROCEDURAL_TEXTURES)} "
                         f"nor an image file; give one of {', '.join(PROCEDURAL_TEXTURES)} or a .png/.jpg file")
    return load_texture(base_dir / _path(value, where), where, srgb)


@functools.cache
def _shape_keys(shape: str) -> dict:
    """The parameters a shape takes (from its function signature) and their kinds (from the defaults)."""
    keys = {}
    for name, param in inspect.signature(SHAPES[shape]).parameters.items():
        default = param.default
        if isinstance(default, bool):
            keys[name] = BOOLEAN
        elif isinstance(default, int):
            keys[name] = INTEGER
        elif isinstance(default, tuple):
            keys[name] = _numbers(len(default))
        else:
            keys[name] = NUMBER
    return keys


def _objects(entries: list[dict], base_dir: Path, imports: list) -> list[SceneObject]:
    """The objects of ``[[objects]]``; each ``gltf`` entry's file contents are appended to ``imports``
    as (GltfScene, whether its lights are wanted). The scene's budget (scene/budget.py) is checked before
    any object is built (their count) and as each mesh is known (triangles, bytes); equal shapes and mesh
    files share one Mesh."""
    objects, meshes, owner = [], {}, {}
    totals = budget.SceneBudget("the scene")
    totals.objects(len(entries))
    for i, data in enumerate(entries):
        where = f"objects[{i}]"
        if isinstance(data, dict) and "gltf" in data:
            imported, with_lights = _gltf_entry(data, where, base_dir)
            imports.append((imported, with_lights))
            totals.objects(len(imported.objects) - 1)  # the entry was counted as one
            for obj in imported.objects:
                totals.mesh(obj.mesh, where)
                base, n = obj.name, 2
                while obj.name in owner:
                    obj.name, n = f"{base}-{n}", n + 1
                owner[obj.name] = where
                objects.append(obj)
            continue
        obj = _object(data, where, base_dir, meshes)
        totals.mesh(obj.mesh, where)
        if obj.name in owner:
            if "name" in data:
                raise SceneError(f"{where}.name {short(obj.name)} is already used by {owner[obj.name]}; "
                                 "give each object its own name")
            obj.name = f"{obj.name}-{i}"
        owner[obj.name] = where
        objects.append(obj)
    return objects


def _gltf_entry(data: dict, where: str, base_dir: Path):
    """A ``gltf = "model.glb"`` entry: the file read with the entry's placement, and its ``lights`` flag."""
    from .gltf.read import read_gltf

    table = _Table(data, where, GLTF_OBJECT_KEYS)
    name = table.get("gltf", STRING)
    path = base_dir / _path(name, f"{where}.gltf")
    if path.suffix.lower() not in GLTF_SUFFIXES:
        raise SceneError(f"{where}.gltf {short(name)} must be a .glb or .gltf file; use mesh = for other formats")
    if not _exists(path, f"{where}.gltf") or not path.is_file():
        raise SceneError(f"{where}.gltf: file {path} not found; check the path (relative to the scene file)")
    with rules.context(where, table.keys):
        placement = Transform(position=table.get("position", VEC3, np.zeros(3)),
                              rotation=table.get("rotation", VEC3, np.zeros(3)),
                              scale=table.get("scale", _numbers(3), np.ones(3))).world_from_object()
    return read_gltf(path, placement), table.get("lights", BOOLEAN, True)


def _object(data: dict, where: str, base_dir: Path, meshes: dict) -> SceneObject:
    """One ``[[objects]]`` entry; ``meshes`` holds the meshes made so far, by file path or shape and parameters."""
    if not isinstance(data, dict):
        raise SceneError(f"{where} must be a table")
    # What the geometry is decides which keys are allowed.
    if ("shape" in data) == ("mesh" in data):
        raise SceneError(f"{where} needs exactly one of shape = '<name>' or mesh = '<file>'; "
                         f"shapes: {', '.join(SHAPES)}")
    shape = data.get("shape")
    if shape is not None and (not isinstance(shape, str) or shape not in SHAPES):
        hint = closest_name(shape, SHAPES) if isinstance(shape, str) else ""
        raise SceneError(f"{where}.shape {short(shape)} is unknown{hint}; choose one of {', '.join(SHAPES)}")
    shape_keys = _shape_keys(shape) if shape else {}
    table = _Table(data, where, {**OBJECT_KEYS, **shape_keys})
    if "center" in table and "position" in table:
        raise SceneError(f"{where} has both center and position; give only one of them")
    with rules.context(where, table.keys):
        if shape:
            params = {key: table.get(key, kind) for key, kind in shape_keys.items() if key in table}
            key = (shape, *sorted((k, np.asarray(v).tobytes()) for k, v in params.items()))
            if key not in meshes:
                meshes[key] = _shape(shape, params, where)
            mesh = meshes[key]
        else:
            path = base_dir / _path(table.get("mesh", STRING), f"{where}.mesh")
            if path.suffix.lower() in GLTF_SUFFIXES:
                warnings.warn(f"{where}.mesh {short(path.name)} merges the glTF's nodes into one mesh with this "
                              f"entry's one material; write gltf = {path.name!r} to keep its objects, materials "
                              "and lights", stacklevel=2)
            key = path.resolve()  # one Mesh per file, however it is named; messages name it as written
            if key not in meshes:
                meshes[key] = load_mesh(path)
            mesh = meshes[key]
        transform = Transform(
            position=table.get("position" if "position" in table else "center", VEC3, np.zeros(3)),
            rotation=table.get("rotation", VEC3, np.zeros(3)),
            scale=table.get("scale", _numbers(3), np.ones(3)),
        )
    material = _material(data.get("material"), f"{where}.material", base_dir)
    textured = [key for key in TEXTURE_KEYS if key in vars(material) and getattr(material, key) is not None]
    if textured and mesh.uvs is None:
        raise SceneError(f"{where}.material.{textured[0]} needs texture coordinates, which "
                         f"{short(shape or data['mesh'])} has none; texture a plane or a box, or a mesh file with uvs")
    name = table.get("name", STRING, shape or Path(data.get("mesh", "mesh")).stem)
    return SceneObject(name, mesh, material, transform)


def _shape(shape: str, params: dict, where: str) -> Mesh:
    """The shape's mesh; its parameter errors read ``objects[i].radius must ...``."""
    try:
        return SHAPES[shape](**params)
    except ValueError as exc:
        raise SceneError(rules.joined(where, str(exc), _shape_keys(shape))) from None
