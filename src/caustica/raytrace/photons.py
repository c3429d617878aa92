"""Exact photon tracing: the caustics oracle.

:func:`trace_photons` shoots photons from the scene's lights towards the
specular objects (glass and mirrors), follows them wavefront style through
every specular interaction with Embree, and records where they land on a
diffuse surface *after at least one* specular interaction: those hits are the
caustic. Photons that reach a diffuse surface directly are direct light and
are dropped (the renderer's shadow-mapped direct light covers them).

Emission (importance: only photons aimed at specular objects can make a
caustic). The target is the bounding sphere (centre c, radius r) of the
specular objects, or what ``target`` names.

- Point light at distance L from c: directions uniform over the cone of half
  angle asin(r / L) (the whole sphere when the light is inside), solid angle
  Omega = 2 pi (1 - cos theta_max); each photon carries I Omega / count.
- Spot light: the same, times the spot falloff of the photon's direction.
- Line light: its point samples, each a point light with its share of the
  intensity (the renderer's model of a line light).
- Directional light of irradiance E: origins uniform over the disc of radius r
  perpendicular to the light, centred on c and moved back out of the scene;
  each photon carries E pi r^2 / count.
- The environment's bright part (``environment``, an
  :class:`~caustica.raytrace.environment_light.EnvironmentLight`): each photon is a directional light
  from a direction drawn by the bright part's power (pdf p), over the same disc; it carries
  L / p pi r^2 / count, L the bright radiance from there.

Photon counts are shared between emitters in proportion to the flux each sends
towards the target, so that every photon carries about the same flux.

Transport, per photon (the conventions of :mod:`caustica.raytrace.paths`):

- Glass, ``branches="split"`` (default): the photon splits deterministically
  into the reflected branch (flux times F) and the refracted one (times 1 - F);
  total internal reflection reflects everything. ``branches="transmit"``
  keeps only the refracted branch times 1 - F (TIR still reflects), the
  ``(1 - F1)(1 - F2)`` model of most real-time caustic techniques.
- Dispersive glass (an Abbe number: per-channel IOR) is traced once per RGB
  channel with that channel's IOR; each pass carries one channel's flux.
- Beer-Lambert: flux times exp(-sigma_a t) for every segment inside glass.
- Mirrors reflect times their colour.
- ``max_depth`` bounds the specular interactions of a path; branches alive
  past it, or whose largest channel falls below ``min_weight`` times the
  photon's emitted flux, are dropped and their flux counted in the stats.

Estimators: :func:`irradiance_histogram` bins the hits on a planar receiver
(flux per bin over the bin area, W/m^2), :func:`irradiance_on_pixels` per
camera pixel over the receiver area each pixel covers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..scene.codes import MATERIAL_DIFFUSE, MATERIAL_GLASS, MATERIAL_MIRROR
from ..scene.lights import DirectionalLight, SpotLight
from .embree_scene import ray_scene_for, world_sphere
from .environment_light import tangent_frame
from .optics import dot, normalize
from .paths import Materials, facing, interface, reflect_above

CHUNK_PHOTONS = 1 << 18


@dataclass
class PhotonHits:
    """Caustic photons on diffuse receivers, and where the rest of the emitted flux went.

    ``flux`` is in watts (RGB); the fluxes of :attr:`emitted` split into the
    caustic hits, :attr:`direct` (photons that reached a diffuse surface with no
    specular interaction), :attr:`escaped` (left the scene), :attr:`dropped`
    (cut by ``max_depth`` or ``min_weight``), and what glass absorption and
    mirror colours took.
    """

    position: np.ndarray  # (N,3) float64 hit point
    flux: np.ndarray  # (N,3) float64 watts per channel
    object_index: np.ndarray  # (N,) int32 receiver index into scene.objects
    normal: np.ndarray  # (N,3) receiver shading normal, facing the side the photon came from
    direction: np.ndarray  # (N,3) photon direction of travel at the hit
    bounces: np.ndarray  # (N,) int: specular interactions on the photon's path
    photons: int = 0  # photons emitted (per channel pass)
    emitted: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,) W sent towards the target
    direct: np.ndarray = field(default_factory=lambda: np.zeros(3))
    escaped: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dropped: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __len__(self) -> int:
        return len(self.position)

    @property
    def total_flux(self) -> np.ndarray:
        """(3,) caustic flux summed over every hit, in watts."""
        return self.flux.sum(axis=0)

    def select(self, mask: np.ndarray) -> PhotonHits:
        """The hits where ``mask`` is True (the flux stats are kept)."""
        return replace(self, position=self.position[mask], flux=self.flux[mask], object_index=self.object_index[mask],
                       normal=self.normal[mask], direction=self.direction[mask], bounces=self.bounces[mask])

    def on(self, object_index: int) -> PhotonHits:
        """The hits on one receiver."""
        return self.select(self.object_index == object_index)


@dataclass
class _Emitter:
    """One point-like or parallel source of photons, aimed at the target sphere."""

    light: object
    position: np.ndarray | None  # None for a directional light
    intensity: np.ndarray  # (3,) W/sr, or W/m^2 for a directional light
    center: np.ndarray
    radius: float
    scene_radius: float  # a distance from the target that leaves the scene

    @property
    def cos_max(self) -> float:
        """Cosine of the half angle of the emission cone (-1: every direction)."""
        distance = float(np.linalg.norm(self.center - self.position))
        if distance <= self.radius * (1.0 + 1e-9):
            return -1.0
        return math.sqrt(max(0.0, 1.0 - (self.radius / distance) ** 2))

    @property
    def measure(self) -> float:
        """Solid angle of the cone (point-like) or area of the disc (directional)."""
        if self.position is None:
            return math.pi * self.radius**2
        return 2.0 * math.pi * (1.0 - self.cos_max)

    @property
    def power(self) -> float:
        """Flux (mean over channels) sent towards the target, an upper bound for spots."""
        return float(np.mean(self.intensity)) * self.measure

    def emit(self, n: int, rng: np.random.Generator, count: int):
        """Origins, unit directions and flux (n,3) of ``n`` of ``count`` photons."""
        u1, u2 = rng.random(n), rng.random(n)
        phi = 2.0 * np.pi * u2
        if self.position is None:
            axis = self.light.direction
            e1, e2 = _frame(axis)
            rho = self.radius * np.sqrt(u1)
            offset = (rho * np.cos(phi))[:, None] * e1 + (rho * np.sin(phi))[:, None] * e2
            origins = self.center + offset - (self.scene_radius + self.radius) * axis
            dirs = np.broadcast_to(axis, (n, 3)).copy()
            falloff = np.ones(n)
        else:
            axis = normalize(self.center - self.position)
            e1, e2 = _frame(axis)
            cos = 1.0 - u1 * (1.0 - self.cos_max)
            sin = np.sqrt(np.maximum(0.0, 1.0 - cos * cos))
            dirs = (sin * np.cos(phi))[:, None] * e1 + (sin * np.sin(phi))[:, None] * e2 + cos[:, None] * axis
            dirs = normalize(dirs)
            origins = np.broadcast_to(self.position, (n, 3)).copy()
            falloff = np.ones(n)
            if isinstance(self.light, SpotLight):
                falloff = self.light.falloff(dirs @ self.light.direction)
        flux = falloff[:, None] * (self.intensity * self.measure / count)[None, :]
        return origins, dirs, flux


@dataclass
class _EnvironmentEmitter:
    """The environment's bright part as photons: a directional light per photon, from a direction drawn
    by the bright part's power."""

    light: object  # an EnvironmentLight with a bright part
    center: np.ndarray
    radius: float
    scene_radius: float

    @property
    def power(self) -> float:
        return self.light.bright_power() * math.pi * self.radius**2

    def emit(self, n: int, rng: np.random.Generator, count: int):
        """Origins, unit directions and flux (n,3) of ``n`` of ``count`` photons."""
        towards, radiance, pdf = self.light.sample_bright(rng.random((n, 2)))
        u1, phi = rng.random(n), 2.0 * np.pi * rng.random(n)
        e1, e2 = tangent_frame(towards)
        rho = self.radius * np.sqrt(u1)
        offset = (rho * np.cos(phi))[:, None] * e1 + (rho * np.sin(phi))[:, None] * e2
        origins = self.center + offset + (self.scene_radius + self.radius) * towards
        flux = radiance / pdf[:, None] * (math.pi * self.radius**2 / count)
        return origins, -towards, flux


