"""The environment's light in the raster techniques: its sun as a directional light, the rest as SH.

A small, very bright region of the environment (a sun) lights diffuse surfaces through a sharp shadow and
focuses through glass into a caustic; the unoccluded SH irradiance (Ramamoorthi and Hanrahan 2001) the
raster techniques give diffuse surfaces has neither. So at frame setup the sun is taken out of the
environment as a :class:`~caustica.scene.lights.DirectionalLight` that goes through the same shadow-map and
caustic-map machinery as the scene's lights (``passes/lights.py``: ``light_samples`` appends it, flagged
``environment``), and the diffuse ambient becomes the SH irradiance of the rest. Glass and mirrors still
look the sun up in the environment; users' ``scene.lights`` never see it. docs/environment-light.md.

The bright region is the one ``exact`` samples (:class:`~caustica.raytrace.environment_light.EnvironmentLight`:
texels above ``BRIGHT_RATIO`` times the mean radiance); the split adds up to the original image exactly.
The light's irradiance is the bright part's radiance integrated over solid angle (per channel), its
direction of travel minus the power-weighted mean direction, both estimated from SUN_SAMPLES stratified
samples of ``EnvironmentLight.sample_bright`` (which samples by power, so the estimate is near exact). A
bright part spread wider than SUN_SPREAD degrees (several suns, a window) is no sun: it stays in the SH.

Part 2 (where auto asks for ``environment_lobes``): the rest of the sky as strata of equal power with
shadow maps (passes/lights.py ShadowMaps draws them), glass passing its transmittance, the blocked sky
showing the occluders' bounce, and a floor's bounce for the light from below (docs/environment-light.md).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..cache import LruCache, array_digest, kept_on, material_state_key, scene_state_key
from ..progress import detail
from ..raytrace.environment_light import environment_light, hammersley
from ..scene.environment import Environment, irradiance_sh_of, texel_grid, uv_to_direction
from ..scene.lights import DirectionalLight
from ..render.frame import frame_setting

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
    without its sun where the ``light_samples`` (passes/lights.py) hold the sun, else the whole environment's."""
    for held in (shadows, bake):
        if held is not None and held.ambient_sh is not None:
            return held.ambient_sh
    if any(getattr(s, "environment", False) for s in samples):
        return environment_sun(environment).rest_sh
    return environment.irradiance_sh()


# Part 2: the rest of the environment's light, occluded -------------------------------------------------

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
    unoccluded light stands in for it better than its shadow (measured: docs/environment-light.md)."""
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


# The floor's bounce: the ground's light for diffuse surfaces --------------------------------------------

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


def lobe_settings(params) -> tuple[int, int]:
    """(lobes, texels a side of each map) a frame's parameters ask for: the ``environment_lobes`` and
    ``environment_lobe_size`` attributes auto sets on the planned technique's parameters (on the view's of a
    composite's pair), else (0, LOBE_MAP_SIZE)."""
    count = int(frame_setting(params, "environment_lobes") or 0)
    if not 0 <= count <= MAX_LOBES:
        raise ValueError(f"environment_lobes must be 0 to {MAX_LOBES} (got {count})")
    return count, int(frame_setting(params, "environment_lobe_size") or LOBE_MAP_SIZE)


@dataclass
class EnvironmentShadows:
    """ShadowMaps' ``environment_shadows``: the lobes, their directional samples (passes/lights.py's
    LightSample, one tile each) and the atlas of their opaque objects' distance maps (r32f, K N x N); where
    the scene has glass, the atlas of the glass along each lobe (rgba32f: rgb its optical depth, -log of its
    transmittance per channel, a its nearest distance; passes/glass_optical_depth.frag), else None."""

    atlas: object
    tiles: list
    lobes: EnvironmentLobes
    glass: object = None
    ambient_sh: np.ndarray | None = None  # (9, 3): floor_bounce_sh where the scene has a floor, else None
    bounce: object = None  # rgba32f atlas: per lobe texel, the radiance a receiver behind the occluder sees
    nearest: object = None  # rg32f atlas: per lobe texel, the nearest opaque and glass distance over its taps

    def defines(self) -> dict[str, int]:
        """lighting.glsl's ENVIRONMENT_GLASS and ENVIRONMENT_BOUNCE: 1 where the glass's, the bounce's atlas is
        bound (ShadowMaps always draws the bounce; bench_environment_light measures without it)."""
        return {"ENVIRONMENT_GLASS": int(self.glass is not None), "ENVIRONMENT_BOUNCE": int(self.bounce is not None)}


