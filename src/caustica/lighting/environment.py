"""The environment's light for the raster techniques: its sun as a directional light, the rest as SH
irradiance (Ramamoorthi and Hanrahan 2001), optionally as strata of equal power ("lobes") with shadow maps,
and a floor's bounce (docs/environment-light.md).

A small, very bright region of the environment (a sun) is taken out as a
:class:`~caustica.scene.lights.DirectionalLight` that goes through the shadow-map and caustic-map machinery of
the scene's lights (lighting/samples.py appends it, flagged ``environment``); the diffuse ambient becomes the
SH irradiance of the rest, so the split adds up to the original image. The bright region is the one ``exact``
samples (:class:`~caustica.raytrace.environment_light.EnvironmentLight`: texels above ``BRIGHT_RATIO`` times
the mean radiance); its irradiance and power-weighted mean direction come from SUN_SAMPLES stratified samples.
A bright part spread wider than SUN_SPREAD degrees (several suns, a window) is no sun: it stays in the SH.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cache import array_digest, kept_on, scene_state_key
from ..raytrace.environment_light import environment_light, hammersley
from ..scene.environment import Environment, irradiance_sh_of, texel_grid, uv_to_direction
from ..scene.lights import DirectionalLight

SUN_SAMPLES = 16384  # stratified samples of the bright part (its integral to about 1e-4 on sky-checker's sun)


SUN_SPREAD = 10.0  # degrees: the largest angular radius (from the mean resultant length) of a sun


@dataclass(frozen=True)
class EnvironmentSun:
    """The environment's sun as a directional light (None: it has none) and the SH irradiance of the rest."""

    light: DirectionalLight | None
    rest_sh: np.ndarray  # (9, 3): Environment.irradiance_sh of the environment without the sun


def environment_sun(environment: Environment) -> EnvironmentSun:
    """The :class:`EnvironmentSun` of ``environment``, cached on it by the image's content."""
    return kept_on(environment, "_sun_cache", array_digest(environment.image), lambda: _extract_sun(environment))


def _extract_sun(environment: Environment) -> EnvironmentSun:
    split = environment_light(environment)
    if not split.has_bright:
        return EnvironmentSun(None, environment.irradiance_sh())
    direction, radiance, pdf = split.sample_bright(hammersley(SUN_SAMPLES))
    weighted = radiance / pdf[:, None]  # per sample: the bright part's integral, per channel
    irradiance = weighted.mean(axis=0)
    resultant = (direction * weighted.mean(axis=1, keepdims=True)).mean(axis=0)
    spread = np.linalg.norm(resultant) / max(float(irradiance.mean()), 1e-300)
    if spread < np.cos(np.radians(SUN_SPREAD)):
        return EnvironmentSun(None, environment.irradiance_sh())
    light = DirectionalLight(direction=-resultant / np.linalg.norm(resultant), intensity=irradiance)
    return EnvironmentSun(light, split.rest.irradiance_sh())


def ambient_sh(environment: Environment, samples, shadows=None, bake=None) -> np.ndarray:
    """(9, 3) SH irradiance diffuse surfaces take as ambient: the floor's bounce below the horizon where the
    frame's ``environment_shadows`` or ``environment_bake`` hold it (floor_bounce_sh); else the environment's
    without its sun where the ``light_samples`` (passes/shading/shadows.py) hold the sun, else the whole environment's."""
    for held in (shadows, bake):
        if held is not None and held.ambient_sh is not None:
            return held.ambient_sh
    if any(getattr(s, "environment", False) for s in samples):
        return environment_sun(environment).rest_sh
    return environment.irradiance_sh()


LOBES = 16  # auto's count of environment lobes with shadow maps (docs/environment-light.md)


LOBE_MAP_SIZE = 256  # texels a side of each lobe's map


MAX_LOBES = 32  # lighting.glsl's MAX_ENV_LOBES


