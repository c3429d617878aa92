"""Orbit camera: yaw and pitch about a target, distance, pan; converts to the scene's :class:`Camera`.

Mouse conventions of the viewer: left drag orbits, right drag pans, the wheel
zooms, F frames the scene's bounding box, R resets to the scene camera. Drags
are in window pixels so that scripted events mean the same as real ones.
"""
from __future__ import annotations

import math

import numpy as np

from ..scene import Camera

DEGREES_PER_PIXEL = 0.3  # orbit speed of a drag
ZOOM_PER_STEP = 0.9  # distance factor of one wheel step towards the target
MAX_PITCH = 89.0  # degrees: never cross the pole (the up vector would flip)


class OrbitCamera:
    """An eye on a sphere around ``target``; ``up`` is the scene camera's up vector (+Y by convention)."""

    def __init__(self, camera: Camera):
        self.home = camera
        self.reset()

    def reset(self) -> None:
        """Back to the scene's own camera."""
        camera = self.home
        self.up = camera.up / np.linalg.norm(camera.up)
        self.fov_y, self.near, self.far = camera.fov_y, camera.near, camera.far
        self.target = np.array(camera.look_at, dtype=np.float64)
        offset = camera.position - camera.look_at
        self.distance = float(np.linalg.norm(offset))
        # Express the eye direction in the (east, up, south) basis around the up vector.
        east, south = self._ground_basis()
        direction = offset / self.distance
        self.pitch = math.degrees(math.asin(float(np.clip(direction @ self.up, -1.0, 1.0))))
        self.yaw = math.degrees(math.atan2(float(direction @ east), float(direction @ south)))

    def _ground_basis(self) -> tuple[np.ndarray, np.ndarray]:
        """Two unit vectors perpendicular to ``up``: east and south (the home camera's side of the target)."""
        offset = self.home.position - self.home.look_at
        south = offset - (offset @ self.up) * self.up
        if np.linalg.norm(south) < 1e-9:  # looking straight down or up: any horizontal axis
            south = np.cross(self.up, [1.0, 0.0, 0.0] if abs(self.up[0]) < 0.9 else [0.0, 0.0, 1.0])
        south = south / np.linalg.norm(south)
        east = np.cross(self.up, south)
        return east, south

    @property
    def position(self) -> np.ndarray:
        east, south = self._ground_basis()
        yaw, pitch = math.radians(self.yaw), math.radians(self.pitch)
        direction = math.cos(pitch) * (math.sin(yaw) * east + math.cos(yaw) * south) + math.sin(pitch) * self.up
        return self.target + self.distance * direction

    def camera(self, size: tuple[int, int]) -> Camera:
        """The scene camera for the current orbit at ``size`` (width, height)."""
        return Camera(self.position, self.target, self.up, self.fov_y, self.near, self.far, (int(size[0]), int(size[1])))

    # Compose a view from drags and wheel steps.
    def orbit(self, dx: float, dy: float) -> None:
        """Rotate by a drag of (dx, dy) pixels: right drags turn the scene right, down drags look from above."""
        self.yaw -= dx * DEGREES_PER_PIXEL
        self.pitch = float(np.clip(self.pitch + dy * DEGREES_PER_PIXEL, -MAX_PITCH, MAX_PITCH))

    def pan(self, dx: float, dy: float, height: int) -> None:
        """Move the target with the drag so that the point under the cursor follows it (``height`` in pixels)."""
        eye = self.position
        forward = (self.target - eye) / self.distance
        right = np.cross(forward, self.up)
        right /= np.linalg.norm(right)
        cam_up = np.cross(right, forward)
        units_per_pixel = 2.0 * self.distance * math.tan(math.radians(self.fov_y) / 2.0) / max(1, height)
        self.target = self.target + units_per_pixel * (-dx * right + dy * cam_up)

    def zoom(self, steps: float) -> None:
        """Move towards the target (positive steps) or away; never through it."""
        self.distance = max(1e-3, self.distance * ZOOM_PER_STEP ** steps)

    def frame(self, bounds: np.ndarray, aspect: float = 1.0) -> None:
        """Aim at the centre of ``bounds`` (2, 3) from a distance where its bounding sphere fills the view."""
        lo, hi = np.asarray(bounds, dtype=np.float64)
        radius = max(1e-6, float(np.linalg.norm(hi - lo)) / 2.0)
        half_fov = math.radians(self.fov_y) / 2.0
        half_fov = min(half_fov, math.atan(math.tan(half_fov) * aspect))
        self.target = (lo + hi) / 2.0
        self.distance = 1.05 * radius / math.sin(half_fov)
