"""Presets of the light transport table (Iwasaki et al., section 7, figs. 8-11): ``transport-*``.

Each is a glass object over a floor, dimmed sky, 512x512, and renders with any
technique; ``transport-table`` precomputes (and caches) its table on first use.
The teapot and the bunny read ``../shared/data`` (or $CAUSTICA_DATA).
"""
from __future__ import annotations

from collections.abc import Callable

from .lights import DirectionalLight, LineLight, PointLight, SpotLight
from .materials import Glass
from .preset_parts import caustic_scene as _caustic_scene
from .preset_parts import floor_object as _floor
from .preset_parts import glass_model as _glass_model
from .scene import Scene, SceneObject
from .shapes import sphere, torus, torus_knot
from .transform import Transform

_CAMERA = {"position": [0.0, 2.8, 3.6], "look_at": [0.0, 0.3, 0.0], "fov_y": 40.0}
_LIGHT = [0.8, 3.6, -1.2]


def _placed(obj: SceneObject) -> list[SceneObject]:
    """The object and a floor just under it."""
    low = obj.world_mesh().bounds[0]
    return [obj, _floor(height=float(low[1]) - 1e-3)]


def _ball() -> SceneObject:
    return SceneObject("ball", sphere(0.5, subdivisions=5), Glass(ior=1.5), Transform(position=[0.0, 0.8, 0.0]))


def _torus() -> SceneObject:
    return SceneObject("torus", torus(0.6, 0.22, segments=96, sides=48), Glass(ior=1.5),
                       Transform(position=[0.0, 0.9, 0.0], rotation=[60.0, 0.0, 20.0]))


def _knot() -> SceneObject:
    return SceneObject("knot", torus_knot(2, 3, 0.7, 0.18, segments=384, sides=32), Glass(ior=1.5),
                       Transform(position=[0.0, 1.0, 0.0], rotation=[70.0, 0.0, 0.0]))


def transport_ball() -> Scene:
    """Fig. 8 (a): a glass ball (R 0.5, IOR 1.5) over a floor under a parallel light."""
    light = DirectionalLight(direction=[-0.25, -1.0, 0.35], intensity=[2.5, 2.5, 2.5])
    return _caustic_scene("transport-ball", objects=_placed(_ball()), lights=[light], **_CAMERA)


def transport_torus() -> Scene:
    """Fig. 8 (b): a tilted glass torus (IOR 1.5) over a floor under a point light."""
    return _caustic_scene("transport-torus", objects=_placed(_torus()),
                          lights=[PointLight(position=_LIGHT, intensity=[30.0] * 3)], **_CAMERA)


def transport_knot() -> Scene:
    """Fig. 9 (a): a glass (2, 3) torus knot (IOR 1.5) under a point light."""
    return _caustic_scene("transport-knot", objects=_placed(_knot()),
                          lights=[PointLight(position=_LIGHT, intensity=[30.0] * 3)], **_CAMERA)


def transport_teapot() -> Scene:
    """Fig. 9 (b): a glass teapot (IOR 1.5) under a point light. Needs ``models/teapot.obj`` (shared data)."""
    teapot = _glass_model("teapot.obj", "transport-teapot", 1.6, 1.5)
    teapot.transform.position = teapot.transform.position + [0.0, 0.9, 0.0]
    return _caustic_scene("transport-teapot", objects=_placed(teapot),
                          lights=[PointLight(position=_LIGHT, intensity=[30.0] * 3)], **_CAMERA)


def transport_spot() -> Scene:
    """Fig. 10 (a): the glass ball under a spot light (inner 14, outer 20 degrees)."""
    light = SpotLight(position=[0.6, 3.4, -0.8], direction=[-0.6, -2.6, 0.8], intensity=[40.0] * 3,
                      inner_angle=14.0, outer_angle=20.0)
    return _caustic_scene("transport-spot", objects=_placed(_ball()), lights=[light], **_CAMERA)


def transport_three_points() -> Scene:
    """Fig. 10 (b): the glass torus under three coloured point lights."""
    lights = [PointLight(position=[-1.4, 3.4, -1.0], intensity=[24.0, 8.0, 8.0]),
              PointLight(position=[1.4, 3.4, -1.0], intensity=[8.0, 24.0, 8.0]),
              PointLight(position=[0.0, 3.4, 1.4], intensity=[8.0, 8.0, 24.0])]
    return _caustic_scene("transport-three-points", objects=_placed(_torus()), lights=lights, **_CAMERA)


def transport_line() -> Scene:
    """Fig. 10 (c): the glass knot under a linear light approximated by 8 point lights (blurred caustics)."""
    light = LineLight(start=[-0.8, 3.5, -1.0], end=[0.8, 3.5, -1.0], intensity=[4.0] * 3, samples=8)
    return _caustic_scene("transport-line", objects=_placed(_knot()), lights=[light], **_CAMERA)


def transport_bunny() -> Scene:
    """Fig. 11 (b): a coloured-glass bunny (IOR 1.5, green Beer-Lambert absorption) under a point light.

    Needs ``models/stanford-bunny.obj`` (shared data).
    """
    bunny = _glass_model("stanford-bunny.obj", "transport-bunny", 1.4, 1.5)
    bunny.material = Glass(ior=1.5, absorption_color=[0.45, 0.85, 0.55], absorption_distance=0.4)
    bunny.transform.position = bunny.transform.position + [0.0, 0.7, 0.0]
    return _caustic_scene("transport-bunny", objects=_placed(bunny),
                          lights=[PointLight(position=_LIGHT, intensity=[30.0] * 3)], **_CAMERA)


TRANSPORT_PRESETS: dict[str, Callable[[], Scene]] = {
    "transport-ball": transport_ball,
    "transport-torus": transport_torus,
    "transport-knot": transport_knot,
    "transport-teapot": transport_teapot,
    "transport-spot": transport_spot,
    "transport-three-points": transport_three_points,
    "transport-line": transport_line,
    "transport-bunny": transport_bunny,
}
