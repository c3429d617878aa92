"""Exact specular paths through glass and mirrors, traced wavefront style on the CPU.

:func:`trace` is the radiance oracle of the ``exact`` technique. Every bounce
processes all live rays at once with arrays. At a glass surface a ray splits
deterministically into both branches (reflected with weight F, refracted with
1 - F; total internal reflection reflects with weight 1), so the image has no
noise. Beer-Lambert absorption exp(-sigma_a distance) applies per channel to
every segment inside glass. A mirror reflects times its colour. A diffuse
surface is shaded directly and ends the path: albedo / pi times the irradiance
of every light (hard shadows from shadow rays; every object, glass included,
occludes) plus the environment's light: by default its unoccluded SH
irradiance (as the rasterizer does), or, with an :class:`EnvironmentSampling`,
cosine-weighted rays traced through glass and mirrors (occluded) plus shadow
rays towards its bright part. Rays that escape read the environment.

Conventions and limits:

- A ray enters a glass object where dot(d, n_shading) < 0 and leaves it where
  dot(d, n_shading) > 0, as a path tracer's dielectric decides (see
  :func:`interface`); the medium outside every object is air (IOR 1). Nested
  or touching dielectrics are not modelled.
- Directions use the interpolated shading normal. At mirrors and diffuse
  surfaces the geometric normal decides the side; where a shading-normal
  direction would cross to the wrong side of the face, the geometric normal
  is used instead (and for glass's transmitted ray).
- Glass with an Abbe number (per-channel IOR) is traced once per channel with
  that channel's IOR.
- Light reaches diffuse surfaces directly (shadow rays, in which glass is opaque); the caustics, light
  of the lights and of the environment's bright part through glass and off mirrors, come from exact
  photons when ``trace`` is given a CausticGather (:mod:`caustica.raytrace.caustic_gather`; the ``exact``
  technique does so by default). The rest of the environment reaches them through glass along the
  cosine rays.

A receiver with glTF's metallic-roughness specular lobe (a Principled, :mod:`caustica.raytrace.principled`)
is shaded with its BRDF: every light and the environment's bright part evaluated through it (shadow rays),
the caustic photons through its diffuse part, and the path goes on along one direction its BRDF samples (the
rest of the environment and the other objects seen in the glossy reflection), so that it converges with the
samples per pixel.

:func:`exit_directions` follows only the refracted branch (the angular-error
oracle), and :func:`distance_along_negative_normal` computes Wyman's d_N.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene.codes import MATERIAL_CODES, MATERIAL_DIFFUSE, MATERIAL_GLASS, MATERIAL_MIRROR
from ..scene.microfacet import schlick
from ..scene.lights import DirectionalLight, SpotLight
from ..scene.materials import Principled
from ..scene.mesh import Mesh
from ..scene.textures import sample_texture, texture_of
from . import principled as brdf
from .embree_scene import RayScene, ray_scene_for
from .environment_light import cosine_directions, point_offsets, rotated_pattern
from .optics import dot, fresnel_dielectric, normalize, reflect, refract

BATCH_SIZE = 1 << 20


@dataclass
class TraceStats:
    """Path weight (mean over channels, summed over rays, divided by the ray count) that
    :func:`trace` dropped, indexed by the depth of the branch that was cut."""

    max_depth: int = 8
    by_depth_limit: np.ndarray = field(default=None)  # branches still alive at max_depth
    by_min_weight: np.ndarray = field(default=None)  # branches whose weight fell below min_weight

    def __post_init__(self):
        size = self.max_depth + 2
        self.by_depth_limit = np.zeros(size) if self.by_depth_limit is None else self.by_depth_limit
        self.by_min_weight = np.zeros(size) if self.by_min_weight is None else self.by_min_weight

    @property
    def total(self) -> float:
        return float(self.by_depth_limit.sum() + self.by_min_weight.sum())


@dataclass
class Materials:
    """Per-object material tables, indexed by object index."""

    kind: np.ndarray  # (K+1,) int; the last entry, -1, is what object index -1 (a miss) reads
    color: np.ndarray  # (K,3) diffuse albedo or mirror reflectance
    ior_rgb: np.ndarray  # (K,3), 1 for non-glass
    sigma: np.ndarray  # (K,3) absorption coefficient, 0 for non-glass
    # object index -> (texture (H, W, 3), uvs of each world-mesh face's corners (M, 3, 2)): textured receivers
    textures: dict = field(default_factory=dict)
    # (K+1,) bool: receivers shaded with the metallic-roughness BRDF (a Principled with a specular lobe)
    glossy: np.ndarray | None = None
    # object index -> principled.SurfaceTable: those, and the Principled receivers without a specular lobe
    # whose normal map or emission the Lambertian shading reads
    surfaces: dict = field(default_factory=dict)

    @classmethod
    def of(cls, scene) -> "Materials":
        mats = [o.material for o in scene.objects]
        kind = np.array([MATERIAL_CODES[m.kind] for m in mats] + [-1], dtype=np.int64)
        color = np.array([getattr(m, "color", np.ones(3)) for m in mats]).reshape(-1, 3)
        ior = np.array([m.ior_rgb if m.kind == "glass" else np.ones(3) for m in mats]).reshape(-1, 3)
        sigma = np.array([m.absorption_coefficient if m.kind == "glass" else np.zeros(3) for m in mats]).reshape(-1, 3)
        textures = {}
        for k, obj in enumerate(scene.objects):
            texture = texture_of(obj)
            if texture is not None:
                world = obj.world_mesh()  # its faces are the ones hit (reversed under a mirroring transform)
                textures[k] = (texture, world.uvs[world.faces])
        glossy = np.zeros(len(mats) + 1, bool)
        surfaces = {}
        for k, obj in enumerate(scene.objects):
            m = obj.material
            if isinstance(m, Principled) and m.kind == "diffuse" and (
                    m.glossy or m.normal_texture is not None or np.any(m.emission > 0)):
                surfaces[k] = brdf.SurfaceTable.of(obj)
                glossy[k] = m.glossy
        return cls(kind, color, ior, sigma, textures, glossy, surfaces)

    def albedo(self, hits, where: np.ndarray) -> np.ndarray:
        """Diffuse albedo (n, 3) at the ``where`` hits: colour times the texture (scene/textures.py's
        bilinear, repeating lookup) at the uvs interpolated with the hit's barycentrics."""
        index = hits.object_index[where]
        albedo = self.color[index]
        for k, (texture, corner_uvs) in self.textures.items():
            on = np.flatnonzero(where)[index == k]
            if len(on):
                uv = np.einsum("ik,ikj->ij", hits.barycentric[on], corner_uvs[hits.face[on]])
                albedo[index == k] *= sample_texture(texture, uv)
        return albedo

    @property
    def dispersive(self) -> bool:
        return bool(np.any(self.ior_rgb != self.ior_rgb[:, :1]))