def _frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing ``axis`` to an orthonormal frame."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = normalize(np.cross(axis, helper))
    return e1, np.cross(axis, e1)


def _object_sphere(obj) -> tuple[np.ndarray, float]:
    """A bounding sphere of one object in world space (the exact one for analytic spheres)."""
    sphere = world_sphere(obj.mesh, obj.world_from_object())
    if sphere is not None:
        return sphere
    vertices = obj.world_mesh().vertices.astype(np.float64)
    center = (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
    return center, float(np.linalg.norm(vertices - center, axis=1).max())


def _enclosing_sphere(spheres) -> tuple[np.ndarray, float]:
    """A sphere around every (center, radius): centred on their bounding box."""
    lo = np.min([c - r for c, r in spheres], axis=0)
    hi = np.max([c + r for c, r in spheres], axis=0)
    center = (lo + hi) / 2.0
    return center, max(float(np.linalg.norm(c - center)) + r for c, r in spheres)


def target_sphere(scene, target=None) -> tuple[np.ndarray, float] | None:
    """The (center, radius) photons are aimed at; None when there is nothing to aim at.

    ``target`` is None (every glass and mirror object), a ``(center, radius)``
    pair, or a list of object names or indices.
    """
    if target is not None and len(target) == 2 and np.size(target[0]) == 3 and np.ndim(target[1]) == 0:
        return np.asarray(target[0], dtype=np.float64), float(target[1])
    if target is None:
        objects = [o for o in scene.objects if o.material.kind in ("glass", "mirror")]
    else:
        names = {o.name: i for i, o in enumerate(scene.objects)}
        try:
            objects = [scene.objects[names[t] if isinstance(t, str) else int(t)] for t in target]
        except (KeyError, IndexError) as exc:
            raise ValueError(f"photon target {exc} is not an object of the scene") from None
    if not objects:
        return None
    return _enclosing_sphere([_object_sphere(o) for o in objects])


def _emitters(scene, light_index, target, environment=None) -> list:
    sphere = target_sphere(scene, target)
    if sphere is None:
        return []
    center, radius = sphere
    lo, hi = scene.bounds()
    scene_radius = float(np.linalg.norm(hi - lo) + np.linalg.norm(center - (lo + hi) / 2.0))  # reaches out of the scene
    lights = scene.lights if light_index is None else [scene.lights[light_index]]
    out = []
    for light in lights:
        if isinstance(light, DirectionalLight):
            out.append(_Emitter(light, None, light.intensity, center, radius, scene_radius))
        else:
            for position, intensity in light.point_samples():
                out.append(_Emitter(light, np.asarray(position, np.float64), intensity, center, radius, scene_radius))
    if environment is not None and environment.has_bright:
        out.append(_EnvironmentEmitter(environment, center, radius, scene_radius))
    return [e for e in out if e.power > 0]


def _split_count(count: int, powers: list[float]) -> list[int]:
    """Photon counts proportional to ``powers`` that sum to ``count`` (each at least 1)."""
    weights = np.asarray(powers) / np.sum(powers)
    counts = np.maximum(1, np.floor(weights * count).astype(np.int64))
    counts[np.argmax(weights)] += max(0, count - int(counts.sum()))
    return [int(c) for c in counts]


class _Tally:
    """Hits and flux bookkeeping gathered over chunks and passes."""

    def __init__(self):
        self.parts = []
        self.direct, self.escaped, self.dropped = np.zeros(3), np.zeros(3), np.zeros(3)


def trace_photons(scene, light_index: int | None = None, count: int = 1_000_000, seed: int = 0, max_depth: int = 8,
                  target=None, branches: str = "split", min_weight: float = 1e-4,
                  chunk: int = CHUNK_PHOTONS, environment=None) -> PhotonHits:
    """Trace ``count`` photons (per channel pass) from the lights and return their caustic hits.

    ``light_index`` picks one light (default: all, sharing ``count`` by flux). ``environment`` (an
    :class:`~caustica.raytrace.environment_light.EnvironmentLight`) adds its bright part as an emitter;
    with ``light_index`` given the photons come from that light only, else they share ``count`` by flux.
    ``target`` overrides what photons are aimed at (see :func:`target_sphere`).
    ``branches`` is ``"split"`` or ``"transmit"`` (see the module docstring).
    """
    if branches not in ("split", "transmit"):
        raise ValueError(f"branches '{branches}' must be 'split' or 'transmit'")
    if count < 1:
        raise ValueError(f"photon count {count} must be at least 1")
    emitters = _emitters(scene, light_index, target, environment if light_index is None else None)
    tally = _Tally()
    emitted = np.zeros(3)
    if emitters:
        ray_scene = ray_scene_for(scene)
        # Skip the surface a ray leaves with an offset of the specular objects' scale, not the scene's
        # (a large floor would make the default one skip short chords near a sphere's rim).
        center, radius = emitters[0].center, emitters[0].radius
        tnear = min(ray_scene.epsilon, 1e-5 * (radius + float(np.abs(center).max())))
        materials = Materials.of(scene)
        if materials.dispersive:
            passes = [(materials.ior_rgb[:, c], np.eye(3)[c]) for c in range(3)]
        else:
            passes = [(materials.ior_rgb[:, 0], np.ones(3))]
        counts = _split_count(count, [e.power for e in emitters])
        for e_index, (emitter, n) in enumerate(zip(emitters, counts)):
            for start in range(0, n, chunk):
                size = min(chunk, n - start)
                rng = np.random.default_rng([seed, e_index, start])
                o, d, flux = emitter.emit(size, rng, n)
                for ior, channel in passes:
                    emitted += (flux * channel).sum(axis=0)
                    _trace_chunk(ray_scene, materials, ior, o, d, flux * channel, max_depth, branches,
                                 min_weight, tnear, tally)
    if tally.parts:
        columns = [np.concatenate(c) for c in zip(*tally.parts)]
    else:
        columns = [np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int32), np.zeros((0, 3)), np.zeros((0, 3)),
                   np.zeros(0, np.int64)]
    return PhotonHits(*columns, photons=int(count) if emitters else 0, emitted=emitted, direct=tally.direct,
                      escaped=tally.escaped, dropped=tally.dropped)


