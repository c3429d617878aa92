"""Built-in scenes, loadable by name wherever a scene file is accepted."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import SceneError

from .camera import Camera
from .environment import procedural_environment
from .lights import PointLight
from .materials import Diffuse, Glass
from .mesh import Mesh, load_mesh
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


def _sky_checker_scene(name: str, position, look_at, fov_y: float, objects, lights=()) -> Scene:
    """A 512x512 scene in the sky-checker environment (the TVCG presets and the glass models)."""
    return Scene(
        camera=Camera(position=position, look_at=look_at, fov_y=fov_y, size=(512, 512)),
        objects=list(objects), lights=list(lights), environment=procedural_environment("sky-checker"), name=name,
    )


def tvcg_fig10() -> Scene:
    """Hu and Qin's fig. 10: a unit sphere of IOR 0.8 (an air bubble in a denser medium).

    With n_t < n_i the view ray bends away from the normal, so many rays leave
    through a front-facing surface, and grazing rays are totally reflected at
    the entry. The sphere fills most of the frame, as in the paper's figure.
    """
    bubble = SceneObject("bubble", sphere(1.0, subdivisions=5), Glass(ior=0.8))
    return _sky_checker_scene("tvcg-fig10", [0.0, 0.0, 3.2], [0.0, 0.0, 0.0], 45.0, [bubble])


def tvcg_fig11() -> Scene:
    """Hu and Qin's fig. 11: refractive spheres of IOR 1.75 above a nearby diffuse plane.

    Three spheres (radius 0.5) stand in a row above a lit floor, as in the
    figure that compares Wyman's method, depth search and ray tracing; the
    spheres' edges show where the methods differ. Techniques that refract only
    the environment (env-map, image-space, depth-search) see the sky through
    the spheres where a ray tracer also sees the floor.
    """
    spheres = [SceneObject(f"sphere-{i}", sphere(0.5, subdivisions=5), Glass(ior=1.75),
                           Transform(position=[x, 0.5, 0.0])) for i, x in enumerate((-1.2, 0.0, 1.2))]
    floor = SceneObject("floor", plane((8.0, 8.0)), Diffuse(color=[0.6, 0.6, 0.6]))
    light = PointLight(position=[1.0, 4.0, 2.0], intensity=[15.0, 15.0, 15.0])
    return _sky_checker_scene("tvcg-fig11", [0.0, 1.8, 4.8], [0.0, 0.4, 0.0], 40.0, spheres + [floor], [light])


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


def _glass_model(filename: str, preset: str, size: float, ior: float) -> SceneObject:
    """A shared model as glass, scaled so its largest side is ``size`` and centred at the origin."""
    mesh = _shared_model(filename, preset)
    low, high = mesh.bounds
    scale = size / float(np.max(high - low))
    return SceneObject(Path(filename).stem, mesh, Glass(ior=ior),
                       Transform(position=-scale * (low + high) / 2.0, scale=scale))


def glass_teapot() -> Scene:
    """A glass teapot (IOR 1.5), centred, about 2 units wide, in the sky-checker environment.

    Needs the shared data: ``models/teapot.obj`` under $CAUSTICA_DATA or ``../shared/data``.
    """
    teapot = _glass_model("teapot.obj", "glass-teapot", 2.2, 1.5)
    return _sky_checker_scene("glass-teapot", [0.0, 1.2, 4.0], [0.0, 0.0, 0.0], 40.0, [teapot])


def glass_bunny() -> Scene:
    """The Stanford bunny in glass (IOR 1.5), scaled to about unit size and centred.

    Needs the shared data: ``models/stanford-bunny.obj`` under $CAUSTICA_DATA or ``../shared/data``.
    """
    bunny = _glass_model("stanford-bunny.obj", "glass-bunny", 1.0, 1.5)
    return _sky_checker_scene("glass-bunny", [0.0, 0.4, 2.2], [0.0, 0.0, 0.0], 40.0, [bunny])


PRESETS: dict[str, Callable[[], Scene]] = {
    "glass-sphere": glass_sphere,
    "caustic-sphere": caustic_sphere,
    "tvcg-fig10": tvcg_fig10,
    "tvcg-fig11": tvcg_fig11,
    "glass-teapot": glass_teapot,
    "glass-bunny": glass_bunny,
}


def preset_names() -> list[str]:
    """Names of the built-in scenes, sorted."""
    return sorted(PRESETS)