@dataclass
class Interface:
    """What happens where rays meet a glass surface: normals facing the ray, eta, Fresnel."""

    entering: np.ndarray  # (n,) bool
    normal: np.ndarray  # (n,3) shading normal facing against d
    geometric_normal: np.ndarray  # (n,3) face normal facing against d
    reflectance: np.ndarray  # (n,) F
    reflected: np.ndarray  # (n,3)
    refracted: np.ndarray  # (n,3), the reflection where tir
    tir: np.ndarray  # (n,) bool


def facing(d: np.ndarray, normal: np.ndarray, geometric: np.ndarray):
    """Normals flipped to the side ``d`` comes from (decided by the geometric normal).

    Returns (front, shading, geometric): ``front`` is True where the ray hits the
    outside. Where the shading normal still faces along ``d``, the geometric one replaces it.
    """
    front = dot(d, geometric) < 0
    sign = np.where(front, 1.0, -1.0)[:, None]
    ng, ns = geometric * sign, normal * sign
    ns = np.where((dot(d, ns) < 0)[:, None], ns, ng)
    return front, ns, ng


def reflect_above(d: np.ndarray, ns: np.ndarray, ng: np.ndarray) -> np.ndarray:
    """Reflection about the shading normal, or the geometric one where that would enter the face."""
    r = reflect(d, ns)
    return np.where((dot(r, ng) > 0)[:, None], r, reflect(d, ng))


def interface(d: np.ndarray, normal: np.ndarray, geometric: np.ndarray, ior: np.ndarray) -> Interface:
    """Reflection, refraction and Fresnel reflectance where rays ``d`` meet glass of index ``ior``.

    The shading normal decides the side, as a path tracer's dielectric does (Mitsuba's works in the
    shading frame): at a smooth-shaded silhouette, where it turns away from a ray that meets the face's
    outside, the ray leaves the surface the normals describe at a grazing angle, is mostly totally
    reflected, and reflects about the shading normal even where that crosses the face. The transmitted
    ray stays on the face's far side (the geometric normal decides where the shading one would not)."""
    entering = dot(d, normal) < 0
    ns = normal * np.where(entering, 1.0, -1.0)[:, None]
    ng = geometric * np.where(dot(d, geometric) < 0, 1.0, -1.0)[:, None]
    eta_i = np.where(entering, 1.0, ior)
    eta_t = np.where(entering, ior, 1.0)
    t, tir = refract(d, ns, eta_i / eta_t)
    wrong_side = ~tir & (dot(t, ng) >= 0)
    if wrong_side.any():
        t_g, tir_g = refract(d[wrong_side], ng[wrong_side], (eta_i / eta_t)[wrong_side])
        t[wrong_side], tir[wrong_side] = t_g, tir_g
    cos_i = -dot(d, ns)
    reflectance = np.where(tir, 1.0, fresnel_dielectric(cos_i, eta_i, eta_t))
    reflected = reflect(d, ns)
    t = np.where(tir[:, None], reflected, t)
    return Interface(entering, ns, ng, reflectance, reflected, t, tir)


