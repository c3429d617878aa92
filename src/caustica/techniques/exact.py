"""``exact``: specular paths ray traced on the CPU with Embree, the accuracy oracle.

Every pixel sample follows its path through mirrors and glass exactly
(:func:`caustica.raytrace.paths.trace`): at each glass surface both the
reflected (weight F, exact unpolarised Fresnel) and the refracted branch
(1 - F) are followed, with Beer-Lambert absorption inside, up to
``max_depth`` interactions. Spheres from ``shapes.sphere`` are intersected as
true spheres (see :mod:`caustica.raytrace.embree_scene`).

Environment light on diffuse surfaces (``environment_samples`` > 0, the default): the environment is split
into its bright part (texels above ``environment_bright`` times the mean radiance: a sun), sampled by power
with ``environment_light_samples`` shadow rays a hit, and the rest, gathered by ``environment_samples``
stratified cosine-weighted rays a hit that are occluded by the scene and continue through glass and off
mirrors with the path weights of the eye paths (:mod:`caustica.raytrace.environment_light`). A cosine ray
that meets a diffuse surface shades it with the lights, one sample of the bright part and the rest's SH
irradiance (``environment_bounce``: one bounce of interreflection). ``environment_samples = 0`` gives
back the unoccluded SH irradiance of the rasterized techniques.

Caustics: photons from every light and from the environment's bright part, traced through glass and
mirrors with the same Embree paths (:func:`caustica.raytrace.photons.trace_photons`, seeded), give the
light that reaches diffuse surfaces after a specular interaction; every eye path that ends on a diffuse
surface adds their k-nearest-photon irradiance estimate there (:mod:`caustica.raytrace.caustic_gather`).
Direct light keeps its hard shadow rays, in which glass is opaque: the photons bring back what passes
through it. So the caustic seen through glass or in a mirror is there too, which Mitsuba's composite
reference misses. ``caustic_photons = 0`` turns the caustics off (glass then casts opaque shadows of the
lights and of the bright part).

Limits:

- Interreflection: one bounce, along the environment rays; the diffuse point they meet is shaded
  without its caustics and with the rest of the environment unoccluded.
- Dielectrics sit in air (no nested or touching glass).
- CPU speed: a few million rays per second; meant for measurement, not real time.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..cache import LruCache, array_digest, material_state_key, scene_state_key
from ..progress import progress, status
from ..raytrace.caustic_gather import CausticGather
from ..raytrace.embree_scene import ray_scene_for
from ..raytrace.environment_bake import without_standing_faces
from ..raytrace.environment_light import BRIGHT_RATIO, environment_light
from ..raytrace.paths import BATCH_SIZE, EnvironmentSampling, Materials, caustic_footprint, facing, trace
from ..scene.codes import MATERIAL_DIFFUSE
from ..raytrace.photons import target_sphere, trace_photons
from .base import Params, Technique, param


@dataclass
class ExactParams(Params):
    """``max_depth``: most specular interactions per path; ``min_weight``: drop fainter branches.

    16, as deep as the Mitsuba reference goes; the deeper paths cost little, since the branches below
    ``min_weight`` end first (docs/measured-defaults.md)."""

    max_depth: int = param(16, range=(0, 64), unit="interactions", help="most specular interactions per path")
    min_weight: float = param(1e-4, range=(0.0, 1.0), ends="[)", help="drop branches fainter than this throughput")
    caustic_photons: int = param(500_000, range=(0, 1 << 26), unit="photons",
                                 special={0: "none: glass casts opaque shadows"},
                                 help="photons traced from the lights for the caustics (Jensen's photon map)")
    caustic_neighbours: int = param(64, range=(1, 4096), unit="photons",
                                    help="nearest photons in each caustic irradiance estimate (the kernel's size)")
    environment_samples: int = param(64, range=(0, 4096), unit="rays",
                                     special={0: "the environment's unoccluded SH irradiance"},
                                     help="cosine-weighted rays per diffuse hit for the environment's light, "
                                          "occluded, through glass and mirrors")
    environment_light_samples: int = param(16, range=(0, 4096), unit="rays",
                                           special={0: "no bright part: every texel is cosine sampled"},
                                           help="shadow rays per diffuse hit towards the environment's bright part")
    environment_bright: float = param(BRIGHT_RATIO, range=(0.0, 1e9), unit="x mean radiance",
                                      special={0: "no bright part: every texel is cosine sampled"},
                                      help="texels brighter than this are the environment's bright part (a sun): "
                                           "sampled as lights, with photons for its caustics")
    environment_bounce: bool = param(True, help="environment rays that meet a diffuse surface shade it (one "
                                                "bounce of interreflection)")


class Exact(Technique):
    """Exact specular paths through glass and mirrors (Embree on the CPU)."""

    name = "exact"
    summary = "Exact specular paths through glass and mirrors, ray traced on the CPU with Embree (the accuracy oracle)"
    Params = ExactParams
    role = "reference"
    uses_gl = False

    def render(self, scene, camera, params, spp: int) -> np.ndarray:
        """Trace ``spp`` stratified samples per pixel and average them: (H, W, 3) float32.

        Rows are made and traced in bands of about one trace batch (paths.BATCH_SIZE rays), so memory
        stays bounded at any size and spp (the primary rays alone took 48 bytes a sample), and in
        PROGRESS_BANDS bands at least; each ray's path is independent of the others, so the image does not
        depend on the bands."""
        params = params if params is not None else ExactParams()
        width, height = camera.size
        sampling = environment_sampling(scene, params)
        rays_per_row = width * spp
        if sampling is not None:  # each diffuse hit traces its environment rays: smaller bands, finer progress
            rays_per_row *= 1 + (sampling.samples + sampling.bright_samples) // 8
        # A band is at most PROGRESS_BANDS-th of the rows, so progress moves each tenth (docs/cli.md) on small images too.
        band = max(1, min(BATCH_SIZE // rays_per_row, -(-height // PROGRESS_BANDS)))
        # Glass standing on a floor touches it: its faces on the floor leave the rays (a ray inside meets the floor).
        traced = without_standing_faces(scene)
        rays = ray_scene_for(traced)
        caustics = caustic_gather(traced, params)
        sample_angle = _sample_angle(camera, spp)
        image = np.empty((height, width, 3), dtype=np.float32)
        label = ("" if sampling is None else f" ({sampling.samples} rays a hit for the lights' light one bounce on: "
                 "the environment is black)" if is_black(scene.environment) else
                 f" ({sampling.samples}+{sampling.bright_samples} environment rays a hit)")
        with progress(height, f"exact {scene.name}{label}", unit="rows") as bar:
            for first in range(0, height, band):
                stop = min(height, first + band)
                origins, dirs = camera.primary_rays(spp, rows=(first, stop))
                radiance = trace(rays, scene, origins.reshape(-1, 3), dirs.reshape(-1, 3), params.max_depth,
                                 params.min_weight, caustics=caustics, sample_angle=sample_angle, environment=sampling)
                image[first:stop] = radiance.reshape(stop - first, width, -1, 3).mean(axis=2)
                bar.update(stop - first)
        return image


    def caustic_layer(self, scene, camera, params, hits=None) -> np.ndarray:
        """The ``caustic`` label (caustica.labels): intensity_scale times the caustic irradiance at the
        diffuse surface each pixel centre's ray meets first, 0 elsewhere, (H, W, 3) float32; the estimate
        ``render`` adds there at 1 spp (over the pixel's footprint). ``hits``: those rays' Embree hits."""
        params = params if params is not None else ExactParams()
        width, height = camera.size
        out = np.zeros((height * width, 3), np.float32)
        caustics = caustic_gather(scene, params)
        if caustics is not None:
            origins, dirs = (a.reshape(-1, 3) for a in camera.primary_rays(1))
            hits = hits if hits is not None else ray_scene_for(scene).intersect(origins, dirs)
            diffuse = Materials.of(scene).kind[hits.object_index] == MATERIAL_DIFFUSE
            _, ns, ng = facing(dirs[diffuse], hits.normal[diffuse], hits.geometric_normal[diffuse])
            footprint = caustic_footprint(dirs[diffuse], ng, hits.t[diffuse], _sample_angle(camera, 1))
            irradiance = caustics.irradiance(hits.position[diffuse], ns, hits.object_index[diffuse], footprint)
            out[diffuse] = irradiance * scene.intensity_scale
        return out.reshape(height, width, 3)


def _sample_angle(camera, spp: int) -> float:
    """One sample's share of a pixel, as an angle: its caustic estimates average at least that footprint."""
    return 2.0 * math.tan(math.radians(camera.fov_y) / 2.0) / camera.size[1] / math.sqrt(spp)


PROGRESS_BANDS = 20  # exact traces an image in this many bands of rows at least (its progress steps)
KERNEL_REACH = 0.1  # the caustic kernel's largest radius, in radii of the specular objects' bounding sphere


_GATHERS = LruCache(2)  # the photon maps of the scenes rendered last, reused while nothing they depend on changes


def environment_sampling(scene, params) -> EnvironmentSampling | None:
    """How diffuse hits gather the environment's light under ``params``; None for its unoccluded SH
    irradiance (``environment_samples`` 0), and where the rays could bring nothing: a black environment
    (all zero) with no light for their bounce to meet (no lights, or ``environment_bounce`` off). In a black
    environment with lights the rays still carry the lights' light one bounce on (interreflection)."""
    if not params.environment_samples or (is_black(scene.environment) and not (params.environment_bounce
                                                                                and scene.lights)):
        return None
    bright = params.environment_bright if params.environment_light_samples else 0.0
    return EnvironmentSampling(environment_light(scene.environment, bright),
                               params.environment_samples, params.environment_light_samples,
                               params.environment_bounce, params.max_depth, params.min_weight)


def is_black(environment) -> bool:
    """Whether ``environment`` sheds no light at all (every texel zero: ``--environment black``)."""
    return not np.any(environment.image)


def caustic_gather(scene, params) -> CausticGather | None:
    """The caustic photons of the lights and of the environment's bright part (when the environment is
    sampled: ``environment_samples`` > 0) in ``scene`` for ``params``, ready to gather; None when there are
    none (no photons asked for, no emitter, or nothing specular). Kept for the next render of the same
    lights, environment, geometry, placement and materials (a camera move traces no photons)."""
    target = target_sphere(scene)
    sampling = environment_sampling(scene, params)
    environment = sampling.light if sampling is not None and sampling.light.has_bright else None
    if not params.caustic_photons or (not scene.lights and environment is None) or target is None:
        return None
    key = (scene_state_key(scene), material_state_key(scene), params.caustic_photons, params.caustic_neighbours,
           params.max_depth, params.min_weight,
           None if environment is None else (array_digest(scene.environment.image), environment.bright))
    gather = _GATHERS.get(key)
    if gather is None:
        sources = "lights" if environment is None else "lights and the environment's bright part"
        status(f"exact: tracing {params.caustic_photons} photons from the {sources} for the caustics")
        hits = trace_photons(scene, count=params.caustic_photons, seed=0, max_depth=params.max_depth,
                             min_weight=params.min_weight, environment=environment)
        gather = CausticGather(hits, params.caustic_neighbours, KERNEL_REACH * target[1])
        _GATHERS[key] = gather
    return gather