def _trace_chunk(ray_scene, materials, ior, o, d, flux, max_depth, branches, min_weight, tnear, tally: _Tally) -> None:
    """The wavefront loop over one chunk of photons, one IOR per object."""
    reference = flux.max(axis=1)  # emitted flux, for the min_weight cut
    medium = np.full(len(o), -1, np.int64)  # glass object the photon travels in, -1 for air
    for depth in range(max_depth + 1):
        if len(o) == 0:
            break
        hits = ray_scene.intersect(o, d, tnear)
        # Attenuate segments inside glass (Beer-Lambert).
        inside = (medium >= 0) & hits.hit
        if inside.any():
            flux[inside] *= np.exp(-materials.sigma[medium[inside]] * hits.t[inside, None])
        tally.escaped += flux[~hits.hit].sum(axis=0)
        kind = materials.kind[hits.object_index]
        # Diffuse receivers end the path: a caustic hit after a specular interaction, else direct light.
        diffuse = kind == MATERIAL_DIFFUSE
        if diffuse.any():
            if depth == 0:
                tally.direct += flux[diffuse].sum(axis=0)
            else:
                _, ns, _ = facing(d[diffuse], hits.normal[diffuse], hits.geometric_normal[diffuse])
                tally.parts.append((hits.position[diffuse], flux[diffuse], hits.object_index[diffuse], ns,
                                    d[diffuse], np.full(int(diffuse.sum()), depth, np.int64)))
        specular = (kind == MATERIAL_MIRROR) | (kind == MATERIAL_GLASS)
        if depth == max_depth:
            tally.dropped += flux[specular].sum(axis=0)
            break
        # Spawn the children of mirror and glass hits.
        children = []  # (origin, direction, flux, medium, reference)
        mirror = kind == MATERIAL_MIRROR
        if mirror.any():
            _, ns, ng = facing(d[mirror], hits.normal[mirror], hits.geometric_normal[mirror])
            r = reflect_above(d[mirror], ns, ng)
            color = materials.color[hits.object_index[mirror]]
            children.append((hits.position[mirror], r, flux[mirror] * color, medium[mirror], reference[mirror]))
        glass = kind == MATERIAL_GLASS
        if glass.any():
            obj = hits.object_index[glass]
            it = interface(d[glass], hits.normal[glass], hits.geometric_normal[glass], ior[obj])
            p, w, f, ref = hits.position[glass], flux[glass], it.reflectance[:, None], reference[glass]
            if branches == "split":
                children.append((p, it.reflected, w * f, medium[glass], ref))
            else:
                # Only TIR reflects; the externally or partially reflected flux is dropped.
                tir = it.tir
                tally.dropped += (w * f)[~tir].sum(axis=0)
                children.append((p[tir], it.reflected[tir], w[tir], medium[glass][tir], ref[tir]))
            tr = ~it.tir
            new_medium = np.where(it.entering, obj, -1)[tr]
            children.append((p[tr], it.refracted[tr], (w * (1.0 - f))[tr], new_medium, ref[tr]))
        if not children:
            break
        o, d, flux, medium, reference = (np.concatenate(parts) for parts in zip(*children))
        # Drop faint branches.
        faint = flux.max(axis=1) < min_weight * reference
        if faint.any():
            tally.dropped += flux[faint].sum(axis=0)
            keep = ~faint
            o, d, flux, medium, reference = o[keep], d[keep], flux[keep], medium[keep], reference[keep]