def bind_environment_shadows(program, shadows: EnvironmentShadows, unit: int) -> None:
    """Set lighting.glsl's env_lobe_* uniforms and bind the atlas to texture unit ``unit`` (the glass's,
    where there is one, to ``unit`` + 1, the bounce atlas to ``unit`` + 2, the nearest distances' to + 3)."""
    from ..gpu.meshes import set_uniform, write_uniform_array

    count = len(shadows.tiles)
    rows = {"env_lobe_origin": [t.position for t in shadows.tiles],
            "env_lobe_direction": [t.direction for t in shadows.tiles],
            "env_lobe_irradiance": shadows.lobes.irradiance,
            "env_lobe_span": np.repeat(shadows.lobes.span[:, None], 3, axis=1)}
    for name, values in rows.items():
        padded = np.zeros((MAX_LOBES, 3), "f4")
        padded[:count] = values
        write_uniform_array(program, name, padded)
    clips = np.tile(np.eye(4, dtype="f4"), (MAX_LOBES, 1, 1))
    clips[:count] = [t.clip_from_world for t in shadows.tiles]
    write_uniform_array(program, "env_lobe_clip_from_world", np.ascontiguousarray(clips.transpose(0, 2, 1)))
    set_uniform(program, "env_lobe_count", count)
    shadows.atlas.use(unit)
    set_uniform(program, "env_shadow_atlas", unit)
    if shadows.bounce is not None:
        shadows.bounce.use(unit + 2)
        set_uniform(program, "env_bounce_atlas", unit + 2)
    shadows.nearest.use(unit + 3)
    set_uniform(program, "env_nearest_atlas", unit + 3)
    if shadows.glass is not None:
        shadows.glass.use(unit + 1)
        set_uniform(program, "env_glass_atlas", unit + 1)


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


# The light maps: the ambient environment's light on the diffuse receivers, baked with exact's rays -----------

MAX_BAKE_SIZE = 1024  # texels a side of the floor's light map, at most
ATLAS_WIDTH = 1024  # texels a row of the bake's atlas at least (the vertices' rows)
TABLE_TEXELS = 5  # texels a rectangle takes in the atlas's table (rectangle_rows: origin and slack, u', v', normal, tile)
MAX_OBJECT_RECTS = 6  # lighting.glsl's: the rectangles of one object (a box's faces) set as its uniforms

_BAKES = LruCache(4)  # the bakes of the scenes rendered last (not the camera: a move bakes nothing)


@dataclass(frozen=True)
class Receiver:
    """How one diffuse object's share of the environment's light is baked (bake_plan): ``kind`` "floor" (its
    top face), "box" (its six faces), "plane" (both sides of the rectangle of its plane, shared with the
    coplanar objects of ``group``) or "vertices" (per vertex, ``baked`` of its ``vertices`` where capped)."""

    kind: str
    group: int = -1  # "plane": the index of its plane among bake_plan's groups
    vertices: int = 0  # "vertices": the mesh's
    baked: int = 0  # "vertices": how many are baked (the others interpolated), at most VERTEX_CAP


@dataclass(frozen=True)
class BakePlan:
    """Per scene object its :class:`Receiver` (None: not diffuse, nothing to bake), the floor (or None) and the
    coplanar groups of flat objects (lists of scene object indices)."""

    receivers: tuple
    floor: object
    planes: tuple


def bake_plan(scene) -> BakePlan:
    """What :func:`scene_bake` bakes for ``scene`` (docs/environment-light.md, "Light maps on every diffuse
    receiver"): the floor's top (scene_floor), the faces of box-shaped objects (box_faces), the rectangle of each
    plane holding flat objects (plane_of: walls, backdrops, a chart's squares, coplanar ones sharing it), the
    vertices of every other diffuse mesh (capped at VERTEX_CAP). Cached on the scene by its state."""
    return kept_on(scene, "_bake_plan_cache", (scene_state_key(scene), tuple(o.material.kind for o in scene.objects)),
                   lambda: _bake_plan(scene))


