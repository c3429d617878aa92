"""Scenes of Hu and Qin's impostor figures (TVCG 2007, fig. 14, 18, 24, 26-28) and a stack of two glass balls.

Meant for ``impostors`` and ``impostors+impostor-caustics``; the fig. 24 stages
are technique settings over one scene (``FIG24_STAGES``, used by bench/bench_impostors.py).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .camera import Camera
from .environment import Environment, procedural_environment, sky_checker
from .lights import PointLight
from .materials import Diffuse, Glass, Mirror, water
from .mesh import Mesh
from .scene import Scene, SceneObject
from .shapes import box, plane, ring, sphere, torus, water_heightfield
from .transform import Transform

SKY_SCALE = 0.25  # caustic scenes dim the sky so the focused light stands out


def _scene(name, position, look_at, objects, lights=(), fov_y=40.0, sky_scale=1.0) -> Scene:
    sky = Environment(sky_checker() * sky_scale, source=f"procedural:sky-checker*{sky_scale}") if sky_scale != 1.0 \
        else procedural_environment("sky-checker")
    return Scene(camera=Camera(position=list(position), look_at=list(look_at), fov_y=fov_y, size=(512, 512)),
                 objects=list(objects), lights=list(lights), environment=sky, name=name)


def _floor(size=8.0, color=(0.7, 0.7, 0.7)) -> SceneObject:
    return SceneObject("floor", plane((size, size)), Diffuse(color=list(color)))


def tvcg_fig14() -> Scene:
    """Fig. 14: a refractive sphere in front of objects it must reveal (parts hidden from the eye without it)."""
    return _scene("tvcg-fig14", [0.0, 1.0, 4.0], [0.0, 0.5, 0.0], [
        SceneObject("sphere", sphere(0.6, 5), Glass(ior=1.5), Transform(position=[0.0, 0.6, 0.9])),
        SceneObject("box", box((0.7, 0.7, 0.7)), Diffuse(color=[0.8, 0.3, 0.2]),
                    Transform(position=[-0.3, 0.35, -0.5], rotation=[0.0, 30.0, 0.0])),
        SceneObject("torus", torus(0.35, 0.12), Diffuse(color=[0.2, 0.6, 0.3]),
                    Transform(position=[0.55, 0.5, -0.9], rotation=[90.0, 0.0, 0.0])),
        _floor()], [PointLight(position=[1.5, 4.0, 2.0], intensity=[30.0, 30.0, 30.0])])


def tvcg_fig18() -> Scene:
    """Fig. 18: two IOR 1.0 refractors over rectangles; with correction they should be invisible."""
    return _scene("tvcg-fig18", [0.0, 1.2, 4.0], [0.0, 0.5, 0.0], [
        SceneObject("left", sphere(0.5, 5), Glass(ior=1.0), Transform(position=[-0.6, 0.6, 0.8])),
        SceneObject("right", sphere(0.5, 5), Glass(ior=1.0), Transform(position=[0.6, 0.6, 0.8])),
        SceneObject("box", box((1.6, 0.6, 0.4)), Diffuse(color=[0.8, 0.3, 0.2]), Transform(position=[0.0, 0.3, -0.6])),
        _floor()])


def tvcg_fig24() -> Scene:
    """Fig. 24: a glass sphere, a mirror ball beside it and a box on a floor under a point light."""
    return _scene("tvcg-fig24", [0.0, 2.0, 4.2], [0.0, 0.4, 0.0], [
        SceneObject("sphere", sphere(0.5, 5), Glass(ior=1.5), Transform(position=[-0.3, 0.9, 0.3])),
        SceneObject("mirror-ball", sphere(0.35, 5), Mirror(color=[0.9, 0.9, 0.9]), Transform(position=[0.8, 0.35, -0.2])),
        SceneObject("box", box((0.5, 0.5, 0.5)), Diffuse(color=[0.3, 0.4, 0.8]),
                    Transform(position=[-0.9, 0.25, -0.8], rotation=[0.0, 20.0, 0.0])),
        _floor()], [PointLight(position=[0.0, 3.8, 0.2], intensity=[20.0, 20.0, 20.0])], sky_scale=SKY_SCALE)


# Fig. 24 (a)-(g): each stage adds one feature (technique, parameters); ratios are to stage (a).
FIG24_STAGES = {
    "a": ("depth-search", {}),
    "b": ("impostors", {"impostor_iterations": 0, "reflections": False}),
    "c": ("impostors", {"reflections": False}),
    "d": ("impostors+impostor-caustics", {"reflections": False, "photon_buffer": 128}),
    "e": ("impostors+impostor-caustics", {"reflections": False, "photon_buffer": 256}),
    "f": ("impostors+impostor-caustics", {"photon_buffer": 256}),
    "g": ("impostors+impostor-caustics", {"photon_buffer": 256, "depth": 1}),
}


def tvcg_fig26() -> Scene:
    """Fig. 26: a ring that reflects (outer mirror ring) and refracts (inner glass ring) onto the floor."""
    return _scene("tvcg-fig26", [0.0, 2.6, 3.0], [0.0, 0.2, 0.0], [
        SceneObject("mirror-ring", ring(0.9, 0.95, 0.5, segments=192), Mirror(color=[0.95, 0.9, 0.8]),
                    Transform(position=[0.0, 0.25, 0.0])),
        SceneObject("glass-ring", torus(0.45, 0.12), Glass(ior=1.5), Transform(position=[0.0, 0.3, 0.0])),
        _floor()], [PointLight(position=[0.0, 3.5, -2.0], intensity=[40.0, 40.0, 40.0])], sky_scale=SKY_SCALE)


def tvcg_fig27() -> Scene:
    """Fig. 27: caustics on two objects (the floor and a box) under two lights."""
    return _scene("tvcg-fig27", [0.0, 2.2, 3.8], [0.0, 0.4, 0.0], [
        SceneObject("ball", sphere(0.45, 5), Glass(ior=1.5), Transform(position=[0.0, 1.0, 0.0])),
        SceneObject("box", box((0.6, 0.3, 0.6)), Diffuse(color=[0.8, 0.8, 0.7]), Transform(position=[0.5, 0.15, 0.4])),
        _floor()], [PointLight(position=[-1.0, 3.6, -0.8], intensity=[18.0, 14.0, 10.0]),
                    PointLight(position=[1.2, 3.6, -0.6], intensity=[10.0, 14.0, 18.0])], sky_scale=SKY_SCALE)


def tvcg_fig28(time: float = 0.0) -> Scene:
    """Fig. 28: underwater caustics through a rippling one-interface surface, the camera below the water."""
    surface = SceneObject("water", water_heightfield((4.0, 4.0), resolution=96, amplitude=0.06, waves=5, seed=2,
                                                     time=float(time)), water(), Transform(position=[0.0, 1.5, 0.0]))
    return _scene("tvcg-fig28", [0.0, 0.8, 1.8], [0.0, 0.3, -0.8], [
        surface,
        SceneObject("wall", plane((4.0, 1.5)), Diffuse(color=[0.6, 0.7, 0.75]),
                    Transform(position=[0.0, 0.75, -2.0], rotation=[90.0, 0.0, 0.0])),
        SceneObject("dolphin", sphere(0.3, 4), Diffuse(color=[0.5, 0.55, 0.6]),
                    Transform(position=[0.3, 0.5, -0.8], scale=[1.8, 0.8, 0.8])),
        _floor(4.0, (0.7, 0.75, 0.7))], [PointLight(position=[0.5, 5.0, -0.5], intensity=[60.0, 60.0, 60.0])],
        sky_scale=SKY_SCALE)


def morphing_blob(amount: float) -> Mesh:
    """A glass blob between a sphere (``amount`` 0) and a lumpy shape (1): radial displacement of one
    icosphere, so every frame has the same topology and nothing is precomputed."""
    base = sphere(0.5, 5)
    v = base.vertices.astype(np.float64)
    n = v / np.linalg.norm(v, axis=1, keepdims=True)
    lumps = 0.25 * np.sin(3.0 * n[:, 0] + 1.0) * np.sin(3.0 * n[:, 1]) * np.cos(2.0 * n[:, 2])
    r = 0.5 * (1.0 + float(amount) * lumps)[:, None]
    return Mesh(n * r, None, base.faces, name=f"blob-{amount:.3f}")


def tvcg_fig29(time: float = 0.0) -> Scene:
    """Fig. 29: a morphing glass mesh (its shape changes with ``time``) casting caustics: no preprocessing
    is needed, every frame works from the current mesh."""
    amount = 0.5 - 0.5 * np.cos(float(time) * np.pi)
    return _scene("tvcg-fig29", [0.0, 2.0, 3.6], [0.0, 0.4, 0.0], [
        SceneObject("blob", morphing_blob(amount), Glass(ior=1.5), Transform(position=[0.0, 1.1, 0.0])),
        _floor()], [PointLight(position=[0.0, 4.0, -0.3], intensity=[25.0, 25.0, 25.0])], sky_scale=SKY_SCALE)


def glass_stack() -> Scene:
    """A glass ball behind a glass ball (and both over a floor): the rear one must stay visible."""
    return _scene("impostors-glass-stack", [0.0, 0.8, 4.0], [0.0, 0.6, 0.0], [
        SceneObject("front", sphere(0.5, 5), Glass(ior=1.3), Transform(position=[0.0, 0.6, 0.8])),
        SceneObject("back", sphere(0.5, 5), Glass(ior=1.5, absorption_color=[0.3, 0.9, 0.3]),
                    Transform(position=[0.15, 0.6, -0.8])),
        _floor()], [PointLight(position=[1.0, 4.0, 2.0], intensity=[25.0, 25.0, 25.0])])


IMPOSTOR_PRESETS: dict[str, Callable[[], Scene]] = {
    "tvcg-fig14": tvcg_fig14,
    "tvcg-fig18": tvcg_fig18,
    "tvcg-fig24": tvcg_fig24,
    "tvcg-fig26": tvcg_fig26,
    "tvcg-fig27": tvcg_fig27,
    "tvcg-fig28": tvcg_fig28,
    "tvcg-fig29": tvcg_fig29,
    "impostors-glass-stack": glass_stack,
}
