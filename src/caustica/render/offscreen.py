"""Rendering part of a scene from a virtual camera into textures (reflection maps, impostor textures).

Shared by per-vertex reflection maps and impostor textures: a camera-like
object, a sub-frame that shares the parent's light samples and shadow maps,
and cached sub-scenes.
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ..cache import LruCache
from ..scene.scene import Scene
from ..scene.transform import look_at_view_from_world, perspective_clip_from_view
from .frame import Frame
from .graph import run_passes

_SUBSCENES = LruCache(64)  # sub-scenes by their objects, lights and environment


@dataclass
class OffscreenCamera:
    """What the passes read of a Camera: position, size, up, view and clip matrices."""

    position: np.ndarray
    size: tuple[int, int]
    up: np.ndarray
    _view: np.ndarray
    _clip: np.ndarray

    def view_from_world(self) -> np.ndarray:
        return self._view

    def clip_from_world(self) -> np.ndarray:
        return self._clip

    @property
    def forward(self) -> np.ndarray:
        return -self._view[2, :3]

    def pixel_angle(self) -> float:
        """Radians one pixel subtends at the image centre (Camera.pixel_angle): the projection's
        [1, 1] is 1 / tan(fov_y / 2)."""
        projection = self._clip @ np.linalg.inv(self._view)
        return float(2.0 / (projection[1, 1] * self.size[1]))


def aimed_camera(position, target, up, half_width: float, half_height: float, near: float, far: float,
                 size: tuple[int, int]) -> OffscreenCamera:
    """A pinhole at ``position`` looking at ``target`` whose image plane through ``target`` spans
    [-half_width, half_width] x [-half_height, half_height] (scene units)."""
    position, target = np.asarray(position, np.float64), np.asarray(target, np.float64)
    view = look_at_view_from_world(position, target, up)
    distance = float(np.linalg.norm(target - position))
    fov_y = 2.0 * np.degrees(np.arctan(half_height / distance))
    clip = perspective_clip_from_view(fov_y, half_width / half_height, near, far) @ view
    return OffscreenCamera(position, (int(size[0]), int(size[1])), view[1, :3].copy(), view, clip)


def scene_subset(scene: Scene, keep) -> Scene:
    """``scene`` with only the objects whose indices are in ``keep`` (cached, so that GPU meshes
    and Embree scenes keyed on it are built once)."""
    keep = sorted(set(int(i) for i in keep))
    objects = [scene.objects[i] for i in keep]
    key = (tuple(id(o) for o in objects), tuple(id(light) for light in scene.lights), id(scene.environment),
           scene.intensity_scale)
    sub = _SUBSCENES.get(key)
    if sub is None:
        sub = Scene(camera=scene.camera, objects=objects, lights=scene.lights, environment=scene.environment,
                    intensity_scale=scene.intensity_scale, name=f"{scene.name}-subset")
        _SUBSCENES[key] = sub
    return sub


def render_offscreen(frame: Frame, scene: Scene, camera, passes, keep=("color",), share=(), params=None) -> dict:
    """Run ``passes`` on a sub-frame of ``frame`` (``scene`` seen by ``camera``) and return its ``keep``
    channels, now lent to ``frame``; the sub-frame gives back everything else.

    The sub-frame starts with the parent's ``light_samples`` and ``shadow_maps`` and the ``share``d channels.
    """
    inherited = {name: frame.read(name) for name in ("light_samples", "shadow_maps", *share) if name in frame.channels}
    sub = frame.sub_frame(scene, camera, inherited, params)
    try:
        run_passes(passes, sub, keep=keep)
        kept = {name: sub.read(name) for name in keep}
        for obj in sub.take_out(kept):
            frame.own(obj)
    finally:
        sub.give_back()
    return kept


@contextmanager
def offscreen_channels(frame: Frame, scene: Scene, camera, passes, keep=("color",), share=(), params=None):
    """:func:`render_offscreen` for a ``with`` block: the kept channels are given back at its end."""
    kept = render_offscreen(frame, scene, camera, passes, keep, share, params)
    try:
        yield kept
    finally:
        frame.give_back(kept)
