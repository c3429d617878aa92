"""The scene: camera, objects (mesh + transform + material), lights, environment."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .camera import Camera
from .environment import Environment, procedural_environment
from .lights import Light
from .materials import Material
from .mesh import Mesh
from .transform import Transform


@dataclass
class SceneObject:
    name: str
    mesh: Mesh
    material: Material
    transform: Transform = field(default_factory=Transform)
    _world: Mesh | None = field(default=None, repr=False, compare=False)

    def world_from_object(self) -> np.ndarray:
        return self.transform.world_from_object()

    def world_mesh(self) -> Mesh:
        """The mesh in world space (cached; reset by :meth:`moved`)."""
        if self._world is None:
            self._world = self.mesh.transformed(self.world_from_object())
        return self._world

    def moved(self, transform: Transform) -> "SceneObject":
        return SceneObject(self.name, self.mesh, self.material, transform)


@dataclass
class Scene:
    camera: Camera = field(default_factory=Camera)
    objects: list[SceneObject] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    environment: Environment = field(default_factory=lambda: procedural_environment("sky-checker"))
    intensity_scale: float = 1.0
    name: str = "scene"

    def objects_of(self, kind: str) -> list[SceneObject]:
        """Objects whose material kind is ``kind`` ('diffuse', 'mirror', 'glass')."""
        return [o for o in self.objects if o.material.kind == kind]

    def bounds(self) -> np.ndarray:
        """(2,3) world bounding box of every object."""
        if not self.objects:
            return np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
        boxes = np.stack([o.world_mesh().bounds for o in self.objects])
        return np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])
