"""Node transforms between glTF (column-major matrices, TRS with xyzw quaternions) and caustica's
:class:`~caustica.scene.Transform` (scale, then XYZ Euler rotation in degrees, then translation)."""
from __future__ import annotations

import math

import numpy as np

from .. import rules
from ..transform import Transform

ORTHONORMAL_TOLERANCE = 1e-5  # how far R^T R may be from I for a matrix to count as rotation times scale


def matrix_from_quaternion(q) -> np.ndarray:
    """3x3 rotation of a unit quaternion (x, y, z, w); normalized first."""
    x, y, z, w = np.asarray(q, dtype=np.float64) / max(float(np.linalg.norm(q)), 1e-300)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def quaternion_from_matrix(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w), w >= 0, of a 3x3 rotation (Shepperd's method: the largest pivot)."""
    r = np.asarray(r, dtype=np.float64)
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(max(1.0 + r[i, i] - r[j, j] - r[k, k], 1e-300))
        q = [0.0, 0.0, 0.0, (r[k, j] - r[j, k]) / s]
        q[i], q[j], q[k] = s / 4, (r[j, i] + r[i, j]) / s, (r[k, i] + r[i, k]) / s
    q = np.array(q)
    return q / np.linalg.norm(q) * (1.0 if q[3] >= 0 else -1.0)


def euler_degrees_from_rotation(r: np.ndarray) -> np.ndarray:
    """The XYZ Euler angles (degrees) of a 3x3 rotation, the inverse of ``rotation_from_euler_degrees``
    (R = Rz Ry Rx); at gimbal lock (Y = +-90 degrees) the Z angle is 0."""
    r = np.asarray(r, dtype=np.float64)
    sy = float(np.clip(-r[2, 0], -1.0, 1.0))
    ry = math.asin(sy)
    if math.sqrt(r[0, 0] ** 2 + r[1, 0] ** 2) > 1e-9:
        rx, rz = math.atan2(r[2, 1], r[2, 2]), math.atan2(r[1, 0], r[0, 0])
    else:  # cos(ry) = 0: only rx -+ rz is defined; with rz = 0, R[1, 1] = cos(rx) and R[1, 2] = -sin(rx)
        rx, rz = math.atan2(-r[1, 2], r[1, 1]), 0.0
    return np.degrees([rx, ry, rz])


def trs_matrix(translation, rotation_xyzw, scale) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = matrix_from_quaternion(rotation_xyzw) @ np.diag(np.asarray(scale, dtype=np.float64))
    m[:3, 3] = translation
    return m


def transform_of(matrix: np.ndarray) -> Transform | None:
    """``matrix`` as a caustica Transform when it is a rotation times a positive scale plus a translation,
    within the scene rules' ranges; None when it shears or mirrors (the caller bakes it into vertices)."""
    linear = np.asarray(matrix, dtype=np.float64)[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    if not np.all(scale > 0) or np.linalg.det(linear) <= 0:
        return None
    rotation = linear / scale
    if np.abs(rotation.T @ rotation - np.eye(3)).max() > ORTHONORMAL_TOLERANCE:
        return None
    low, high = rules.SCALE_RANGE
    if scale.min() < low or scale.max() > high or np.abs(matrix[:3, 3]).max() > rules.MAX_COORDINATE:
        return None
    return Transform(position=matrix[:3, 3].copy(), rotation=euler_degrees_from_rotation(rotation), scale=scale)
