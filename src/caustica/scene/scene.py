"""The scene: camera, objects (mesh + transform + material), lights, environment."""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..cache import kept_on
from ..errors import SceneError, closest_name, short
from . import rules
from .camera import Camera
from .environment import Environment, procedural_environment
from .lights import DirectionalLight, Light, LineLight, PointLight, SpotLight
from .materials import Diffuse, Glass, Material, Mirror, Principled
from .mesh import Mesh
from .transform import Transform


@dataclass
class SceneObject:
    """One object: a named mesh with its material, placed by ``transform`` (object to world)."""

    name: str
    mesh: Mesh
    material: Material
    transform: Transform = field(default_factory=Transform)
    _world: tuple | None = field(default=None, repr=False, compare=False)
    _translated: tuple | None = field(default=None, repr=False, compare=False)

    def world_from_object(self) -> np.ndarray:
        """The transform's 4x4 matrix."""
        return self.transform.world_from_object()

    def world_mesh(self) -> Mesh:
        """The mesh in world space, cached until the mesh, its arrays or the transform change."""
        matrix = self.world_from_object()
        mesh = self.mesh
        parts = (mesh, mesh.vertices, mesh.normals, mesh.faces)
        cached = self._world
        if cached is None or any(a is not b for a, b in zip(cached[0], parts)) or not np.array_equal(cached[1], matrix):
            cached = self._world = (parts, matrix, mesh.transformed(matrix))
        return cached[2]

    def validate(self, where: str = "object") -> None:
        """Check the mesh, material and transform (the loader's rules) and that the transformed mesh stays
        within +-rules.MAX_COORDINATE; errors name ``where.key``."""
        with rules.context(where, ("name", "mesh", "material", "transform")):
            if not isinstance(self.name, str):
                raise SceneError(f"name {_type_name(self.name)} must be a string")
            mesh = _part(self.mesh, (Mesh,), "mesh", "a caustica.scene.Mesh")
            rules.once_per_arrays(mesh, ("vertices", "normals", "faces"), mesh.validate)
        _validated(self.material, (Glass, Diffuse, Mirror, Principled), f"{where}.material",
                   "a Glass, Diffuse, Mirror or Principled")
        _validated(self.transform, (Transform,), f"{where}.transform", "a Transform")
        # The object's world box: the corners of its object-space box through world_from_object.
        corners = np.array(np.meshgrid(*self.mesh.bounds.T.astype(np.float64))).reshape(3, -1).T
        world = corners @ self.world_from_object()[:3, :3].T + self.transform.position
        reach = float(np.abs(world).max())
        if reach > rules.MAX_COORDINATE:
            raise SceneError(f"{where} reaches {reach:.3g} scene units from the origin once scaled and placed, beyond "
                             f"+-{rules.MAX_COORDINATE:g}; lower its scale or move it closer")

    def translated(self, offset) -> "SceneObject":
        """The object moved by ``offset``, sharing mesh and material; the same object again while neither
        the offset, the mesh nor the transform changes (the GPU and ray caches then keep what they hold)."""
        offset = np.asarray(offset, dtype=np.float64)
        t = self.transform
        parts = (self.mesh, self.material)
        values = (self.name, tuple(offset), tuple(t.position), tuple(t.rotation), tuple(t.scale))
        cached = self._translated
        if cached is None or any(a is not b for a, b in zip(cached[0], parts)) or cached[1] != values:
            moved = self.moved(dataclasses.replace(t, position=t.position + offset))
            cached = self._translated = (parts, values, moved)
        return cached[2]

    def moved(self, transform: Transform) -> "SceneObject":
        """The same mesh and material placed by ``transform``."""
        return SceneObject(self.name, self.mesh, self.material, transform)


