"""Light sources. Point intensity in W/sr, directional irradiance in W/m^2."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .materials import _rgb


def _unit(value, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) < 1e-12:
        raise ValueError(f"{name} must be a non-zero vector [x, y, z]")
    return v / np.linalg.norm(v)


@dataclass
class PointLight:
    position: np.ndarray
    intensity: np.ndarray = field(default_factory=lambda: np.array([10.0, 10.0, 10.0]))
    kind = "point"

    def __post_init__(self):
        self.position = np.asarray(self.position, dtype=np.float64).reshape(3)
        self.intensity = _rgb(self.intensity, "point light intensity")

    def point_samples(self):
        return [(self.position, self.intensity)]


@dataclass
class DirectionalLight:
    """Parallel light travelling along ``direction``; ``intensity`` is irradiance."""

    direction: np.ndarray
    intensity: np.ndarray = field(default_factory=lambda: np.array([3.0, 3.0, 3.0]))
    kind = "directional"

    def __post_init__(self):
        self.direction = _unit(self.direction, "directional light direction")
        self.intensity = _rgb(self.intensity, "directional light irradiance")


@dataclass
class SpotLight:
    """Point light restricted to a cone; full intensity inside ``inner_angle``, zero past ``outer_angle`` (degrees, half angles)."""

    position: np.ndarray
    direction: np.ndarray
    intensity: np.ndarray = field(default_factory=lambda: np.array([10.0, 10.0, 10.0]))
    inner_angle: float = 20.0
    outer_angle: float = 30.0
    kind = "spot"

    def __post_init__(self):
        self.position = np.asarray(self.position, dtype=np.float64).reshape(3)
        self.direction = _unit(self.direction, "spot light direction")
        self.intensity = _rgb(self.intensity, "spot light intensity")
        if not 0 < self.inner_angle <= self.outer_angle < 90:
            raise ValueError("spot angles must satisfy 0 < inner_angle <= outer_angle < 90 degrees")

    def falloff(self, cos_angle: np.ndarray) -> np.ndarray:
        """Smooth step from the outer cone (0) to the inner cone (1)."""
        cos_in, cos_out = np.cos(np.radians(self.inner_angle)), np.cos(np.radians(self.outer_angle))
        t = np.clip((cos_angle - cos_out) / max(cos_in - cos_out, 1e-9), 0.0, 1.0)
        return t * t * (3.0 - 2.0 * t)

    def point_samples(self):
        return [(self.position, self.intensity)]


@dataclass
class LineLight:
    """A segment light from ``start`` to ``end`` made of ``samples`` point lights sharing ``intensity``."""

    start: np.ndarray
    end: np.ndarray
    intensity: np.ndarray = field(default_factory=lambda: np.array([10.0, 10.0, 10.0]))
    samples: int = 8
    kind = "line"

    def __post_init__(self):
        self.start = np.asarray(self.start, dtype=np.float64).reshape(3)
        self.end = np.asarray(self.end, dtype=np.float64).reshape(3)
        self.intensity = _rgb(self.intensity, "line light intensity")
        self.samples = int(self.samples)
        if self.samples < 1:
            raise ValueError("line light samples must be at least 1")

    def point_samples(self):
        ts = (np.arange(self.samples) + 0.5) / self.samples
        return [(self.start + t * (self.end - self.start), self.intensity / self.samples) for t in ts]


Light = PointLight | DirectionalLight | SpotLight | LineLight
