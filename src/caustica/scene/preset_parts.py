"""Parts the built-in presets share (scene/presets*.py): the shared data's models, the caustic scenes' dimmed
sky and their floor."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import SceneError
from .camera import Camera
from .environment import Environment, sky_checker
from .materials import Diffuse, Glass
from .mesh import Mesh
from .mesh_files import load_mesh
from .scene import Scene, SceneObject
from .shapes import plane
from .transform import Transform


def shared_data_dir() -> Path:
    """The shared data folder: $CAUSTICA_DATA, else ``../shared/data`` beside the repository."""
    import os

    import caustica

    env = os.environ.get("CAUSTICA_DATA")
    return Path(env) if env else Path(caustica.__file__).resolve().parents[3] / "shared" / "data"


def _shared_model(filename: str, preset: str) -> Mesh:
    """A mesh from the shared data's models/, or SceneError naming the missing file."""
    path = shared_data_dir() / "models" / filename
    if not path.is_file():
        raise SceneError(f"preset '{preset}' needs {path}, which is missing; set CAUSTICA_DATA to the shared data folder")
    return load_mesh(path)


def glass_model(filename: str, preset: str, size: float, ior: float) -> SceneObject:
    """A shared model as glass, scaled so its largest side is ``size`` and centred at the origin."""
    mesh = _shared_model(filename, preset)
    low, high = mesh.bounds
    scale = size / float(np.max(high - low))
    return SceneObject(Path(filename).stem, mesh, Glass(ior=ior),
                       Transform(position=-scale * (low + high) / 2.0, scale=scale))


CAUSTIC_SKY_SCALE = 0.2


def caustic_scene(name: str, position, look_at, fov_y: float, objects, lights) -> Scene:
    """A 512x512 scene under the sky-checker dimmed to CAUSTIC_SKY_SCALE."""
    sky = Environment(sky_checker() * CAUSTIC_SKY_SCALE, source=f"procedural:sky-checker*{CAUSTIC_SKY_SCALE}")
    return Scene(camera=Camera(position=position, look_at=look_at, fov_y=fov_y, size=(512, 512)),
                 objects=list(objects), lights=list(lights), environment=sky, name=name)


def floor_object(size=(10.0, 10.0), height: float = 0.0, color=(0.7, 0.7, 0.7)) -> SceneObject:
    return SceneObject("floor", plane(size), Diffuse(color=list(color)), Transform(position=[0.0, height, 0.0]))