# Estimators --------------------------------------------------------------------


def irradiance_histogram(hits: PhotonHits, plane_origin, plane_u, plane_v, extent, resolution,
                         tolerance: float | None = None, receiver: int | None = None) -> np.ndarray:
    """Caustic irradiance (W/m^2) on a planar receiver, (rows, cols, 3).

    The square (or ``extent`` = (width along u, height along v)) is centred on
    ``plane_origin`` and spanned by the unit axes ``plane_u`` and ``plane_v``;
    ``resolution`` is one count or (cols, rows). ``out[j, i]`` is the bin at
    u = (i + 0.5) / cols - 1/2 of the width, v the same with j (row 0 at -v).
    Hits farther than ``tolerance`` (default 1e-3 of the extent) from the plane,
    or on another object than ``receiver`` when given, are left out.
    """
    origin = np.asarray(plane_origin, dtype=np.float64)
    u, v = normalize(np.asarray(plane_u, dtype=np.float64)), normalize(np.asarray(plane_v, dtype=np.float64))
    width, height = np.broadcast_to(np.asarray(extent, dtype=np.float64), (2,))
    cols, rows = np.broadcast_to(np.asarray(resolution, dtype=np.int64), (2,))
    tolerance = 1e-3 * max(width, height) if tolerance is None else float(tolerance)
    rel = hits.position - origin
    a, b = rel @ u, rel @ v
    keep = np.abs(rel @ normalize(np.cross(u, v))) <= tolerance
    if receiver is not None:
        keep &= hits.object_index == receiver
    i = np.floor((a / width + 0.5) * cols).astype(np.int64)
    j = np.floor((b / height + 0.5) * rows).astype(np.int64)
    keep &= (i >= 0) & (i < cols) & (j >= 0) & (j < rows)
    flat = j[keep] * cols + i[keep]
    out = np.stack([np.bincount(flat, weights=hits.flux[keep, c], minlength=rows * cols) for c in range(3)], axis=-1)
    bin_area = (width / cols) * (height / rows)
    return out.reshape(rows, cols, 3) / bin_area