@dataclass(frozen=True)
class EnvironmentLobes:
    """The rest of the environment's sky (without its sun) cut into ``count`` strata of equal power, each a
    direction of travel and its irradiance vector's length per channel: where a stratum's shadow map says
    its direction is blocked, its share max(0, n . -direction) * irradiance leaves the SH ambient."""

    directions: np.ndarray  # (K, 3) unit directions of travel (minus each stratum's mean direction)
    irradiance: np.ndarray  # (K, 3) per channel: |sum of radiance * solid angle * direction| over the stratum
    span: np.ndarray  # (K,) |sum of solid angle * direction| over the stratum: irradiance per unit radiance


def environment_lobes(environment: Environment, sun_taken: bool, count: int = LOBES) -> EnvironmentLobes:
    """The :class:`EnvironmentLobes` of ``environment`` (its rest when ``sun_taken``), cached on it."""
    def strata() -> EnvironmentLobes:
        image = environment_light(environment).rest.image if sun_taken else environment.image
        return _strata(image.astype(np.float64), int(count))

    return kept_on(environment, "_lobe_cache", (array_digest(environment.image), bool(sun_taken), int(count)), strata)


def _strata(image: np.ndarray, count: int) -> EnvironmentLobes:
    """Stratified importance over the upper hemisphere: rows cut into sqrt(count) bands of equal power
    (luminance times solid angle, at the lookup's texel directions u = (x + 1/2) / W, v = y / (H - 1)), each
    band's columns into count / bands segments of equal power. Light from below the horizon stays unoccluded
    SH: above a floor it arrives as the floor's bounce, which no raster technique traces, and the ground's
    unoccluded light stands in for it better than its shadow (docs/environment-light.md)."""
    h, w = image.shape[:2]
    uu, vv = np.meshgrid((np.arange(w) + 0.5) / w, np.arange(h) / (h - 1))
    direction = uv_to_direction(np.stack([uu, vv], axis=-1))
    sky = (direction[..., 1] > 0.0)[..., None]
    solid_angle = np.sin(np.pi * vv) * (np.pi / (h - 1)) * (2.0 * np.pi / w) * sky[..., 0]
    weighted = image * solid_angle[..., None]  # above the horizon only
    power = weighted.mean(axis=2) + 1e-30 * sky[..., 0]  # a black sky still cuts into strata
    bands = max(int(round(np.sqrt(count))), 1)
    per_band = [count // bands + (1 if b < count % bands else 0) for b in range(bands)]
    row_edges = _equal_cuts(power.sum(axis=1), bands)
    directions, irradiance, spans = [], [], []
    for (top, bottom), columns in zip(zip(row_edges[:-1], row_edges[1:]), per_band):
        column_edges = _equal_cuts(power[top:bottom].sum(axis=0), columns)
        for left, right in zip(column_edges[:-1], column_edges[1:]):
            cell = (slice(top, bottom), slice(left, right))
            vectors = np.einsum("hwc,hwk->ck", weighted[cell], direction[cell])  # per channel: sum L dw d
            mean = np.einsum("hw,hwk->k", power[cell], direction[cell])
            norm = np.linalg.norm(mean)
            directions.append(-mean / norm if norm > 0 else np.array([0.0, -1.0, 0.0]))
            irradiance.append(np.linalg.norm(vectors, axis=1))
            spans.append(np.linalg.norm(np.einsum("hw,hwk->k", solid_angle[cell], direction[cell])))
    return EnvironmentLobes(np.array(directions), np.array(irradiance), np.array(spans))


def _equal_cuts(weights: np.ndarray, parts: int) -> list[int]:
    """Indices 0 = e_0 < e_1 < ... < e_parts = len(weights) cutting ``weights`` into parts of about equal sum
    (each part at least one entry)."""
    cdf = np.cumsum(weights) / weights.sum()
    edges = [0]
    for k in range(1, parts):
        cut = int(np.searchsorted(cdf, k / parts)) + 1
        edges.append(min(max(cut, edges[-1] + 1), len(weights) - (parts - k)))
    return edges + [len(weights)]


FLOOR_FLATNESS = 0.01  # a floor's height over its width, at most


def scene_floor(scene):
    """The scene's floor, or None: a diffuse object at most FLOOR_FLATNESS as high as it is wide whose top is
    at or below every other object's bottom and whose x and z extents cover theirs."""
    boxes = [o.world_mesh().bounds for o in scene.objects]
    for i, obj in enumerate(scene.objects):
        low, high = boxes[i]
        width = max(high[0] - low[0], high[2] - low[2])
        others = np.array([b for j, b in enumerate(boxes) if j != i])
        if obj.material.kind != "diffuse" or not len(others) or high[1] - low[1] > FLOOR_FLATNESS * width:
            continue
        below = others[:, 0].min(axis=0)[1] >= high[1] - FLOOR_FLATNESS * width
        if below and np.all(low[[0, 2]] <= others[:, 0].min(axis=0)[[0, 2]]) and np.all(
                high[[0, 2]] >= others[:, 1].max(axis=0)[[0, 2]]):
            return obj
    return None


def ground_sh(scene, sun_taken: bool) -> np.ndarray | None:
    """floor_bounce_sh under the scene's floor (scene_floor, its mean albedo); None without a floor."""
    floor = scene_floor(scene)
    return None if floor is None else floor_bounce_sh(scene.environment, sun_taken, mean_albedo(floor))


def floor_bounce_sh(environment: Environment, sun_taken: bool, albedo: np.ndarray) -> np.ndarray:
    """(9, 3) SH irradiance for diffuse surfaces where a floor of ``albedo`` lies under the scene: the
    environment (its rest when ``sun_taken``) with the light from below the horizon replaced by the open
    floor's radiance, albedo / pi times the whole environment's irradiance on an upward normal (sun included).
    A one-bounce interreflection from an unshadowed, infinite floor: what a box's side sees below the horizon is
    the floor lit by the sky, not the environment's ground. Cached on the environment."""
    def bounced() -> np.ndarray:
        directions, solid_angle = texel_grid(*environment.image.shape[:2])
        up = np.maximum(directions[..., 1], 0.0) * solid_angle
        radiance = albedo / np.pi * np.einsum("hwc,hw->c", environment.image.astype(np.float64), up)
        image = (environment_light(environment).rest.image if sun_taken else environment.image).astype(np.float64)
        return irradiance_sh_of(np.where((directions[..., 1] < 0.0)[..., None], radiance, image))

    key = (array_digest(environment.image), bool(sun_taken), tuple(np.round(albedo, 9)))
    return kept_on(environment, "_floor_cache", key, bounced)


def mean_albedo(obj) -> np.ndarray:
    """An object's mean diffuse albedo per channel: its texture's mean where it shows one, else its colour;
    0 for mirrors and glass."""
    from ..scene.textures import texture_of

    if obj.material.kind != "diffuse":
        return np.zeros(3)
    texture = texture_of(obj)
    return np.asarray(texture, np.float64).reshape(-1, 3).mean(axis=0) if texture is not None else obj.material.color


LOBE_POINTS = 2048  # points on the diffuse surfaces where lobe_occlusion tries the lobes


def lobe_occlusion(scene, count: int = LOBES) -> float:
    """The share of the lobes' irradiance (sun taken out, as the frame does) that other objects block on the
    scene's diffuse surfaces (glass by what it does not transmit, _glass_loss): the mean over LOBE_POINTS area-sampled points of the faces the camera can see (a
    closed mesh's outside, an open sheet's side towards the camera) of sum_k blocked_k cos_k E_k / sum_k cos_k
    E_k, with exact rays (Embree) towards each lobe. Where nothing blocks a
    lobe and the scene has no floor (scene_floor, whose bounce replaces the ground's light), the lobes change
    no pixel: 0 means they would cost a frame for nothing (auto's planner skips them then). Cached on the
    scene by its state and the camera's position."""
    key = (scene_state_key(scene), tuple(o.material.kind for o in scene.objects), int(count),
           np.asarray(scene.camera.position, np.float64).tobytes())
    return kept_on(scene, "_lobe_occlusion_cache", key, lambda: _lobe_occlusion(scene, int(count)))


def _lobe_occlusion(scene, count: int) -> float:
    from ..raytrace.embree_scene import RayScene

    diffuse = [o.world_mesh() for o in scene.objects if o.material.kind == "diffuse"]
    glass = [o for o in scene.objects if o.material.kind == "glass"]
    opaque = [o.world_mesh() for o in scene.objects if o.material.kind != "glass"]
    if not diffuse or not count:
        return 0.0
    lobes = environment_lobes(scene.environment, environment_sun(scene.environment).light is not None, count)
    # Area-sampled points on the diffuse triangles (seeded: the plan is the same every time).
    triangles = np.concatenate([m.vertices[m.faces].astype(np.float64) for m in diffuse])
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    # The faces the camera can see: an open sheet (a floor, a chart) from either side, a closed mesh's outside.
    open_sheet = np.concatenate([np.full(len(m.faces), m.is_open()) for m in diffuse])
    towards = np.einsum("ij,ij->i", cross, scene.camera.position - triangles.mean(axis=1)) > 0.0
    cross = np.where((open_sheet & ~towards)[:, None], -cross, cross)
    area = np.where(open_sheet | towards, np.linalg.norm(cross, axis=1), 0.0)
    if not area.sum() > 0.0:
        return 0.0
    rng = np.random.default_rng(0)
    face = rng.choice(len(triangles), LOBE_POINTS, p=area / area.sum())
    a, b = rng.random((2, LOBE_POINTS))
    a, b = np.where(a + b > 1.0, 1.0 - a, a), np.where(a + b > 1.0, 1.0 - b, b)
    t = triangles[face]
    points = t[:, 0] + a[:, None] * (t[:, 1] - t[:, 0]) + b[:, None] * (t[:, 2] - t[:, 0])
    normals = cross[face] / np.maximum(area[face], 1e-300)[:, None]
    # Each lobe's share at each point, and whether an object stops the ray towards it.
    weight = np.clip(-normals @ lobes.directions.T, 0.0, None) * lobes.irradiance.mean(axis=1)  # (points, lobes)
    lit = weight > 0.0
    rows, cols = np.nonzero(lit)
    size = float(np.linalg.norm(np.ptp(scene.bounds(), axis=0)))
    origins, towards = points[rows] + 1e-5 * size * normals[rows], -lobes.directions[cols]
    blocked = np.zeros_like(weight)
    blocked[rows, cols] = RayScene.from_meshes(opaque).occluded(origins, towards, np.inf, tnear=1e-6 * size)
    if glass:
        blocked[rows, cols] = np.maximum(blocked[rows, cols], _glass_loss(glass, origins, towards, 1e-6 * size))
    total = weight.sum(axis=1)
    share = np.where(total > 0.0, (blocked * weight).sum(axis=1) / np.maximum(total, 1e-300), 0.0)
    return float(share.mean())


def _glass_loss(glass: list, origins: np.ndarray, directions: np.ndarray, tnear: float) -> np.ndarray:
    """Per ray, the share of a lobe's light the first glass object along it takes (the lobes' glass atlas dims
    them so): 1 - (1 - F0)^2 exp(-sigma chord), F0 the normal-incidence reflectance of each of its two
    interfaces, sigma its mean absorption coefficient, chord the ray's path inside (exact, Embree)."""
    from ..raytrace.embree_scene import RayScene
    from ..raytrace.optics import fresnel_dielectric

    rays = RayScene.from_meshes([o.world_mesh() for o in glass])
    entry = rays.intersect(origins, directions, tnear)
    loss = np.zeros(len(origins))
    if not entry.hit.any():
        return loss
    exit_ = rays.intersect(entry.position[entry.hit], directions[entry.hit], tnear)
    index = entry.object_index[entry.hit]
    ior = np.array([o.material.ior_rgb[1] for o in glass])[index]
    sigma = np.array([float(np.mean(o.material.absorption_coefficient)) for o in glass])[index]
    chord = np.where(exit_.hit, exit_.t, 0.0)
    loss[entry.hit] = 1.0 - (1.0 - fresnel_dielectric(1.0, 1.0, ior)) ** 2 * np.exp(-sigma * chord)
    return loss
