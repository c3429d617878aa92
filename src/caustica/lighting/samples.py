"""The scene's lights as the shaders' light samples: points, directional and spot lights, the points of a line
light, and the environment's sun as one more directional sample (lighting/environment.py)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import TechniqueError
from ..scene.codes import LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT
from ..scene.lights import DirectionalLight, SpotLight
from ..scene.transform import look_at_view_from_world, orthographic_clip_from_view, perspective_clip_from_view, up_hint
from .environment import environment_sun

MAX_LIGHTS = 8  # shadow maps take texture units 8..15, caustic maps 16..23 (NVIDIA and llvmpipe have 32)


CUBE_FORWARD = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64)


CUBE_UP = np.array([[0, 1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1], [0, 1, 0], [0, 1, 0]], dtype=np.float64)


@dataclass
class LightSample:
    """One shadowed emitter as the shaders see it (a line light gives several)."""

    type: int
    position: np.ndarray
    direction: np.ndarray
    intensity: np.ndarray
    cone_cos: tuple[float, float] = (1.0, 1.0)
    clip_from_world: np.ndarray | None = None  # directional and spot maps
    environment: bool = False  # the environment's sun (passes/shading/environment.py), not one of scene.lights


def scene_sphere(scene) -> tuple[np.ndarray, float]:
    """(centre, radius) of the sphere around the scene's bounds that the light samples' maps are fitted to."""
    return scene.bounds().mean(axis=0), 0.5 * np.linalg.norm(np.ptp(scene.bounds(), axis=0)) + 1e-6


def light_samples(scene) -> list[LightSample]:
    """Expand the scene's lights into point/directional/spot samples, then the environment's sun as a
    directional sample (passes/shading/environment.py) where it has one and a sample is free."""
    center, radius = scene_sphere(scene)
    samples: list[LightSample] = []
    for light in scene.lights:
        if isinstance(light, DirectionalLight):
            samples.append(directional_sample(light, center, radius))
        elif isinstance(light, SpotLight):
            view = look_at_view_from_world(light.position, light.position + light.direction, up_hint(light.direction))
            far = np.linalg.norm(light.position - center) + 2 * radius
            clip = perspective_clip_from_view(2 * light.outer_angle + 2.0, 1.0, 0.01 * radius, far) @ view
            cones = (float(np.cos(np.radians(light.inner_angle))), float(np.cos(np.radians(light.outer_angle))))
            samples.append(LightSample(LIGHT_SPOT, light.position, light.direction, light.intensity, cones, clip))
        else:
            for position, intensity in light.point_samples():
                samples.append(LightSample(LIGHT_POINT, position, np.array([0.0, -1.0, 0.0]), intensity))
    if len(samples) > MAX_LIGHTS:
        raise TechniqueError(
            f"the scene has {len(samples)} light samples but at most {MAX_LIGHTS} are supported; "
            "use fewer lights or fewer line-light samples"
        )
    sun = environment_sun(scene.environment).light
    if sun is not None and len(samples) < MAX_LIGHTS:
        samples.append(dataclasses.replace(directional_sample(sun, center, radius), environment=True))
    return samples


def directional_sample(light: DirectionalLight, center: np.ndarray, radius: float) -> LightSample:
    """A directional light's sample: an orthographic map over the sphere (center, radius) around the scene."""
    origin = center - light.direction * 2.0 * radius
    view = look_at_view_from_world(origin, center, up_hint(light.direction))
    clip = orthographic_clip_from_view(radius, radius, 0.01 * radius, 4.0 * radius) @ view
    return LightSample(LIGHT_DIRECTIONAL, origin, light.direction, light.intensity, clip_from_world=clip)
