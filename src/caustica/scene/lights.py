"""Light sources. Point intensity in W/sr, directional irradiance in W/m^2."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from . import rules


def _intensity(value) -> np.ndarray:
    return rules.rgb(value, "intensity", rules.MAX_INTENSITY)


@dataclass
class PointLight:
    """Light from one point, ``intensity`` in W/sr."""

    position: np.ndarray
    intensity: np.ndarray = field(default_factory=lambda: np.array([10.0, 10.0, 10.0]))
    kind = "point"

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.position = rules.vector(self.position, "position")
        self.intensity = _intensity(self.intensity)

    def point_samples(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The light as (position, intensity) point lights: this one."""
        return [(self.position, self.intensity)]


@dataclass
class DirectionalLight:
    """Parallel light travelling along ``direction``; ``intensity`` is irradiance."""

    direction: np.ndarray
    intensity: np.ndarray = field(default_factory=lambda: np.array([3.0, 3.0, 3.0]))
    kind = "directional"

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.direction = rules.direction(self.direction, "direction")
        self.intensity = _intensity(self.intensity)


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
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.position = rules.vector(self.position, "position")
        self.direction = rules.direction(self.direction, "direction")
        self.intensity = _intensity(self.intensity)
        self.inner_angle = rules.number(self.inner_angle, "inner_angle", 0.0, 90.0, open_low=True, hint=" degrees")
        self.outer_angle = rules.number(self.outer_angle, "outer_angle", 0.0, 90.0, open_low=True, hint=" degrees")
        if not self.inner_angle <= self.outer_angle < 90:
            raise SceneError(f"spot angles (inner_angle {self.inner_angle:g}, outer_angle {self.outer_angle:g}) "
                                   "must satisfy 0 < inner_angle <= outer_angle < 90 degrees")

    def falloff(self, cos_angle: np.ndarray) -> np.ndarray:
        """Smooth step from the outer cone (0) to the inner cone (1)."""
        cos_in, cos_out = np.cos(np.radians(self.inner_angle)), np.cos(np.radians(self.outer_angle))
        t = np.clip((cos_angle - cos_out) / max(cos_in - cos_out, 1e-9), 0.0, 1.0)
        return t * t * (3.0 - 2.0 * t)

    def point_samples(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The light as (position, intensity) point lights: this one."""
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
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.start = rules.vector(self.start, "start")
        self.end = rules.vector(self.end, "end")
        self.intensity = _intensity(self.intensity)
        self.samples = rules.integer(self.samples, "samples", 1, rules.MAX_LINE_SAMPLES,
                                     hint=" (GL techniques take 8 light samples in all)")

    def point_samples(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The ``samples`` point lights at the segment's stratum centres, each 1/samples of the intensity."""
        ts = (np.arange(self.samples) + 0.5) / self.samples
        return [(self.start + t * (self.end - self.start), self.intensity / self.samples) for t in ts]


Light = PointLight | DirectionalLight | SpotLight | LineLight
