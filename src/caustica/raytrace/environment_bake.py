"""A light map of the environment's light on a floor, baked with ``exact``'s rays (issue 23, real time).

The raster techniques light diffuse surfaces with the environment's SH irradiance, unoccluded, or with a
few lobes' shadow maps (passes/environment_lights.py); neither has the sky's light refracted by glass
onto the floor (its caustic), and the lobes cost a frame several times plain's. For a static scene the
floor's share of that light does not depend on the camera, so it is computed once per scene state and read
by the shading with one texture fetch: a light map, the oldest precomputation of global illumination
(Heckbert 1990, "Adaptive radiosity textures for bidirectional ray tracing"; here gathered, not shot).

Each texel of the floor's top rectangle gathers the irradiance of the *ambient* environment (the image
without its sun where the sun is a directional light of its own, which keeps its sharp shadow and its caustic
map) with ``exact``'s cosine rays (:func:`~caustica.raytrace.paths.cosine_gather`): occluded by every object,
through glass and off mirrors (the sky's caustic and the glass's tinted shadow) and one bounce of
interreflection, where the bounced surface is lit by the scene's lights, the sun and the ambient
environment's SH. The rays carry a control variate: each adds what it brings less what the open sky brings
along it, and the open floor's irradiance is added back in closed form (a sum over the environment's
texels), so a texel nothing shadows is exact and the noise stays where objects are.

Texels whose centre lies inside an object (under a box resting on the floor: the ray straight up leaves the
object through its back face) take their nearest outside neighbours' mean, so bilinear filtering at an
object's foot does not blend in the black of its inside.

Deterministic: the ray patterns are hashed from each texel's position (environment_light.rotated_pattern).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..progress import progress
from ..scene.environment import Environment, texel_grid
from .embree_scene import ray_scene_for
from .environment_light import EnvironmentLight
from .paths import EnvironmentSampling, Materials, cosine_gather

BAKE_SIZE = 64  # texels a side of the floor's light map
BAKE_SAMPLES = 256  # cosine rays a texel


@dataclass(frozen=True)
class FloorBake:
    """The irradiance of the ambient environment on a floor's top face (normal +y), per texel of the
    rectangle ``low`` to ``high`` (x, z) at height ``height``: ``irradiance[j, i]`` at x = low.x + (i + 1/2)
    (high.x - low.x) / size, z = low.z + (j + 1/2) (high.z - low.z) / size. Radiance is albedo / pi times it."""

    low: np.ndarray
    high: np.ndarray
    height: float
    irradiance: np.ndarray  # (size, size, 3) float32, intensity_scale not applied


def open_irradiance(image: np.ndarray) -> np.ndarray:
    """(3,) irradiance an upward normal receives from the whole upper hemisphere of an equirectangular
    ``image``: sum over texels of radiance cos(theta) solid angle."""
    directions, solid_angle = texel_grid(*image.shape[:2])
    return np.einsum("hwc,hw->c", image.astype(np.float64), np.maximum(directions[..., 1], 0.0) * solid_angle)


def bake_floor(scene, floor, ambient: Environment, sun=None, size: int = BAKE_SIZE,
               samples: int = BAKE_SAMPLES) -> FloorBake:
    """The :class:`FloorBake` of ``floor`` (one of ``scene.objects``) under the ``ambient`` environment;
    ``sun`` (a DirectionalLight or None) lights the surfaces the rays bounce off, as the scene's lights do."""
    low3, high3 = floor.world_mesh().bounds
    low, high = low3[[0, 2]].astype(np.float64), high3[[0, 2]].astype(np.float64)
    # Texel centres on the floor's top face.
    t = (np.arange(size) + 0.5) / size
    zz, xx = np.meshgrid(low[1] + t * (high[1] - low[1]), low[0] + t * (high[0] - low[0]), indexing="ij")
    points = np.stack([xx.ravel(), np.full(xx.size, float(high3[1])), zz.ravel()], axis=1)
    up = np.tile([0.0, 1.0, 0.0], (len(points), 1))
    # The rays see the ambient environment; the surfaces they bounce off are lit by the lights and the sun.
    lit = replace(scene, lights=[*scene.lights, *([sun] if sun is not None else [])], intensity_scale=1.0)
    rays = ray_scene_for(scene)
    materials = Materials.of(scene)
    sampling = EnvironmentSampling(EnvironmentLight(ambient, bright=0.0), samples, 0, True)
    with progress(len(points), f"baking the environment's light on {floor.name} ({size}x{size}, {samples} rays)",
                  unit="texels") as bar:
        shadowed = cosine_gather(rays, lit, points, up, up, sampling, materials, materials.ior_rgb[:, 0],
                                 less_open=True, done=bar.update)
    irradiance = open_irradiance(ambient.image) + np.pi * shadowed
    inside = _inside(rays, points + up * rays.epsilon)
    irradiance = _fill(irradiance.reshape(size, size, 3), inside.reshape(size, size))
    return FloorBake(low, high, float(high3[1]), np.maximum(irradiance, 0.0).astype(np.float32))


def _inside(rays, origins: np.ndarray) -> np.ndarray:
    """Whether each origin lies inside a closed object: the ray straight up leaves one through a back face."""
    up = np.tile([0.0, 1.0, 0.0], (len(origins), 1))
    hits = rays.intersect(origins, up)
    return hits.hit & (hits.geometric_normal[:, 1] > 0.0)


def _fill(values: np.ndarray, invalid: np.ndarray) -> np.ndarray:
    """``values`` (n, n, 3) with each ``invalid`` texel replaced, ring by ring from the valid ones, by the mean
    of its valid 4-neighbours."""
    values, invalid = values.copy(), invalid.copy()
    if invalid.all():
        return values
    while invalid.any():
        valid = ~invalid
        total = np.zeros_like(values)
        count = np.zeros(invalid.shape)
        for axis, shift in ((0, 1), (0, -1), (1, 1), (1, -1)):
            moved_valid = np.roll(valid, shift, axis=axis)
            moved = np.roll(values, shift, axis=axis)
            edge = [slice(None)] * 2
            edge[axis] = 0 if shift == 1 else -1
            moved_valid[tuple(edge)] = False  # no wrapping around
            total += np.where(moved_valid[..., None], moved, 0.0)
            count += moved_valid
        reached = invalid & (count > 0)
        values[reached] = total[reached] / count[reached][:, None]
        invalid &= ~reached
    return values