def _camera_rays(camera, px: np.ndarray, py: np.ndarray) -> np.ndarray:
    """Unit world directions through image points (px, py) in pixels (0 = left/top edge)."""
    width, height = camera.size
    tan_half = math.tan(math.radians(camera.fov_y) / 2.0)
    x_view = (2.0 * px / width - 1.0) * tan_half * camera.aspect
    y_view = (1.0 - 2.0 * py / height) * tan_half
    d_view = np.stack([x_view, y_view, -np.ones_like(x_view)], axis=-1)
    return normalize(d_view @ np.linalg.inv(camera.view_from_world())[:3, :3].T)


def pixel_receiver_area(scene, camera=None) -> tuple[np.ndarray, np.ndarray]:
    """Area (H, W) of surface each pixel sees, and the object index (H, W) at its centre (-1: none).

    The area is the quad spanned by the primary-ray hits of the pixel's four
    corners when they all land on the centre's object (two triangles); where
    they do not (silhouettes), the differential footprint
    d_omega t^2 / |cos theta| of the centre hit.
    """
    camera = scene.camera if camera is None else camera
    width, height = camera.size
    ray_scene = ray_scene_for(scene)
    # Centre rays.
    py, px = np.meshgrid(np.arange(height) + 0.5, np.arange(width) + 0.5, indexing="ij")
    d = _camera_rays(camera, px, py).reshape(-1, 3)
    o = np.broadcast_to(camera.position, d.shape)
    centre = ray_scene.intersect(o, d)
    obj = centre.object_index.reshape(height, width)
    # Corner rays.
    cy, cx = np.meshgrid(np.arange(height + 1.0), np.arange(width + 1.0), indexing="ij")
    dc = _camera_rays(camera, cx, cy).reshape(-1, 3)
    corners = ray_scene.intersect(np.broadcast_to(camera.position, dc.shape), dc)
    cp = corners.position.reshape(height + 1, width + 1, 3)
    co = corners.object_index.reshape(height + 1, width + 1)
    p00, p01, p10, p11 = cp[:-1, :-1], cp[:-1, 1:], cp[1:, :-1], cp[1:, 1:]
    quad = 0.5 * (np.linalg.norm(np.cross(p01 - p00, p10 - p00), axis=-1)
                  + np.linalg.norm(np.cross(p01 - p11, p10 - p11), axis=-1))
    same = (co[:-1, :-1] == obj) & (co[:-1, 1:] == obj) & (co[1:, :-1] == obj) & (co[1:, 1:] == obj)
    # Differential footprint: pixel solid angle times t^2 over the cosine at the hit.
    tan_half = math.tan(math.radians(camera.fov_y) / 2.0)
    pixel_plane = (2.0 * tan_half * camera.aspect / width) * (2.0 * tan_half / height)
    forward = normalize(camera.look_at - camera.position)
    cos_axis = np.abs(d @ forward)
    cos_hit = np.maximum(np.abs(dot(d, centre.geometric_normal)), 1e-6)
    t = np.where(centre.hit, centre.t, 0.0)
    footprint = (pixel_plane * cos_axis**3 * t * t / cos_hit).reshape(height, width)
    area = np.where(same, quad, footprint)
    return np.where(obj >= 0, area, 0.0), obj