def _accumulate(out: np.ndarray, index: np.ndarray, values: np.ndarray) -> None:
    """out[index] += values, with repeated indices summed."""
    for c in range(out.shape[1]):
        out[:, c] += np.bincount(index, weights=values[:, c], minlength=len(out))


def caustic_footprint(d: np.ndarray, geometric_normal: np.ndarray, travelled: np.ndarray,
                      sample_angle: float) -> np.ndarray:
    """The radius (N,) a camera sample of ``sample_angle`` radians covers where a path of length
    ``travelled`` meets a surface along ``d``: the least kernel of its caustic estimate (the sample's
    area sample_angle^2 travelled^2 / cos as a disc; grazing cosines clamped at 0.05)."""
    cos = np.maximum(np.abs(dot(d, geometric_normal)), 0.05)
    return sample_angle * travelled / np.sqrt(np.pi * cos)


@dataclass
class EnvironmentSampling:
    """How :func:`shade_diffuse` gathers the environment's light: ``samples`` cosine-weighted rays per
    point for the rest (:class:`~caustica.raytrace.environment_light.EnvironmentLight`; 0: its unoccluded
    SH irradiance), traced through glass and mirrors, and ``bright_samples`` shadow rays towards the bright
    part. Where a cosine ray meets a diffuse surface, ``bounce`` shades it with one bright sample and the
    rest's SH irradiance and the lights (one bounce of interreflection), else it brings nothing."""

    light: object
    samples: int = 64
    bright_samples: int = 16
    bounce: bool = True
    max_depth: int = 16
    min_weight: float = 1e-4

    @property
    def secondary(self) -> "EnvironmentSampling | None":
        """The sampling at a cosine ray's diffuse hit."""
        return EnvironmentSampling(self.light, 0, 1, False) if self.bounce else None


def _environment_radiance(ray_scene, scene, position, normal, geometric_normal, albedo, sampling, materials,
                          ior) -> np.ndarray:
    """Radiance (n, 3) Lambertian points reflect of the environment under ``sampling`` (an
    :class:`EnvironmentSampling`), intensity_scale included."""
    light, scale = sampling.light, scene.intensity_scale
    origin = position + geometric_normal * ray_scene.epsilon
    out = np.zeros((len(position), 3))
    if sampling.samples:
        out += albedo * cosine_gather(ray_scene, scene, position, normal, geometric_normal, sampling, materials, ior)
    else:
        out += albedo / np.pi * light.rest.irradiance(normal) * scale
    if sampling.bright_samples and light.has_bright:
        k = sampling.bright_samples
        d, radiance, pdf = light.sample_bright(rotated_pattern(position, k, salt=2))
        cos = np.einsum("nkj,nj->nk", d, normal)
        lit = (cos > 0) & (np.einsum("nkj,nj->nk", d, geometric_normal) > 0)
        where = np.nonzero(lit)
        lit[where] = ~ray_scene.occluded(origin[where[0]], d[where], np.inf)
        contribution = np.where(lit, cos / pdf, 0.0)[..., None] * radiance
        out += albedo / np.pi * contribution.mean(axis=1) * scale
    return out


