"""A frame's sweep values applied to a scene: a new Scene that shares every untouched part (meshes,
unedited objects, the environment) with the one it starts from, which is never changed.

Camera keys apply in this order: ``position`` (or ``path``), ``look_at``, ``distance`` (from
look_at), ``elevation`` (degrees above the horizontal plane through look_at), then a turn about +Y
through look_at by ``azimuth`` + ``orbit`` degrees (right-handed: counter-clockwise seen from above;
``up`` turns with it), and ``fov_y``. docs/batch.md has the rest.
"""
from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from ..errors import SceneError, closest_name, first_line, short
from ..scene.scene import Scene, SceneObject

_MATERIAL_FIELDS = ("ior", "absorption_color", "absorption_distance", "color")
_POSE = ("position", "rotation", "scale")


class SceneEditor:
    """Applies frames' values to ``scene``; keeps what it loads (materials, environment images) for the
    frames after. ``base_dir``: where a sweep's file names (materials' textures, images) are found."""

    def __init__(self, scene: Scene, base_dir: str | Path = "."):
        self.scene, self.base_dir = scene, Path(base_dir)
        self._loaded: dict = {}

    def check(self, variation) -> None:
        """SceneError naming ``variation.key`` unless each of its extreme values makes a valid scene."""
        parts = variation.key.split(".")
        if parts[0] in ("objects", "lights"):
            self._target(parts)
        for value in variation.extremes():
            try:
                self.apply({variation.key: value}).validate()
            except SceneError as exc:
                raise SceneError(f"sweep {variation.key} = {short(value)}: {first_line(exc)}") from None

    def apply(self, values: dict) -> Scene:
        """The scene with ``values`` ({'objects.ball.ior': 1.4, ...}) in place."""
        groups: dict[tuple, dict] = {}
        for key, value in values.items():
            *where, name = key.split(".")
            groups.setdefault(tuple(where), {})[name] = value
        scene = self.scene
        edited = dataclasses.replace(scene)
        if ("camera",) in groups:
            edited.camera = _camera(scene.camera, groups[("camera",)])
        if ("environment",) in groups:
            edited.environment = self._environment(groups[("environment",)])
        edited.objects = [self._object(o, groups[("objects", o.name)]) if ("objects", o.name) in groups else o
                          for o in scene.objects]
        edited.lights = [_replace(light, groups[("lights", str(i))], f"lights.{i}") if ("lights", str(i)) in groups
                         else light for i, light in enumerate(scene.lights)]
        return edited

    def _target(self, parts: list[str]) -> None:
        """SceneError unless ``objects.NAME`` / ``lights.N`` is in the scene."""
        kind, name = parts[0], parts[1]
        names = [o.name for o in self.scene.objects] if kind == "objects" else [str(i) for i in range(len(self.scene.lights))]
        if name not in names:
            what = "object" if kind == "objects" else "light index"
            raise SceneError(f"sweep {kind}.{name}: no {what} {short(name)} in scene {self.scene.name!r}"
                             f"{closest_name(name, names)}; {kind}: {', '.join(names) or 'none'}")

    def _object(self, obj: SceneObject, values: dict) -> SceneObject:
        where = f"objects.{obj.name}"
        material = obj.material
        if "material" in values:
            material = self._material(values["material"], f"{where}.material")
        fields = {k: values[k] for k in _MATERIAL_FIELDS if k in values}
        if fields:
            material = _replace(material, fields, where, f"a {material.kind} material")
        transform = obj.transform
        pose = {k: values[k] for k in _POSE if k in values}
        if pose:
            transform = _replace(transform, pose, where)
        return SceneObject(obj.name, obj.mesh, material, transform)

    def _material(self, table: dict, where: str):
        from ..scene.io import _material

        key = ("material", json.dumps(table, sort_keys=True))
        if key not in self._loaded:
            self._loaded[key] = _material(table, where, self.base_dir)
        return self._loaded[key]

    def _environment(self, values: dict):
        env = self.scene.environment
        if "image" in values:
            key = ("environment", values["image"])
            if key not in self._loaded:
                self._loaded[key] = _environment_image(values["image"], self.base_dir)
            env = self._loaded[key]
        if values.get("rotation", 0.0) != 0.0:
            env = env.rotated(values["rotation"])
        if values.get("strength", 1.0) != 1.0:
            env = env.scaled(values["strength"])
        return env


def _environment_image(spec: str, base_dir: Path):
    """A procedural environment by name, else an image file relative to the sweep."""
    from ..scene.environment import PROCEDURAL_ENVIRONMENTS, environment_option

    if spec in PROCEDURAL_ENVIRONMENTS:
        return environment_option(spec)
    return environment_option(str(base_dir / spec), relative_to="the sweep file's folder")


def _replace(part, fields: dict, where: str, what: str | None = None):
    """``dataclasses.replace(part, **fields)``, checked by the part's own rules; SceneError naming
    ``where`` for a field the part does not have."""
    names = [f.name for f in dataclasses.fields(part) if f.init and not f.name.startswith("_")]
    for key in fields:
        if key not in names:
            raise SceneError(f"{where}.{key}: {what or 'a ' + type(part).__name__} has no {key}; "
                             f"its keys: {', '.join(names)}")
    return dataclasses.replace(part, **{k: np.asarray(v, dtype=np.float64) if isinstance(v, list) else v
                                        for k, v in fields.items()})


def _camera(camera, values: dict):
    position = np.asarray(values.get("path", values.get("position", camera.position)), dtype=np.float64)
    look_at = np.asarray(values.get("look_at", camera.look_at), dtype=np.float64)
    offset = position - look_at
    radius = float(np.linalg.norm(offset))
    if "distance" in values:
        if radius == 0.0:
            raise SceneError("camera.distance: the camera sits on look_at; give a position apart from it")
        offset, radius = offset / radius * values["distance"], float(values["distance"])
    if "elevation" in values:
        if not -90.0 < values["elevation"] < 90.0:
            raise SceneError(f"camera.elevation {values['elevation']:g} must lie strictly between -90 and 90 degrees")
        azimuth = math.atan2(offset[0], offset[2])
        e = math.radians(values["elevation"])
        offset = radius * np.array([math.cos(e) * math.sin(azimuth), math.sin(e), math.cos(e) * math.cos(azimuth)])
    placed = dataclasses.replace(camera, position=look_at + offset, look_at=look_at,
                                 fov_y=values.get("fov_y", camera.fov_y))
    return placed.orbited(values.get("azimuth", 0.0) + values.get("orbit", 0.0))