@dataclass
class Scene:
    """Everything one frame renders: camera, objects, lights and environment (radiance scaled by
    ``intensity_scale``; ``gltf``: what a glTF file said that export writes back). Pure data; the
    ``with_camera``, ``orbited`` and ``replace_object`` methods return new scenes that share the untouched
    parts."""

    camera: Camera = field(default_factory=Camera)
    objects: list[SceneObject] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    environment: Environment = field(default_factory=lambda: procedural_environment("sky-checker"))
    intensity_scale: float = 1.0
    name: str = "scene"
    gltf: object | None = field(default=None, repr=False, compare=False)  # scene/gltf/origin.py: what export keeps

    def validate(self) -> "Scene":
        """Check every part with the TOML loader's rules (scene/rules.py and each part's ``validate``), for a
        scene edited after loading: SceneError, MeshError or EnvironmentImageError naming the part the way
        scene files do (``objects[0].material.ior ...``). Pure data, a few milliseconds for a 69K-triangle
        mesh. Returns the scene."""
        _validated(self.camera, (Camera,), "camera", "a caustica.scene.Camera")
        for name, items in (("objects", self.objects), ("lights", self.lights)):
            if not isinstance(items, (list, tuple)):
                raise SceneError(f"{name} {_type_name(items)} must be a list")
        for i, obj in enumerate(self.objects):
            _part(obj, (SceneObject,), f"objects[{i}]", "a SceneObject").validate(f"objects[{i}]")
        for i, light in enumerate(self.lights):
            _validated(light, (PointLight, DirectionalLight, SpotLight, LineLight), f"lights[{i}]",
                       "a PointLight, DirectionalLight, SpotLight or LineLight")
        _validated(self.environment, (Environment,), "environment", "a caustica.scene.Environment", arrays=("image",))
        self.intensity_scale = rules.intensity_scale(self.intensity_scale)
        if not isinstance(self.name, str):
            raise SceneError(f"name {_type_name(self.name)} must be a string")
        return self

    def with_camera(self, camera: Camera) -> Scene:
        """A new Scene seen through ``camera``, sharing every other part with this one (unchanged)."""
        return dataclasses.replace(self, camera=_part(camera, (Camera,), "camera", "a caustica.Camera"))

    def orbited(self, degrees: float, axis: str | Sequence[float] = "y") -> Scene:
        """A new Scene whose camera is turned ``degrees`` about ``axis`` through its look_at
        (:meth:`Camera.orbited`): one frame of a turntable."""
        return self.with_camera(self.camera.orbited(degrees, axis))

    def replace_object(self, name_or_index: str | int, new_object: SceneObject) -> Scene:
        """A new Scene with the (first) object named ``name_or_index``, or the one at that index, swapped for
        ``new_object``; the other objects and this scene are unchanged. SceneError for an unknown name or
        index, listing the scene's object names."""
        _part(new_object, (SceneObject,), "new_object", "a caustica.SceneObject")
        index = self._object_index(name_or_index)
        objects = list(self.objects)
        objects[index] = new_object
        return dataclasses.replace(self, objects=objects)

    def _object_index(self, name_or_index: str | int) -> int:
        """The list index of the object named (or numbered) ``name_or_index``; SceneError if none is."""
        names = [o.name for o in self.objects]
        more = f" and {len(names) - 20} more" if len(names) > 20 else ""
        listing = f"; give one of: {', '.join(map(repr, names[:20]))}{more}" if names else "; the scene has no objects"
        if isinstance(name_or_index, str):
            if name_or_index not in names:
                raise SceneError(f"scene {self.name!r} has no object {short(name_or_index)}"
                                 f"{closest_name(name_or_index, names)}{listing}")
            return names.index(name_or_index)
        if isinstance(name_or_index, (int, np.integer)) and not isinstance(name_or_index, bool):
            if not -len(names) <= name_or_index < len(names):
                raise SceneError(f"object index {name_or_index} is out of range for scene {self.name!r} "
                                 f"({len(names)} objects){listing}")
            return int(name_or_index) % len(names)
        raise SceneError(f"object {short(name_or_index)} must be an object's name (a string) or index (an integer)"
                         f"{listing}")

    def translated(self, offset) -> Scene:
        """A new Scene moved by ``offset`` (three numbers): objects, lights and camera alike, so every image
        is the same; meshes, materials and the environment (directions only) are shared."""
        offset = np.asarray(offset, dtype=np.float64)
        objects = [obj.translated(offset) for obj in self.objects]
        lights = [_light_moved(light, offset) for light in self.lights]
        return dataclasses.replace(self, objects=objects, lights=lights, camera=self.camera.translated(offset))

    def objects_of(self, kind: str) -> list[SceneObject]:
        """Objects whose material kind is ``kind`` ('diffuse', 'mirror', 'glass')."""
        return [o for o in self.objects if o.material.kind == kind]

    def bounds(self) -> np.ndarray:
        """(2,3) world bounding box of every object."""
        if not self.objects:
            return np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
        boxes = np.stack([o.world_mesh().bounds for o in self.objects])
        return np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])