def _bake_plan(scene) -> BakePlan:
    from ..raytrace.environment_bake import VERTEX_CAP, _spread, box_faces, plane_of
    from .impostors import same_plane

    floor = scene_floor(scene)
    size = float(np.linalg.norm(np.ptp(scene.bounds(), axis=0))) if scene.objects else 1.0
    receivers, planes, plane_keys = [], [], []
    for index, obj in enumerate(scene.objects):
        if obj.material.kind != "diffuse":
            receivers.append(None)
        elif obj is floor:
            receivers.append(Receiver("floor"))
        elif box_faces(obj) is not None:
            receivers.append(Receiver("box"))
        elif (flat := plane_of(obj)) is not None:
            group = next((k for k, known in enumerate(plane_keys) if same_plane(flat, known, 1e-4 * size)), None)
            if group is None:
                group = len(planes)
                planes.append([])
                plane_keys.append(flat)
            planes[group].append(index)
            receivers.append(Receiver("plane", group))
        else:
            mesh = obj.world_mesh()
            count = len(mesh.vertices)
            baked = count if count <= VERTEX_CAP else len(_spread(mesh.vertices.astype(np.float64),
                                                                  mesh.normals.astype(np.float64), VERTEX_CAP))
            receivers.append(Receiver("vertices", vertices=count, baked=baked))
    return BakePlan(tuple(receivers), floor, tuple(tuple(g) for g in planes))


@dataclass(frozen=True)
class SceneBake:
    """The bake of a scene state (:func:`scene_bake`): the LightMaps (raytrace/environment_bake.py: the floor's
    top first where there is one, then each box's six faces, then each plane's two sides), per scene object the
    range of its maps (first, count; (0, 0) for none) and its per-vertex irradiance ((vertices, 3) or None), and
    the seconds the bake took."""

    maps: list
    ranges: tuple
    vertices: tuple
    seconds: float


def bake_settings(params) -> int:
    """Texels a side of the floor's light map the frame's parameters ask for (``environment_bake``, which auto
    sets on the planned technique's parameters); 0: none."""
    size = int(frame_setting(params, "environment_bake") or 0)
    if not 0 <= size <= MAX_BAKE_SIZE:
        raise ValueError(f"environment_bake must be 0 to {MAX_BAKE_SIZE} texels (got {size})")
    return size


def scene_bake(scene, sun_taken: bool, size: int, samples: int | None = None) -> SceneBake:
    """The :class:`SceneBake` of every diffuse receiver of ``scene`` (bake_plan) under the ambient environment
    (without its sun where ``sun_taken``): the floor's top ``size`` texels a side, box faces FACE_SIZE, a plane's
    rectangle ``size`` along its longer side where it spans the scene (in proportion, FACE_SIZE at least,
    otherwise), VERTEX_CAP vertices of a mesh at most; kept for the next frame of the same geometry, materials
    and environment."""
    from ..raytrace.environment_bake import BAKE_SAMPLES

    samples = BAKE_SAMPLES if samples is None else samples
    key = (scene_state_key(scene), material_state_key(scene), bool(sun_taken), int(size), int(samples))
    bake = _BAKES.get(key)
    if bake is None:
        bake = _BAKES[key] = _scene_bake(scene, sun_taken, int(size), int(samples))
    return bake


def _scene_bake(scene, sun_taken: bool, size: int, samples: int) -> SceneBake:
    import time

    from ..raytrace.environment_bake import (FACE_SIZE, bake_floor, bake_rectangles, bake_vertices, box_faces,
                                             plane_of, plane_rectangle)

    start = time.perf_counter()
    plan = bake_plan(scene)
    sun = environment_sun(scene.environment).light if sun_taken else None
    ambient = environment_light(scene.environment).rest if sun_taken else scene.environment
    objects = scene.objects
    maps, ranges, vertices = [], [(0, 0)] * len(objects), [None] * len(objects)
    if plan.floor is not None:
        maps.append(bake_floor(scene, plan.floor, ambient, sun, size, samples))
        ranges[next(i for i, o in enumerate(objects) if o is plan.floor)] = (0, 1)
    boxes = [i for i, r in enumerate(plan.receivers) if r is not None and r.kind == "box"]
    if boxes:
        faces = [face for i in boxes for face in box_faces(objects[i])]
        label = ", ".join(objects[i].name for i in boxes)
        for k, i in enumerate(boxes):
            ranges[i] = (len(maps) + 6 * k, 6)
        maps += bake_rectangles(scene, faces, (FACE_SIZE, FACE_SIZE), ambient, sun, samples, label)
    extent = float(np.ptp(scene.bounds(), axis=0).max())
    for group in plan.planes:
        members = [objects[i] for i in group]
        origin, u, v, normal = plane_rectangle(members, *plane_of(members[0]))
        lengths = np.array([np.linalg.norm(u), np.linalg.norm(v)])
        columns, rows = np.maximum(np.round(min(size, max(FACE_SIZE, size * lengths.max() / extent))
                                            * lengths / lengths.max()), 1).astype(int)
        sides = [(origin, u, v, normal), (origin, u, v, -normal)]
        for i in group:
            ranges[i] = (len(maps), 2)
        maps += bake_rectangles(scene, sides, (int(columns), int(rows)), ambient, sun, samples,
                                ", ".join(o.name for o in members))
    for i, receiver in enumerate(plan.receivers):
        if receiver is not None and receiver.kind == "vertices":
            vertices[i] = bake_vertices(scene, objects[i], ambient, sun, samples)[0]
    seconds = time.perf_counter() - start
    texels = sum(m.irradiance.shape[0] * m.irradiance.shape[1] for m in maps)
    points = sum(r.baked for r in plan.receivers if r is not None and r.kind == "vertices")
    detail(f"the environment's light baked in {seconds:.1f} s: {len(maps)} light maps ({texels} texels) and "
           f"{points} vertices, {samples} rays each")
    return SceneBake(maps, tuple(ranges), tuple(vertices), seconds)