def cosine_gather(ray_scene, scene, position, normal, geometric_normal, sampling, materials, ior,
                  less_open: bool = False, done=None, medium=None) -> np.ndarray:
    """Mean radiance (n, 3) of ``sampling.samples`` stratified cosine-weighted rays per point (pi times it is the
    irradiance), traced through glass and off mirrors; escaping rays read the rest of ``sampling.light``.
    ``less_open``: each ray less what it would read unblocked (the rest along its direction), so a point
    nothing shadows gives exactly 0 (a control variate: add the open irradiance back). ``done(points)`` is
    called after each batch; ``medium`` (n,): the glass object each point lies in (its absorption), -1 air."""
    k, light = sampling.samples, sampling.light
    origin = position + geometric_normal * ray_scene.epsilon
    out = np.zeros((len(position), 3))
    step = max(1, BATCH_SIZE // k)
    for start in range(0, len(position), step):
        sl = slice(start, start + step)
        d = cosine_directions(position[sl], normal[sl], k).reshape(-1, 3)
        # Below the face (the shading normal tilts past it): mirrored above it.
        ng = np.repeat(geometric_normal[sl], k, axis=0)
        d = np.where((dot(d, ng) < 0)[:, None], d - 2.0 * dot(d, ng)[:, None] * ng, d)
        o = np.repeat(origin[sl], k, axis=0)
        inside = None if medium is None else np.repeat(medium[sl], k)
        # Less the open sky, a ray nothing blocks brings exactly 0: only the blocked ones are traced.
        traced = ray_scene.occluded(o, d, np.inf) if less_open else slice(None)
        radiance = np.zeros((len(d), 3))
        radiance[traced] = _trace_batch(ray_scene, scene, materials, ior, np.ones(3), o[traced], d[traced],
                                        sampling.max_depth, sampling.min_weight, TraceStats(sampling.max_depth),
                                        environment=sampling.secondary, escape=light.rest, diffuse=sampling.bounce,
                                        medium=None if inside is None else inside[traced])
        if less_open:
            radiance[traced] -= light.rest.lookup(d[traced]) * scene.intensity_scale
        out[sl] = radiance.reshape(-1, k, 3).mean(axis=1)
        if done is not None:
            done(len(out[sl]))
    return out


def light_samples(ray_scene: RayScene, scene, position, normal, geometric_normal):
    """The light of every point sample of every light at points with shading ``normal`` (facing the viewer),
    shadowed (every object occludes): yields (lit (n,) bool, unit directions to the light at the lit points,
    the irradiance there (m, 3): cos times the falloff times the intensity, before intensity_scale)."""
    shadow_origin = position + geometric_normal * ray_scene.epsilon
    for light in scene.lights:
        if isinstance(light, DirectionalLight):
            samples = [(None, light.intensity)]
        else:
            samples = light.point_samples()
        for light_position, intensity in samples:
            if light_position is None:
                to_light = np.broadcast_to(-light.direction, position.shape)
                distance = np.full(len(position), np.inf)
                falloff = np.ones(len(position))
            else:
                offset = light_position - position
                distance = np.linalg.norm(offset, axis=1)
                to_light = offset / np.maximum(distance, 1e-300)[:, None]
                falloff = 1.0 / np.maximum(distance, 1e-300) ** 2
                if isinstance(light, SpotLight):
                    falloff = falloff * light.falloff(dot(-to_light, np.broadcast_to(light.direction, to_light.shape)))
            cos = dot(normal, to_light)
            lit = (cos > 0) & (falloff > 0)
            if not lit.any():
                continue
            lit[lit] = ~ray_scene.occluded(shadow_origin[lit], to_light[lit], distance[lit] - ray_scene.epsilon)
            yield lit, to_light[lit], (cos * falloff)[lit, None] * intensity


def shade_diffuse(ray_scene: RayScene, scene, position, normal, geometric_normal, albedo, caustics=None,
                  object_index=None, footprint=None, environment: EnvironmentSampling | None = None,
                  materials=None, ior=None) -> np.ndarray:
    """Radiance leaving Lambertian points: albedo / pi * (direct light with shadows + the environment's
    light, + the caustic irradiance of ``caustics``, a :class:`~caustica.raytrace.caustic_gather.CausticGather`,
    on the objects ``object_index``, over at least the radii ``footprint``).

    The environment's light is its unoccluded SH irradiance, or, with ``environment`` (an
    :class:`EnvironmentSampling`; ``materials`` and the per-object ``ior`` of this pass trace its rays),
    sampled with occlusion. ``normal`` and ``geometric_normal`` face the viewer; all light is scaled by
    ``scene.intensity_scale``.
    """
    if environment is None:
        irradiance = scene.environment.irradiance(normal).astype(np.float64)
    else:
        irradiance = np.zeros((len(position), 3))
    if caustics is not None:
        irradiance += caustics.irradiance(position, normal, object_index, footprint)
    for lit, _, received in light_samples(ray_scene, scene, position, normal, geometric_normal):
        irradiance[lit] += received
    out = albedo / np.pi * irradiance * scene.intensity_scale
    if environment is not None:
        out += _environment_radiance(ray_scene, scene, position, normal, geometric_normal, albedo, environment,
                                     materials if materials is not None else Materials.of(scene),
                                     ior if ior is not None else Materials.of(scene).ior_rgb[:, 0])
    return out


def trace(
    ray_scene: RayScene,
    scene,
    origins: np.ndarray,
    dirs: np.ndarray,
    max_depth: int = 8,
    min_weight: float = 1e-4,
    stats: TraceStats | None = None,
    caustics=None,
    sample_angle: float = 0.0,
    environment: EnvironmentSampling | None = None,
) -> np.ndarray:
    """Radiance (N,3) float64 along rays (N,3) through the scene's specular paths.

    ``max_depth`` is the most specular interactions a path may have; a branch
    still alive beyond it, or whose largest channel weight falls below
    ``min_weight``, is dropped, and its weight is added to ``stats`` when given.
    ``caustics`` (a CausticGather) adds the lights' caustics on the diffuse surfaces the paths end on,
    each estimate over at least the sample's footprint there: ``sample_angle`` (radians, the side of one
    sample's square of the image) times the distance travelled, over the square root of pi cos.
    ``environment`` (an :class:`EnvironmentSampling`) samples the environment's light on diffuse surfaces
    with occlusion instead of taking its unoccluded SH irradiance.
    """
    origins = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    dirs = np.asarray(dirs, dtype=np.float64).reshape(-1, 3)
    materials = Materials.of(scene)
    dropped = TraceStats(max_depth)
    # One pass, or one per colour channel for dispersive glass.
    if materials.dispersive:
        passes = [(materials.ior_rgb[:, c], np.eye(3)[c]) for c in range(3)]
    else:
        passes = [(materials.ior_rgb[:, 0], np.ones(3))]
    radiance = np.zeros((len(origins), 3))
    for start in range(0, len(origins), BATCH_SIZE):
        sl = slice(start, start + BATCH_SIZE)
        for ior, channel_weight in passes:
            radiance[sl] += _trace_batch(
                ray_scene, scene, materials, ior, channel_weight, origins[sl], dirs[sl], max_depth, min_weight, dropped,
                caustics, sample_angle, environment)
    if stats is not None:
        stats.max_depth = max_depth
        stats.by_depth_limit = dropped.by_depth_limit / max(len(origins), 1)
        stats.by_min_weight = dropped.by_min_weight / max(len(origins), 1)
    return radiance


def _trace_batch(ray_scene, scene, materials, ior, channel_weight, o, d, max_depth, min_weight, stats,
                 caustics=None, sample_angle: float = 0.0, environment: EnvironmentSampling | None = None,
                 escape=None, diffuse: bool = True, medium=None) -> np.ndarray:
    """The wavefront loop over one batch of primary rays and one IOR per object. Escaped rays read
    ``escape`` (default: the scene's environment), those leaving a glossy surface whose environment's bright
    part it sampled as a light read the rest; ``diffuse`` False: diffuse and glossy hits bring nothing;
    ``medium`` (n,): the glass object each ray starts in, -1 air (the default)."""
    n = len(o)
    out = np.zeros((n, 3))
    pixel = np.arange(n)
    weight = np.broadcast_to(channel_weight, (n, 3)).copy()
    # glass object the ray travels in, -1 for air
    medium = np.full(n, -1, np.int64) if medium is None else np.asarray(medium, np.int64).copy()
    travelled = np.zeros(n)  # path length from the eye (the footprint of caustic estimates)
    reads_rest = np.zeros(n, bool)  # continues a glossy bounce whose bright environment was sampled as a light
    scale = scene.intensity_scale
    escape = scene.environment if escape is None else escape
    bright = environment is not None and environment.bright_samples > 0 and environment.light.has_bright
    for depth in range(max_depth + 1):
        if len(pixel) == 0:
            break
        hits = ray_scene.intersect(o, d)
        travelled = travelled + np.where(hits.hit, hits.t, 0.0)
        # Attenuate segments inside glass (Beer-Lambert).
        inside = (medium >= 0) & hits.hit
        if inside.any():
            weight[inside] *= np.exp(-materials.sigma[medium[inside]] * hits.t[inside, None])
        # Escaped rays read the environment.
        miss = ~hits.hit
        if miss.any():
            seen = escape.lookup(d[miss])
            rest = reads_rest[miss]
            if rest.any():
                seen[rest] = environment.light.rest.lookup(d[miss][rest])
            _accumulate(out, pixel[miss], weight[miss] * seen * scale)
        kind = materials.kind[hits.object_index]
        glossy = materials.glossy[hits.object_index] & diffuse
        # Diffuse surfaces: direct shading, end of the path.
        on_diffuse = (kind == MATERIAL_DIFFUSE) & ~materials.glossy[hits.object_index]
        if diffuse and on_diffuse.any():
            normal, emission = _mapped_receiver(materials, hits, on_diffuse)
            _, ns, ng = facing(d[on_diffuse], normal, hits.geometric_normal[on_diffuse])
            albedo = materials.albedo(hits, on_diffuse)
            footprint = None if caustics is None else caustic_footprint(d[on_diffuse], ng, travelled[on_diffuse],
                                                                        sample_angle)
            radiance = shade_diffuse(ray_scene, scene, hits.position[on_diffuse], ns, ng, albedo, caustics,
                                     hits.object_index[on_diffuse], footprint, environment, materials, ior)
            if emission is not None:
                radiance += emission * scale
            _accumulate(out, pixel[on_diffuse], weight[on_diffuse] * radiance)
        # Glossy surfaces: direct shading, and the path goes on along a direction the BRDF samples.
        if glossy.any():
            surface = brdf.read_surface(materials.surfaces, hits, glossy, hits.normal[glossy])
            _, ns_glossy, ng_glossy = facing(d[glossy], surface.normal, hits.geometric_normal[glossy])
            footprint = None if caustics is None else caustic_footprint(d[glossy], ng_glossy, travelled[glossy],
                                                                        sample_angle)
            radiance = shade_glossy(ray_scene, scene, hits.position[glossy], -d[glossy], ns_glossy, ng_glossy,
                                    surface, caustics, hits.object_index[glossy], footprint,
                                    environment if bright else None)
            _accumulate(out, pixel[glossy], weight[glossy] * radiance)
        specular = (kind == MATERIAL_MIRROR) | (kind == MATERIAL_GLASS) | glossy
        if depth == max_depth:
            stats.by_depth_limit[depth + 1] += weight[specular].mean(axis=1).sum()
            break
        # Spawn the children of mirror, glass and glossy hits.
        children = []  # (pixel, origin, direction, weight, medium, travelled, reads_rest)
        mirror = kind == MATERIAL_MIRROR
        if mirror.any():
            _, ns, ng = facing(d[mirror], hits.normal[mirror], hits.geometric_normal[mirror])
            color = materials.color[hits.object_index[mirror]]
            r = reflect_above(d[mirror], ns, ng)
            children.append((pixel[mirror], hits.position[mirror], r, weight[mirror] * color, medium[mirror],
                             travelled[mirror], reads_rest[mirror]))
        glass = kind == MATERIAL_GLASS
        if glass.any():
            obj = hits.object_index[glass]
            it = interface(d[glass], hits.normal[glass], hits.geometric_normal[glass], ior[obj])
            w, p, f = weight[glass], hits.position[glass], it.reflectance[:, None]
            children.append((pixel[glass], p, it.reflected, w * f, medium[glass], travelled[glass],
                             reads_rest[glass]))
            tr = ~it.tir
            new_medium = np.where(it.entering, obj, -1)[tr]
            children.append((pixel[glass][tr], p[tr], it.refracted[tr], (w * (1.0 - f))[tr], new_medium,
                             travelled[glass][tr], reads_rest[glass][tr]))
        if glossy.any():
            p = hits.position[glossy]
            u = np.c_[point_offsets(p, salt=5), point_offsets(p, salt=6)[:, :1]]
            direction, throughput = brdf.sample(surface, ns_glossy, -d[glossy], u)
            throughput[dot(direction, ng_glossy) <= 0] = 0.0  # below the face: the surface is opaque
            children.append((pixel[glossy], p, direction, weight[glossy] * throughput, medium[glossy],
                             travelled[glossy], np.full(len(p), bright)))
        if not children:
            break
        pixel, o, d, weight, medium, travelled, reads_rest = (np.concatenate(parts) for parts in zip(*children))
        # Drop faint branches.
        faint = weight.max(axis=1) < min_weight
        if faint.any():
            stats.by_min_weight[depth + 1] += weight[faint].mean(axis=1).sum()
            keep = ~faint
            pixel, o, d, weight, medium, travelled, reads_rest = (
                pixel[keep], o[keep], d[keep], weight[keep], medium[keep], travelled[keep], reads_rest[keep])
    return out


def _mapped_receiver(materials, hits, where):
    """The interpolated normals (n, 3) of the ``where`` diffuse hits, normal-mapped on Principled receivers
    without a specular lobe, and their emission (n, 3; None where no hit emits)."""
    normal = hits.normal[where]
    if not materials.surfaces:
        return normal, None
    index = hits.object_index[where]
    mapped = np.isin(index, list(materials.surfaces))
    if not mapped.any():
        return normal, None
    rows = np.zeros(len(hits.hit), bool)
    rows[np.flatnonzero(where)[mapped]] = True
    surface = brdf.read_surface(materials.surfaces, hits, rows, normal[mapped])
    normal = normal.copy()
    normal[mapped] = surface.normal
    emission = np.zeros((len(normal), 3))
    emission[mapped] = surface.emission
    return normal, emission


def shade_glossy(ray_scene: RayScene, scene, position, view, normal, geometric_normal, surface, caustics=None,
                 object_index=None, footprint=None, environment: EnvironmentSampling | None = None) -> np.ndarray:
    """Radiance (n, 3) leaving points of a metallic-roughness surface (:mod:`caustica.raytrace.principled`)
    towards ``view`` before the sampled bounce: its emission, the BRDF times the light of every light
    (shadowed), the caustic irradiance of ``caustics`` times its diffuse part (at the half vector of the
    normal), and with ``environment`` the BRDF times its bright part (``bright_samples`` shadow rays;
    the bounce then reads the rest). ``normal`` and ``geometric_normal`` face the viewer; times
    ``scene.intensity_scale``."""
    out = surface.emission.copy()
    for lit, to_light, received in light_samples(ray_scene, scene, position, normal, geometric_normal):
        out[lit] += brdf.evaluate(surface.rows(lit), normal[lit], view[lit], to_light) * received
    if caustics is not None:
        fresnel = schlick(surface.f0_dielectric, dot(normal, view)[:, None])
        out += surface.diffuse_color / np.pi * (1.0 - fresnel) * caustics.irradiance(position, normal, object_index,
                                                                                    footprint)
    if environment is not None:
        k = environment.bright_samples
        light = environment.light
        d, radiance, pdf = light.sample_bright(rotated_pattern(position, k, salt=2))
        d, radiance, pdf = d.reshape(-1, 3), radiance.reshape(-1, 3), pdf.reshape(-1)
        at = np.repeat(np.arange(len(position)), k)
        lit = (dot(d, normal[at]) > 0) & (dot(d, geometric_normal[at]) > 0)
        origin = position + geometric_normal * ray_scene.epsilon
        lit[lit] = ~ray_scene.occluded(origin[at[lit]], d[lit], np.inf)
        f = brdf.evaluate(surface.rows(at[lit]), normal[at[lit]], view[at[lit]], d[lit])
        contribution = np.zeros((len(d), 3))
        contribution[lit] = f * (dot(d[lit], normal[at[lit]]) / pdf[lit])[:, None] * radiance[lit]
        out += contribution.reshape(-1, k, 3).mean(axis=1)
    return out * scene.intensity_scale


@dataclass
class RefractedPaths:
    """Where rays leave the glass when only the refracted branch is followed."""

    direction: np.ndarray  # (N,3) final direction (the input one for rays that miss all glass)
    position: np.ndarray  # (N,3) last glass surface point (the origin if no glass was hit)
    valid: np.ndarray  # (N,) bool: the ray ended outside glass within max_interfaces
    path_length: np.ndarray  # (N,) distance travelled inside glass
    transmittance: np.ndarray  # (N,) product of Fresnel transmittances (1 - F; 1 at TIR)
    interfaces: np.ndarray  # (N,) glass surfaces met
    # The non-glass object the final ray meets, outside glass or inside it (a floor under an open water
    # surface, an object set in glass), -1 where none (it escaped or leaked), and the point it meets it at.
    landed_object: np.ndarray | None = None  # (N,) int32
    landed_position: np.ndarray | None = None  # (N,3), 0 where none
    # Inside glass when it met nothing more: it left through a hole of an open mesh (a scan's), along
    # ``direction`` from ``position`` (its last glass surface point, or its origin), as light does.
    leaked: np.ndarray | None = None  # (N,) bool


def follow_refraction(
    ray_scene: RayScene, scene, origins, dirs, max_interfaces: int = 16, channel: int | None = None,
    start_inside: bool = False,
) -> RefractedPaths:
    """Follow each ray's refracted branch through glass (TIR reflects) until it leaves all glass.

    A ray is done when, outside glass, it misses everything or hits a
    non-glass object. It is invalid when it leaks out of a glass mesh, hits a
    non-glass object inside glass, or meets more than ``max_interfaces`` glass
    surfaces. ``channel`` picks the per-channel IOR of dispersive glass (default: ``ior``);
    ``start_inside`` says the rays start inside glass (already refracted into it).
    """
    o = np.array(origins, dtype=np.float64).reshape(-1, 3)
    d = np.array(dirs, dtype=np.float64).reshape(-1, 3)
    n = len(o)
    materials = Materials.of(scene)
    if channel is None:
        ior = np.array([getattr(obj.material, "ior", 1.0) for obj in scene.objects], dtype=np.float64)
    else:
        ior = materials.ior_rgb[:, channel]
    result = RefractedPaths(d.copy(), o.copy(), np.zeros(n, bool), np.zeros(n), np.ones(n), np.zeros(n, np.int64),
                            np.full(n, -1, np.int32), np.zeros((n, 3)), np.zeros(n, bool))
    active = np.arange(n)
    inside = np.full(n, bool(start_inside))
    for step in range(max_interfaces + 1):
        if len(active) == 0:
            break
        hits = ray_scene.intersect(o[active], d[active])
        kind = materials.kind[hits.object_index]
        at_glass = kind == MATERIAL_GLASS
        # Finish rays that are outside glass and meet no more glass; inside ones leaked.
        done = ~at_glass | (step == max_interfaces)
        result.valid[active[done]] = ~inside[active[done]] & ~at_glass[done]
        result.leaked[active[done]] = inside[active[done]] & ~hits.hit[done]
        landed = done & hits.hit & ~at_glass  # what the last refracted ray meets
        result.landed_object[active[landed]] = hits.object_index[landed]
        result.landed_position[active[landed]] = hits.position[landed]
        # Refract the rest (TIR reflects) and account for the path inside.
        go = active[~done]
        if len(go) == 0:
            break
        h = ~done
        obj = hits.object_index[h]
        it = interface(d[go], hits.normal[h], hits.geometric_normal[h], ior[obj])
        result.path_length[go] += np.where(inside[go], hits.t[h], 0.0)
        result.transmittance[go] *= np.where(it.tir, 1.0, 1.0 - it.reflectance)
        result.interfaces[go] += 1
        inside[go] = np.where(it.tir, inside[go], it.entering)
        o[go], d[go] = hits.position[h], it.refracted
        result.position[go], result.direction[go] = hits.position[h], it.refracted
        active = go
    return result


def exit_shares(scene, camera, exits: int) -> np.ndarray:
    """(exits,) the share of the light refracted into glass at the camera's glass pixels that leaves it at the
    first, second, ... exit (green channel's IOR; 1 - F at each exit, the reflected F going on inside, TIR
    reflecting all), averaged over ``camera``'s pixels whose primary ray meets glass: what each internal bounce
    of depth-search's extension adds to the image. NaN where no pixel sees glass; zeros where the refracted
    light meets no glass surface again (an open sheet such as a water surface: it lands on what lies below)."""
    o, d = (a[:, :, 0].reshape(-1, 3) for a in camera.primary_rays())
    ray_scene = ray_scene_for(scene)
    materials = Materials.of(scene)
    ior = materials.ior_rgb[:, 1]
    hits = ray_scene.intersect(o, d)
    glass = hits.hit & (materials.kind[hits.object_index] == MATERIAL_GLASS)
    shares = np.zeros(exits)
    count = int(glass.sum())
    if not count:
        return np.full(exits, np.nan)
    entry = interface(d[glass], hits.normal[glass], hits.geometric_normal[glass], ior[hits.object_index[glass]])
    weight = np.where(entry.tir, 0.0, 1.0)
    o, d = hits.position[glass], entry.refracted
    for k in range(exits):
        # Leave with 1 - F at the next glass surface; carry F on inside (all of it on TIR).
        hits = ray_scene.intersect(o, d)
        inside = hits.hit & (materials.kind[hits.object_index] == MATERIAL_GLASS)
        step = interface(d, hits.normal, hits.geometric_normal, ior[hits.object_index])
        shares[k] = float((weight * np.where(inside & ~step.tir, 1.0 - step.reflectance, 0.0)).sum()) / count
        weight = np.where(inside, weight * np.where(step.tir, 1.0, step.reflectance), 0.0)
        o, d = np.where(inside[:, None], hits.position, o), np.where(inside[:, None], step.reflected, d)
    return shares


def exit_directions(ray_scene: RayScene, scene, origins, dirs, max_interfaces: int = 16):
    """(exit direction (N,3), valid (N,), path length inside glass (N,)) of the refracted branch.

    See :func:`follow_refraction`; the angular-error oracle for the refraction techniques.
    """
    paths = follow_refraction(ray_scene, scene, origins, dirs, max_interfaces)
    return paths.direction, paths.valid, paths.path_length


def distance_along_negative_normal(mesh: Mesh, analytic_spheres: bool = False) -> np.ndarray:
    """Wyman's d_N: per vertex, the distance along -normal to the far side of the same mesh.

    ``mesh`` in any space (distances are in its units). Vertices whose ray leaves
    the mesh without a hit (open meshes) get 0. A ray aimed exactly at a vertex or
    edge of the far side can slip between its triangles (a sphere vertex aimed at
    its antipode): those are cast again from four origins nudged along the tangent
    plane, and take the mean of the nudged hits.
    """
    ray_scene = RayScene.from_meshes([mesh], analytic_spheres=analytic_spheres)
    origins = mesh.vertices.astype(np.float64)
    normals = mesh.normals.astype(np.float64)
    hits = ray_scene.intersect(origins, -normals)
    values = np.where(hits.hit, hits.t, 0.0)
    missed = np.flatnonzero(~hits.hit)
    if len(missed):
        n = normals[missed]
        helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        u = normalize(np.cross(n, helper))
        w = np.cross(n, u)
        nudge = 1e-4 * float(np.linalg.norm(np.ptp(origins, axis=0)))
        total, count = np.zeros(len(missed)), np.zeros(len(missed))
        for offset in (u, -u, w, -w):
            nudged = ray_scene.intersect(origins[missed] + nudge * offset, -n)
            total += np.where(nudged.hit, nudged.t, 0.0)
            count += nudged.hit
        values[missed] = np.where(count > 0, total / np.maximum(count, 1), 0.0)
    return values
