"""Scene model: pure data, no GL imports."""
from .camera import Camera, fov_x_from_fov_y, fov_y_from_fov_x
from .environment import Environment, direction_to_uv, load_environment, procedural_environment, uv_to_direction
from .lights import DirectionalLight, LineLight, PointLight, SpotLight
from .materials import Diffuse, Glass, Mirror, Principled, water
from .mesh import Mesh
from .mesh_files import load_mesh
from .scene import Scene, SceneObject
from .transform import Transform

__all__ = [
    "Camera", "fov_x_from_fov_y", "fov_y_from_fov_x",
    "Environment", "direction_to_uv", "uv_to_direction", "load_environment", "procedural_environment",
    "DirectionalLight", "LineLight", "PointLight", "SpotLight",
    "Diffuse", "Glass", "Mirror", "Principled", "water",
    "Mesh", "load_mesh", "Scene", "SceneObject", "Transform",
]