def light_maps(scene, sun_taken: bool, size: int, samples: int | None = None) -> list:
    """The LightMaps of :func:`scene_bake` (the floor's top first where the scene has a floor)."""
    return scene_bake(scene, sun_taken, size, samples).maps


@dataclass
class EnvironmentBake:
    """ShadowMaps' ``environment_bake``: the scene's bake (:class:`SceneBake`) in one rgba32f ``texture`` (the
    maps' ``tiles``, x0, y0, columns, rows in texels each; below them the rectangles' table from row
    ``table_row``, rectangle_rows, TABLE_TEXELS a row; below that the vertices' irradiance from row ``vertex_row``,
    row-major),
    per scene object (in the scene's order) its maps' range and its vertices' first index in that region (-1:
    none), and the SH ambient of every other diffuse surface (floor_bounce_sh where there is a floor, else None)."""

    texture: object
    maps: list
    tiles: np.ndarray
    ambient_sh: np.ndarray | None
    table_row: int = 0
    vertex_row: int = 0
    objects: tuple = ()  # per scene object: (first map, map count, first vertex or -1)
    by_id: tuple = ()  # (id(scene object), its entry) of the scene the bake was made for
    rectangles: np.ndarray | None = None  # rectangle_rows of the maps: what bind_baked_object gives an object
    _uniforms: dict = field(default_factory=dict, repr=False)  # id(object) -> object_uniforms

    @property
    def has_vertices(self) -> bool:
        return any(entry[2] >= 0 for entry in self.objects)

    def pooled(self) -> list:
        """Its one GL object, the atlas (gpu.device.gl_objects: the graph looks for lent textures in every live
        channel after every pass, and the rest of this bake is host data it need not walk)."""
        return [self.texture]

    def entry(self, scene, obj) -> tuple[int, int, int]:
        """``obj``'s (first map, map count, first vertex or -1) by its place in ``scene`` (the frame's, whose
        state the bake's is: ShadowMaps' cache key) or in a part of it (a view without some objects)."""
        index = next((i for i, o in enumerate(scene.objects) if o is obj), None)
        if index is not None and len(scene.objects) == len(self.objects):
            return self.objects[index]
        return dict(self.by_id).get(id(obj), (0, 0, -1))

    def object_uniforms(self, scene, obj) -> tuple[np.ndarray, int, int]:
        """(env_bake_rect's rows, env_bake_rect_count, env_bake_vertex_first) of ``obj`` (bind_baked_object),
        worked out once per object: a frame binds them at every draw of every pass."""
        kept = self._uniforms.get(id(obj))
        if kept is None:
            first, count, vertex = self.entry(scene, obj)
            if count > MAX_OBJECT_RECTS:
                raise ValueError(f"an object has {count} light maps; lighting.glsl takes {MAX_OBJECT_RECTS}")
            rows = np.zeros((MAX_OBJECT_RECTS * TABLE_TEXELS, 4), np.float32)
            rows[:count * TABLE_TEXELS] = self.rectangles[first:first + count].reshape(-1, 4)
            kept = self._uniforms[id(obj)] = (rows, count, vertex)
        return kept


