"""Image regions of a scene (refractor, caustic, rest) and image comparison per region.

:func:`region_masks` classifies each pixel with the exact ray tracer:

- ``"refractor"``: the primary ray's first hit is a glass object;
- ``"caustic"``: the first hit is a diffuse receiver lying in the geometric
  shadow of a refractor for at least one light: the shadow ray from the hit
  point towards the light (each point sample of a point, spot or line light,
  or against the direction of a directional light) first hits a glass object
  before reaching the light. Only lights on the side of the surface the camera
  sees count, and spot lights only inside their outer cone;
- ``"rest"``: everything else (other diffuse pixels, mirrors, the background).

:func:`caustic_region` is the caustic region less the pixels partly on glass, where the Mitsuba
composite lacks light by construction.

:func:`glint_mask`: the pixels where a technique shows a point light's image that the path-traced
reference cannot contain: glass whose refracted view lands in a light's glass shadow (the caustic
seen through the glass, light -> specular -> diffuse -> specular -> camera, which neither of the
composite's integrators samples) and where the technique is much brighter than the reference.

The masks are (H, W) bool, row 0 at the top, pairwise disjoint and together
cover the image.
"""
from __future__ import annotations

import numpy as np

from ..raytrace.embree_scene import ray_scene_for
from ..raytrace.paths import follow_refraction
from ..scene.lights import DirectionalLight, SpotLight
from .checks import image_pair, masked_mean, pixel_mask
from .hits import objects_of_kind
from .images import RELMSE_EPSILON, psnr_linear, psnr_srgb, relmse
from .perceptual import flip_error_map, masked_ssim, ssim_map

REGIONS = ("refractor", "caustic", "rest")


def _light_samples(light):
    """(position or None for directional, cos of the outer cone or None) per point sample of ``light``."""
    if isinstance(light, DirectionalLight):
        return [(None, None)]
    cos_outer = np.cos(np.radians(light.outer_angle)) if isinstance(light, SpotLight) else None
    return [(position, cos_outer) for position, _ in light.point_samples()]


def _in_glass_shadow(ray_scene, scene, glass: np.ndarray, position, facing_normal) -> np.ndarray:
    """(n,) bool: whether each point lies in the geometric shadow of a glass object for some light."""
    shadowed = np.zeros(len(position), bool)
    origin = position + facing_normal * ray_scene.epsilon
    for light in scene.lights:
        for light_position, cos_outer in _light_samples(light):
            if light_position is None:
                to_light = np.broadcast_to(-light.direction, position.shape)
                distance = np.full(len(position), np.inf)
            else:
                offset = light_position - position
                distance = np.linalg.norm(offset, axis=1)
                to_light = offset / np.maximum(distance, 1e-300)[:, None]
            test = ~shadowed & (np.einsum("ij,ij->i", facing_normal, to_light) > 0)
            if cos_outer is not None:
                test &= -to_light @ light.direction >= cos_outer
            if not test.any():
                continue
            hits = ray_scene.intersect(origin[test], to_light[test])
            blocked = hits.hit & (hits.t < distance[test] - ray_scene.epsilon) & glass[hits.object_index]
            shadowed[np.flatnonzero(test)[blocked]] = True
    return shadowed


def region_masks(scene, camera=None, spp: int = 1) -> dict[str, np.ndarray]:
    """{"refractor", "caustic", "rest"} -> (H, W) bool masks of ``camera`` (default ``scene.camera``).

    With ``spp`` > 1 each pixel traces the stratified sub-pixel samples of
    :meth:`Camera.primary_rays` and takes the region most of them fall in
    (ties go to refractor, then caustic, then rest).
    """
    camera = scene.camera if camera is None else camera
    width, height = camera.size
    origins, dirs = camera.primary_rays(spp)
    samples = origins.shape[2]
    origins, dirs = origins.reshape(-1, 3), dirs.reshape(-1, 3)
    ray_scene = ray_scene_for(scene)
    glass = objects_of_kind(scene, "glass")
    hits = ray_scene.intersect(origins, dirs)
    label = np.full(len(dirs), 2, np.int64)
    label[glass[hits.object_index]] = 0
    diffuse = np.flatnonzero(objects_of_kind(scene, "diffuse")[hits.object_index])
    if len(diffuse) and scene.lights:
        ng = hits.geometric_normal[diffuse]
        facing = ng * np.where(np.einsum("ij,ij->i", ng, dirs[diffuse]) < 0, 1.0, -1.0)[:, None]
        label[diffuse[_in_glass_shadow(ray_scene, scene, glass, hits.position[diffuse], facing)]] = 1
    votes = np.eye(len(REGIONS), dtype=np.int64)[label].reshape(height, width, samples, len(REGIONS)).sum(axis=2)
    winner = votes.argmax(axis=2)
    return {name: winner == i for i, name in enumerate(REGIONS)}


def caustic_region(scene, camera=None) -> np.ndarray:
    """(H, W) bool: the pixels of ``region_masks``'s caustic region whose whole footprint (the 16 stratified
    rays of :func:`caustica.reference.render.diffuse_coverage`) first hits a diffuse surface.

    The Mitsuba composite is right by construction only there (reference/render.py): on a pixel partly on
    glass it draws the glass part's light black in the light tracer and without caustics in ``path``, so a
    caustic technique is charged for light the reference lacks. Compare caustics on this region."""
    from ..reference.render import diffuse_coverage

    camera = scene.camera if camera is None else camera
    return region_masks(scene, camera)["caustic"] & (diffuse_coverage(scene, camera) >= 1.0)


