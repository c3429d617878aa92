"""Rigid transforms and the matrices the renderer needs.

Matrix names say what they map (pbrt's xFromY): ``world_from_object``,
``view_from_world``, ``clip_from_view``. Column vectors: p_world = M @ p_object.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, short
from . import rules


def _vec3(value, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.shape != (3,):
        raise ValueError(f"{name} must be three numbers [x, y, z]")
    return arr


def rotation_from_euler_degrees(rotation) -> np.ndarray:
    """3x3 rotation: X first, then Y, then Z (R = Rz @ Ry @ Rx), angles in degrees."""
    rx, ry, rz = np.radians(_vec3(rotation, "rotation"))
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    mx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    my = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    mz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return mz @ my @ mx


AXES = {"x": 0, "y": 1, "z": 2}


def rotation_about_axis(axis: str | Sequence[float], degrees: float) -> np.ndarray:
    """3x3 right-handed rotation by ``degrees`` about ``axis``: 'x', 'y', 'z' (the same matrix as
    :func:`rotation_from_euler_degrees` with that one angle) or a non-zero vector (Rodrigues' formula);
    SceneError for another axis."""
    degrees = rules.number(degrees, "angle", -rules.MAX_ROTATION, rules.MAX_ROTATION, hint=" degrees")
    if isinstance(axis, str):
        if axis.lower() not in AXES:
            raise SceneError(f"axis {short(axis)} must be 'x', 'y', 'z' or three numbers [x, y, z]")
        angles = np.zeros(3)
        angles[AXES[axis.lower()]] = degrees
        return rotation_from_euler_degrees(angles)
    k = rules.direction(axis, "axis")
    a = np.radians(degrees)
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.cos(a) * np.eye(3) + np.sin(a) * cross + (1.0 - np.cos(a)) * np.outer(k, k)


@dataclass
class Transform:
    """Scale, then rotate (degrees, XYZ order), then translate to ``position``."""

    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.position = rules.vector(self.position, "position")
        self.rotation = rules.vector(self.rotation, "rotation", limit=rules.MAX_ROTATION)
        self.scale = rules.scale(self.scale)

    def world_from_object(self) -> np.ndarray:
        """The 4x4 matrix, kept until position, rotation or scale change (a copy is returned)."""
        state = (np.asarray(self.position, dtype=np.float64).tobytes(), np.asarray(self.rotation, dtype=np.float64).tobytes(),
                 np.asarray(self.scale, dtype=np.float64).tobytes())
        memo = self.__dict__.get("_matrix")
        if memo is None or memo[0] != state:
            m = np.eye(4)
            m[:3, :3] = rotation_from_euler_degrees(self.rotation) @ np.diag(self.scale)
            m[:3, 3] = self.position
            memo = self.__dict__["_matrix"] = (state, m)
        return memo[1].copy()


def normal_matrix(world_from_object) -> np.ndarray:
    """The 3x3 matrix that takes object-space normals to world space: the inverse transpose of the
    linear part of ``world_from_object`` (normals stay perpendicular to surfaces under any scale)."""
    return np.linalg.inv(np.asarray(world_from_object, dtype=np.float64)[:3, :3]).T


def up_hint(direction) -> np.ndarray:
    """An up vector for looking along ``direction``: +Y, or +Z when ``direction`` is nearly vertical."""
    return np.array([0.0, 0.0, 1.0]) if abs(direction[1]) > 0.9 else np.array([0.0, 1.0, 0.0])


def look_at_view_from_world(eye, target, up) -> np.ndarray:
    """OpenGL view matrix: the camera at ``eye`` looks down -Z towards ``target``."""
    eye, target, up = (np.asarray(x, dtype=np.float64) for x in (eye, target, up))
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = right, true_up, -forward
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def perspective_clip_from_view(fov_y_degrees: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL perspective projection (clip z in [-w, w])."""
    f = 1.0 / np.tan(np.radians(fov_y_degrees) / 2.0)
    m = np.zeros((4, 4))
    m[0, 0] = f / aspect
    m[1, 1] = f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def orthographic_clip_from_view(half_width: float, half_height: float, near: float, far: float) -> np.ndarray:
    """OpenGL orthographic projection of the box [-hw,hw]x[-hh,hh]x[-far,-near]."""
    m = np.eye(4)
    m[0, 0] = 1.0 / half_width
    m[1, 1] = 1.0 / half_height
    m[2, 2] = -2.0 / (far - near)
    m[2, 3] = -(far + near) / (far - near)
    return m