def rectangle_rows(maps: list, tiles: np.ndarray) -> np.ndarray:
    """(maps, TABLE_TEXELS, 4) float32: per light map (origin, slack: how far off its plane a point may lie), (u /
    |u|^2, 0), (v / |v|^2, 0), (normal, 0), (its tile: x0, y0, columns, rows): lighting.glsl's rectangle, as the
    atlas's table holds it and as an object's uniforms give it."""
    rows = np.zeros((len(maps), TABLE_TEXELS, 4), np.float32)
    for k, (light_map, tile) in enumerate(zip(maps, tiles)):
        u, v = light_map.u, light_map.v
        rows[k, 0] = (*light_map.origin, 1e-3 * min(np.linalg.norm(u), np.linalg.norm(v)))
        rows[k, 1, :3], rows[k, 2, :3] = u / max(float(u @ u), 1e-300), v / max(float(v @ v), 1e-300)
        rows[k, 3, :3], rows[k, 4] = light_map.normal, tile
    return rows


def bake_atlas(bake: SceneBake) -> tuple[np.ndarray, np.ndarray, int, int, tuple, np.ndarray]:
    """(image, rectangle_rows, table_row, vertex_row, per-object entries, tiles) of :class:`EnvironmentBake`'s
    rgba32f texture."""
    tiles, (width, height) = atlas_tiles(bake.maps) if bake.maps else (np.zeros((0, 4), np.int64), (0, 0))
    width = max(width, ATLAS_WIDTH)
    table_row, vertex_row = height, height + len(bake.maps)
    firsts, total = [], 0
    for values in bake.vertices:
        firsts.append(-1 if values is None else total)
        total += 0 if values is None else len(values)
    image = np.zeros((vertex_row + -(-total // width), width, 4), np.float32)
    image[:height, :, :3] = atlas_image(bake.maps, tiles, (width, height)) if bake.maps else 0.0
    rectangles = rectangle_rows(bake.maps, tiles)
    image[table_row:vertex_row, :TABLE_TEXELS] = rectangles
    flat = image[vertex_row:].reshape(-1, 4)
    for first, values in zip(firsts, bake.vertices):
        if values is not None:
            flat[first:first + len(values), :3] = values
    entries = tuple((*bake.ranges[i], firsts[i]) for i in range(len(firsts)))
    return image, rectangles, table_row, vertex_row, entries, tiles


def atlas_tiles(maps: list) -> tuple[np.ndarray, tuple[int, int]]:
    """(tiles, (width, height)): where each map lies in one atlas, (x0, y0, columns, rows) in texels: the first
    at the left, the others in columns to its right, top to bottom."""
    first_rows, first_columns = maps[0].irradiance.shape[:2]
    height = max([first_rows] + [m.irradiance.shape[0] for m in maps[1:]])
    tiles, x, y, column_width = [(0, 0, first_columns, first_rows)], first_columns, 0, 0
    for light_map in maps[1:]:
        rows, columns = light_map.irradiance.shape[:2]
        if y + rows > height:
            x, y, column_width = x + column_width, 0, 0
        tiles.append((x, y, columns, rows))
        y, column_width = y + rows, max(column_width, columns)
    return np.array(tiles, np.int64), (x + column_width, height)


def atlas_image(maps: list, tiles: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(height, width, 3) float32: the maps placed at their tiles."""
    image = np.zeros((shape[1], shape[0], 3), np.float32)
    for light_map, (x0, y0, columns, rows) in zip(maps, tiles):
        image[y0:y0 + rows, x0:x0 + columns] = light_map.irradiance
    return image


def bind_environment_bake(program, baked: EnvironmentBake, unit: int) -> None:
    """Set lighting.glsl's env_bake_layout and bind the bake's atlas to texture unit ``unit``."""
    from ..gpu.meshes import set_uniform

    set_uniform(program, "env_bake_layout", (baked.table_row, len(baked.maps), baked.vertex_row, 0))
    baked.texture.use(unit)
    set_uniform(program, "env_bake", unit)


def bind_baked_object(program, baked: EnvironmentBake, scene, obj) -> None:
    """Set lighting.glsl's per-object rectangles (env_bake_rect, its rectangle_rows, and env_bake_rect_count) and
    env_bake_vertex_first (-1: none)."""
    from ..gpu.meshes import set_uniform, write_uniform_array

    rows, count, vertex = baked.object_uniforms(scene, obj)
    write_uniform_array(program, "env_bake_rect", rows)
    set_uniform(program, "env_bake_rect_count", count)
    set_uniform(program, "env_bake_vertex_first", vertex)