GLINT_EXCESS = 0.5  # a glint is brighter than the reference by half its value, in relMSE's units (relmse term > 0.25)


def _lands_in_glass_shadow(ray_scene, scene, glass, diffuse, origins, dirs) -> np.ndarray:
    """(n,) bool: whether each ray (from a specular surface, already off it) first meets a diffuse surface at a
    point in the geometric shadow of a glass object for some light."""
    hits = ray_scene.intersect(origins, dirs)
    landed = np.flatnonzero(diffuse[hits.object_index])
    out = np.zeros(len(dirs), bool)
    if len(landed):
        ng = hits.geometric_normal[landed]
        facing = ng * np.where(np.einsum("ij,ij->i", ng, dirs[landed]) < 0, 1.0, -1.0)[:, None]
        out[landed] = _in_glass_shadow(ray_scene, scene, glass, hits.position[landed], facing)
    return out


def caustic_through_glass(scene, camera=None, spp: int = 4) -> np.ndarray:
    """(H, W) bool: pixels one of whose ``spp`` stratified primary rays first hits glass or a mirror and, along the
    mirror reflection of that first surface or (glass) along the refracted branch out
    (:func:`caustica.raytrace.paths.follow_refraction`), lands on a diffuse surface in the geometric shadow of a
    glass object for some light: where a light's caustic is seen in or through a specular surface."""
    camera = scene.camera if camera is None else camera
    width, height = camera.size
    origins, dirs = (a.reshape(-1, 3) for a in camera.primary_rays(spp))
    ray_scene = ray_scene_for(scene)
    glass, diffuse = objects_of_kind(scene, "glass"), objects_of_kind(scene, "diffuse")
    seen = np.zeros(len(dirs), bool)
    first = ray_scene.intersect(origins, dirs)
    specular = np.flatnonzero(glass[first.object_index] | objects_of_kind(scene, "mirror")[first.object_index])
    if len(specular) and scene.lights:
        # The first surface's mirror reflection (glass reflects too, the more at grazing angles).
        d, ng = dirs[specular], first.geometric_normal[specular]
        reflected = d - 2.0 * np.einsum("ij,ij->i", d, ng)[:, None] * ng
        start = first.position[specular] + reflected * ray_scene.epsilon
        seen[specular] = _lands_in_glass_shadow(ray_scene, scene, glass, diffuse, start, reflected)
        # Glass: the refracted branch, from where it leaves the last glass surface.
        on_glass = specular[glass[first.object_index[specular]]]
        paths = follow_refraction(ray_scene, scene, origins[on_glass], dirs[on_glass])
        out = np.flatnonzero(paths.valid)
        exits = paths.position[out] + paths.direction[out] * ray_scene.epsilon  # off the glass it leaves
        seen[on_glass[out]] |= _lands_in_glass_shadow(ray_scene, scene, glass, diffuse, exits, paths.direction[out])
    return seen.reshape(height, width, -1).any(axis=2)


def glint_mask(scene, camera, images, reference, through_glass=None) -> np.ndarray:
    """(H, W) bool: pixels of :func:`caustic_through_glass` (or ``through_glass``, when given) where any of
    ``images`` (technique images, (H, W, 3) linear) exceeds ``reference`` by more than GLINT_EXCESS in relMSE's
    units, ``(image - reference) / sqrt(reference^2 + 0.01)`` averaged over the channels: a point light's image
    that the reference cannot contain. One mask for all, so every technique is scored on the same pixels."""
    candidates = caustic_through_glass(scene, camera) if through_glass is None else through_glass
    ref = np.asarray(reference, np.float64)
    scale = np.sqrt(ref * ref + RELMSE_EPSILON)
    mask = np.zeros(candidates.shape, bool)
    for image in images:
        mask |= ((np.asarray(image, np.float64) - ref) / scale).mean(axis=2) > GLINT_EXCESS
    return mask & candidates


def compare_images(image, reference, masks: dict) -> dict[str, dict[str, float]]:
    """Every metric over the whole image ("all") and over each region of ``masks``.

    Returns {region: {"psnr_linear", "psnr_srgb", "relmse", "ssim", "flip"}},
    "all" first, then the regions in the order of ``masks``. SSIM and FLIP
    maps are computed once over the whole image and averaged per region; an
    empty region gives NaN throughout.
    """
    x, ref = image_pair(image, reference)
    if "all" in masks:
        raise ValueError('masks may not contain a region named "all"; it is the whole image')
    regions = {"all": None}
    regions.update({name: pixel_mask(mask, x.shape) for name, mask in masks.items()})
    similarity, flip_errors = ssim_map(x, ref), flip_error_map(x, ref).astype(np.float64)
    return {
        name: {
            "psnr_linear": psnr_linear(x, ref, mask),
            "psnr_srgb": psnr_srgb(x, ref, mask),
            "relmse": relmse(x, ref, mask),
            "ssim": masked_ssim(similarity, mask),
            "flip": masked_mean(flip_errors, mask),
        }
        for name, mask in regions.items()
    }
