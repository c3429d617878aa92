"""Built-in scenes, loadable by name wherever a scene file is accepted."""
from __future__ import annotations

from collections.abc import Callable

from .camera import Camera
from .environment import procedural_environment
from .lights import PointLight
from .materials import Diffuse, Glass
from .scene import Scene, SceneObject
from .shapes import plane, sphere
from .transform import Transform


def glass_sphere() -> Scene:
    """A unit glass sphere (IOR 1.5) in front of the sky-checker environment; no lights."""
    return Scene(
        camera=Camera(position=[0.0, 0.0, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=(512, 512)),
        objects=[SceneObject("sphere", sphere(1.0, subdivisions=5), Glass(ior=1.5))],
        environment=procedural_environment("sky-checker"),
        name="glass-sphere",
    )


def caustic_sphere() -> Scene:
    """A glass ball lens focusing a point light into a bright spot on a diffuse floor.

    The ball (radius 0.6, IOR 1.5) has focal length f = n R / (2 (n - 1)) = 0.9
    from its centre. With the light 2.8 above the centre, paraxial rays would
    focus f d / (d - f) = 1.33 below it; the ball's strong spherical aberration pulls the
    narrowest part of the focused beam closer, so the floor 1.2 below the
    centre catches the tightest spot (traced: half the flux within 0.01).
    """
    ball = SceneObject("ball", sphere(0.6, subdivisions=5), Glass(ior=1.5), Transform(position=[0.0, 1.2, 0.0]))
    floor = SceneObject("floor", plane((12.0, 12.0)), Diffuse(color=[0.5, 0.5, 0.5]))
    return Scene(
        camera=Camera(position=[0.0, 2.2, 4.2], look_at=[0.0, 0.5, 0.0], fov_y=40.0, size=(512, 512)),
        objects=[ball, floor],
        lights=[PointLight(position=[0.0, 4.0, 0.0], intensity=[20.0, 20.0, 20.0])],
        environment=procedural_environment("sky-checker"),
        name="caustic-sphere",
    )


PRESETS: dict[str, Callable[[], Scene]] = {
    "glass-sphere": glass_sphere,
    "caustic-sphere": caustic_sphere,
}


def preset_names() -> list[str]:
    """Names of the built-in scenes, sorted."""
    return sorted(PRESETS)
