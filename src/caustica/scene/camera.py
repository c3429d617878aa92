"""Pinhole camera, OpenGL convention: -Z forward, +Y up, vertical field of view."""
from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, short
from . import rules
from .transform import look_at_view_from_world, perspective_clip_from_view, rotation_about_axis


def fov_y_from_fov_x(fov_x_degrees: float, width: int, height: int) -> float:
    """Vertical field of view for a horizontal one at the given image size."""
    half = math.radians(fov_x_degrees) / 2.0
    return math.degrees(2.0 * math.atan(math.tan(half) * height / width))


def fov_x_from_fov_y(fov_y_degrees: float, width: int, height: int) -> float:
    """Horizontal field of view for a vertical one at the given image size."""
    return fov_y_from_fov_x(fov_y_degrees, height, width)


@dataclass
class Camera:
    """Where the eye is and what it sees. ``size`` is (width, height) in pixels."""

    position: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 4.0]))
    look_at: np.ndarray = field(default_factory=lambda: np.zeros(3))
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    fov_y: float = 40.0
    near: float = 0.05
    far: float = 100.0
    size: tuple[int, int] = (512, 512)

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.position = rules.vector(self.position, "position")
        self.look_at = rules.vector(self.look_at, "look_at")
        self.up = rules.vector(self.up, "up")
        unit_up = rules.direction(self.up, "up")
        self.size = rules.image_size(self.size, "size")
        if not (rules.finite(self.fov_y) and 0.0 < self.fov_y < 180.0):
            raise SceneError(f"field of view {short(self.fov_y)} must lie strictly between 0 and 180 degrees")
        self.fov_y = float(self.fov_y)
        self.near = rules.number(self.near, "near", rules.MIN_LENGTH, rules.MAX_COORDINATE, hint=" scene units")
        self.far = rules.number(self.far, "far", rules.MIN_LENGTH, 10 * rules.MAX_COORDINATE, hint=" scene units")
        if not self.near < self.far <= rules.MAX_DEPTH_RATIO * self.near:
            raise SceneError(f"near {self.near:g} and far {self.far:g} must satisfy 0 < near < far <= "
                             f"{rules.MAX_DEPTH_RATIO:g} * near (depth precision); raise near or lower far")
        forward = self.look_at - self.position
        if np.linalg.norm(forward) < 1e-9 * max(1.0, float(np.abs(self.position).max())):
            raise SceneError("camera position and look_at coincide; move one of them")
        if np.linalg.norm(np.cross(forward / np.linalg.norm(forward), unit_up)) < 1e-9:
            raise SceneError("camera up is parallel to the view direction; choose another up vector")

    @property
    def aspect(self) -> float:
        """Width over height."""
        return self.size[0] / self.size[1]

    @property
    def fov_x(self) -> float:
        """The horizontal field of view in degrees, at this size."""
        return fov_x_from_fov_y(self.fov_y, *self.size)

    def pixel_angle(self) -> float:
        """Radians one pixel subtends at the image centre, at this size."""
        return float(2.0 * np.tan(np.radians(self.fov_y) / 2.0) / self.size[1])

    def with_size(self, width: int, height: int) -> "Camera":
        """The same camera at another resolution (vertical field of view kept). Only the size is checked
        anew (the other fields are this camera's, checked already); the copy is kept for the next frame
        while this camera's fields stay the same."""
        size = rules.image_size((width, height), "size")
        if size == self.size:
            return self
        state = self._state()
        kept = self.__dict__.get("_resized")
        if kept is None or kept[0] != (state, size):
            resized = copy.copy(self)
            resized.__dict__.pop("_resized", None)
            resized.__dict__.pop("_cached_matrices", None)
            resized.size = size
            kept = self.__dict__["_resized"] = ((state, size), resized)
        return kept[1]

    def orbited(self, degrees: float, axis: str | Sequence[float] = "y",
                center: Sequence[float] | None = None) -> Camera:
        """A new camera turned ``degrees`` about ``axis`` ('x', 'y', 'z' or a vector) through ``center``
        (default: look_at), right-handed: counter-clockwise seen from the axis' tip, so +Y turns the camera
        counter-clockwise seen from above. Position, look_at and up turn together; this camera is unchanged."""
        turn = rotation_about_axis(axis, degrees)
        pivot = self.look_at if center is None else rules.vector(center, "center")
        return dataclasses.replace(self, position=pivot + turn @ (self.position - pivot),
                                   look_at=pivot + turn @ (self.look_at - pivot), up=turn @ self.up)

    def translated(self, offset: Sequence[float]) -> Camera:
        """A new camera moved by ``offset``: position and look_at together; this camera is unchanged."""
        offset = np.asarray(offset, dtype=np.float64)
        return dataclasses.replace(self, position=self.position + offset, look_at=self.look_at + offset)

    def _state(self) -> tuple:
        """The fields as a comparable key."""
        return (np.asarray(self.position).tobytes(), np.asarray(self.look_at).tobytes(), np.asarray(self.up).tobytes(),
                self.fov_y, self.near, self.far, self.size)

    def view_from_world(self) -> np.ndarray:
        """The 4x4 OpenGL view matrix (read-only)."""
        return self._matrices()[0]

    def clip_from_view(self) -> np.ndarray:
        """The 4x4 OpenGL perspective projection (read-only)."""
        return self._matrices()[1]

    def clip_from_world(self) -> np.ndarray:
        """Projection times view (read-only)."""
        return self._matrices()[2]

    def _matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(view_from_world, clip_from_view, clip_from_world), read-only, recomputed only when a field
        changed: the passes of one frame ask for them dozens of times."""
        key = self._state()
        cached = self.__dict__.get("_cached_matrices")
        if cached is None or cached[0] != key:
            view = look_at_view_from_world(self.position, self.look_at, self.up)
            clip = perspective_clip_from_view(self.fov_y, self.aspect, self.near, self.far)
            matrices = (view, clip, clip @ view)
            for m in matrices:
                m.flags.writeable = False
            cached = self.__dict__["_cached_matrices"] = (key, matrices)
        return cached[1]

    def primary_rays(self, spp: int = 1, rows: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """World-space ray origins and unit directions, (H, W, spp, 3) each, row 0 at the top.

        Samples lie on a stratified sqrt(spp) grid inside each pixel (a box filter);
        spp = 1 shoots through pixel centres. ``rows`` (first, stop) gives only those image rows.
        """
        width, height = self.size
        first, stop = (0, height) if rows is None else rows
        grid = max(1, int(round(math.sqrt(spp))))
        offsets = (np.arange(grid) + 0.5) / grid
        oy, ox = np.meshgrid(offsets, offsets, indexing="ij")
        ox, oy = ox.reshape(-1), oy.reshape(-1)
        px = np.arange(width)[None, :, None] + ox[None, None, :]
        py = np.arange(first, stop)[:, None, None] + oy[None, None, :]
        tan_half = math.tan(math.radians(self.fov_y) / 2.0)
        x_view = (2.0 * px / width - 1.0) * tan_half * self.aspect
        y_view = (1.0 - 2.0 * py / height) * tan_half
        x_view, y_view = np.broadcast_arrays(x_view, y_view)
        d_view = np.stack([x_view, y_view, -np.ones_like(x_view)], axis=-1)
        world_from_view = np.linalg.inv(self.view_from_world())
        d = d_view @ world_from_view[:3, :3].T
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        o = np.broadcast_to(self.position, d.shape)
        return np.ascontiguousarray(o), d