FAR_FROM_ORIGIN = 10.0  # scene sizes: a scene whose centre lies farther from the origin is rendered moved to it


def recentred(scene: Scene) -> tuple[Scene, np.ndarray]:
    """(the scene, its shift): a scene whose objects' centre lies more than FAR_FROM_ORIGIN times their size
    from the origin (a glTF in geographic coordinates, a set placed at x = 1000) moved by a whole-unit
    shift that brings that centre near the origin, since the GPU and Embree hold coordinates as float32
    (at 350000 units a step is 0.03: shadow acne, broken refraction). Images do not change otherwise; a
    world position computed from the moved scene is the original one minus the shift. Others: (scene, 0)."""
    bounds = scene.bounds()
    center, size = bounds.mean(axis=0), float(np.linalg.norm(bounds[1] - bounds[0]))
    if not scene.objects or float(np.abs(center).max()) <= FAR_FROM_ORIGIN * max(size, 1e-30):
        return scene, np.zeros(3)
    shift = -np.round(center)
    return (scene.translated(shift), shift) if shift.any() else (scene, shift)


def invisible_objects(scene: Scene) -> list[SceneObject]:
    """The objects of glass that no light can see (:attr:`Glass.invisible`: IOR 1, no absorption)."""
    return [o for o in scene.objects if o.material.kind == "glass" and o.material.invisible]


def without_invisible_glass(scene: Scene) -> Scene:
    """``scene`` less its :func:`invisible_objects`, or ``scene`` itself where it has none: what a frame renders
    with ``drop_invisible_glass`` (auto plans it). Kept on the scene while its objects and their invisibility stay,
    so that what passes and rays cache on the scene holds across frames; camera, lights and environment are the
    scene's of the call."""
    hidden = {id(o) for o in invisible_objects(scene)}
    if not hidden:
        return scene
    key = tuple((id(o), id(o) in hidden) for o in scene.objects)
    kept = kept_on(scene, "_visible_cache", key,
                   lambda: dataclasses.replace(scene, objects=[o for o in scene.objects if id(o) not in hidden]))
    for name in ("camera", "lights", "environment", "intensity_scale", "name"):
        setattr(kept, name, getattr(scene, name))
    return kept


def _light_moved(light, offset: np.ndarray):
    if isinstance(light, LineLight):
        return dataclasses.replace(light, start=light.start + offset, end=light.end + offset)
    if isinstance(light, (PointLight, SpotLight)):
        return dataclasses.replace(light, position=light.position + offset)
    return light  # a direction only


def _type_name(value) -> str:
    return f"(a {type(value).__name__})"


def _part(value, kinds: tuple, where: str, what: str):
    """``value`` when it is one of ``kinds``, else SceneError naming ``where``."""
    if not isinstance(value, kinds):
        raise SceneError(f"{where} {_type_name(value)} must be {what}")
    return value


def _validated(value, kinds: tuple, where: str, what: str, arrays: tuple[str, ...] = ()) -> None:
    """Type-check ``value`` and run its own validate, errors naming ``where`` (``where.field ...``); with
    ``arrays``, only when those array fields are new objects (rules.once_per_arrays)."""
    _part(value, kinds, where, what)
    with rules.context(where, [f.name for f in dataclasses.fields(value)]):
        if arrays:
            rules.once_per_arrays(value, arrays, value.validate)
        else:
            value.validate()


def check_scene(scene) -> Scene:
    """``scene`` validated (Renderer.render_timed calls this first); SceneError when it is no Scene."""
    return _part(scene, (Scene,), "the scene", "a caustica.scene.Scene (see caustica.load_scene)").validate()