def irradiance_on_pixels(hits: PhotonHits, scene, camera=None) -> np.ndarray:
    """Caustic irradiance (H, W, 3) in W/m^2 on the receivers each camera pixel sees.

    Each hit visible from the camera (a shadow ray from the eye) is binned into
    the pixel its position projects to, on the object that pixel sees; the sum
    is divided by the receiver area of the pixel (:func:`pixel_receiver_area`).
    """
    camera = scene.camera if camera is None else camera
    width, height = camera.size
    area, obj = pixel_receiver_area(scene, camera)
    out = np.zeros((height * width, 3))
    if len(hits) == 0:
        return out.reshape(height, width, 3)
    # Project the hits to pixels.
    view = (camera.view_from_world() @ np.c_[hits.position, np.ones(len(hits))].T).T
    depth = -view[:, 2]
    tan_half = math.tan(math.radians(camera.fov_y) / 2.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_ndc = view[:, 0] / depth / (tan_half * camera.aspect)
        y_ndc = view[:, 1] / depth / tan_half
    i = np.floor((x_ndc + 1.0) / 2.0 * width)
    j = np.floor((1.0 - y_ndc) / 2.0 * height)
    inside = (depth > 0) & (i >= 0) & (i < width) & (j >= 0) & (j < height)
    i, j = i[inside].astype(np.int64), j[inside].astype(np.int64)
    index, pixel = np.flatnonzero(inside), j * width + i
    # Keep the hits the eye sees: on the pixel's object, and nothing in between.
    on_object = obj.reshape(-1)[pixel] == hits.object_index[index]
    index, pixel = index[on_object], pixel[on_object]
    ray_scene = ray_scene_for(scene)
    to_hit = hits.position[index] - camera.position
    distance = np.linalg.norm(to_hit, axis=1)
    blocked = ray_scene.occluded(np.broadcast_to(camera.position, to_hit.shape), to_hit / distance[:, None],
                                 distance * (1.0 - 1e-6) - ray_scene.epsilon)
    index, pixel = index[~blocked], pixel[~blocked]
    for c in range(3):
        out[:, c] = np.bincount(pixel, weights=hits.flux[index, c], minlength=height * width)
    area = area.reshape(-1)
    out = np.where(area[:, None] > 0, out / np.maximum(area, 1e-300)[:, None], 0.0)
    return out.reshape(height, width, 3)
