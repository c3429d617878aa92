"""``transport-table``: refractive caustics from a precomputed light transport table (Iwasaki et al.).

Iwasaki, Yoshimoto, Dobashi and Nishita, "A Method for Fast Rendering of
Caustics from Refraction by Transparent Objects" (IEICE 2005). Once per mesh
and IOR (section 4, ``caustica.transport.precompute``; cached on disk, keyed
by mesh hash, IOR, direction count and depth, quantized as in section 6) the
table records, per vertex and sampled incident direction, where the light
leaves the object, along which direction, with which Fresnel transmittance.
Every frame the object may move rigidly and the lights change freely:

1. :class:`TransportPhotons`: per glass object and light sample (directional,
   point, spot; line lights as N points), the table lookup at every vertex
   (four nearest samples, bilinear positions and transmittance, slerped
   directions; 5.1), the illumination volumes of the lit triangles with the
   flux ratio of eq. (2), accumulated directly on the receiver surfaces as
   photons (``caustica.transport.runtime``).
2. The shared caustic-map path (``passes/caustics/light_space.py``): a caustic view
   fitted around the photons, the receivers' positions from the light, the
   splat (fixed-point atomics or point sprites) and the resolve into irradiance.

The maps are rebuilt only when lights, objects or materials change. As a
caustic technique it composes with any view technique
(``depth-search+transport-table``; alone it uses depth-search); the view
refraction through the same table (5.3) is the view technique
``transport-table-view``.

Differs from the paper: caustics land on the receiver surfaces (exact
intersection of the volumes' edge rays with Embree) instead of on sample
planes with sliced object images (5.2), so any receiver shape works (the
sample planes themselves are ``caustica.transport.sample_planes``); the table is
made for a copy of the mesh with its large flat faces split (a prism's or a
block's vertices all lie on its edges, where entering light meets the next
face at once), and dispersive glass has a table per channel's IOR. ``exit_rays="traced"`` (ours) traces the table's rays
for the light's own directions each time the light or the object moves, and the sub-rays of the volumes whose
rays part, instead of looking them up (``caustica.transport.runtime``: what a 129-direction table cannot hold
on a scanned mesh). Limits: see ``caustica.transport.runtime``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..passes.caustics.light_space import (PHOTON_BYTES, FitCausticViews, LightSurfaces, Photons, ResolveCausticMaps,
                                           SplatPhotons)
from ..render.cached import CachedPasses
from ..render.frame import Channel, Frame, Pass
from ..transport.precompute import DirectionGrid
from .base import param
from .composite import POINT_MAPS, SPLATS, CausticTechnique
from .env_map import ShadowedParams


@dataclass
class TableParams(ShadowedParams):
    """The table settings shared by ``transport-table`` and ``transport-table-view`` (one declaration, so a
    ``view+caustics`` pair of them shares one value and one cached table)."""

    directions: int = param(129, range=(3, 100000), paper="Iwasaki et al. 4", hint=" (2 r^2 + 1: 129 is r = 8)",
                            help="sampled incident directions per vertex, 2 r^2 + 1 (the paper: 129)")
    max_depth: int = param(8, range=(1, 64), unit="interfaces", paper="Iwasaki et al. 4",
                           help="glass interfaces followed in the precompute (internal reflections included)")
    quantized: bool = param(True, paper="Iwasaki et al. 6",
                            help="the 12-byte-a-sample table (False: the float table, not cached)")

    def __post_init__(self):
        super().__post_init__()
        DirectionGrid.of_count(self.directions)


@dataclass
class TransportTableParams(TableParams):
    """Parameters of ``transport-table`` (Iwasaki et al.)."""

    exit_rays: str = param("table", choices=("table", "traced"), paper="Iwasaki et al. 5.1",
                           help="'table': looked up in the table (the paper); 'traced': the table's rays traced with "
                                "Embree for the light's own directions, and parting volumes' sub-rays too (ours)")
    map_size: int = param(512, range=(16, 4096), unit="texels", help="caustic-map texels a side (per cube face)")
    photon_budget: int = param(1 << 18, range=(1, 1 << 24), unit="photons", paper="Iwasaki et al. 5.1",
                               help="photons spread over the illumination volumes' footprints, per light sample")
    splat: str = param("auto", choices=SPLATS, help="'compute' (fixed-point atomics), 'points' (additive point sprites) or 'auto'")
    splat_radius: float = param(1.5, range=(0.75, 8.0), unit="texels", help="Gaussian splat radius in caustic-map texels")
    point_map: str = param("frustum", choices=POINT_MAPS, help="point lights: 'frustum' (fitted, cube when too wide) or 'cube'")


def scene_photons(scene, sample, params: TransportTableParams, progress: bool = True):
    """(positions, flux, stats) of every glass object's caustic photons for one light sample (CPU arrays).

    Glass standing on a receiver is traced without its faces on it (ours, passes/shading/glass_contact.py): light reaching
    such a face passes into the receiver there, with no interface between them."""
    from ..raytrace.environment_bake import without_standing_faces
    from ..transport.runtime import caustic_photons, object_exit_rays, receiver_scene

    scene = without_standing_faces(scene)

    glass = [o for o in scene.objects if o.material.kind == "glass"]
    receivers = [o for o in scene.objects if o.material.kind == "diffuse"]
    if not glass or not receivers:
        return np.zeros((0, 3)), np.zeros((0, 3)), {}
    ray_scene = receiver_scene(receivers)
    positions, fluxes, stats = [], [], {}
    budget = max(1, params.photon_budget // len(glass))
    for obj in glass:
        channels = object_exit_rays(obj, sample, params.directions, params.max_depth, params.quantized, progress,
                                    traced=params.exit_rays == "traced")
        for rays in channels:
            photons = caustic_photons(rays, ray_scene, max(1, budget // len(channels)))
            positions.append(photons.position[photons.landed])
            fluxes.append(photons.flux[photons.landed])
            stats.setdefault(obj.name, []).append(photons.stats)
    stats = {name: _summed(found) for name, found in stats.items()}
    return np.concatenate(positions), np.concatenate(fluxes), stats


def _summed(stats: list[dict]) -> dict:
    """One object's photon statistics over its channels' tables (counts and per-channel fluxes added)."""
    return {key: np.sum([one[key] for one in stats], axis=0).tolist() for key in stats[0]}


class TransportPhotons(Pass):
    """Table lookup, illumination volumes and photons on the receivers, per light sample (Iwasaki et al. 5.1)."""

    reads = ("light_samples",)
    writes = (Channel("photons", "buffer[light]", "per light: Photons (landing point, flux) or None"),)

    def __init__(self, params: TransportTableParams):
        self.params = params

    def run(self, frame: Frame) -> None:
        out = []
        for sample in frame.read("light_samples"):
            position, flux, stats = scene_photons(frame.scene, sample, self.params)
            if len(position) == 0:
                out.append(None)
                continue
            data = np.zeros((len(position), 8), "f4")
            data[:, :3], data[:, 3], data[:, 4:7] = position, 1.0, flux
            buffer = frame.own(frame.gpu.ctx.buffer(data.tobytes()))
            assert data.itemsize * 8 == PHOTON_BYTES
            out.append(Photons(buffer, len(position), stats))
        frame.write("photons", out)


class TransportTable(CausticTechnique):
    name = "transport-table"
    summary = "Caustics from a precomputed per-vertex light transport table, illumination volumes (Iwasaki et al.)"
    Params = TransportTableParams

    def caustic_passes(self, params):
        p = params
        inner = [
            TransportPhotons(p),
            FitCausticViews("photons", p.map_size, margin_texels=p.splat_radius + 2.0, point_map=p.point_map),
            LightSurfaces("caustic_views", "receivers"),
            SplatPhotons("photons", mode=p.splat, radius=p.splat_radius),
            ResolveCausticMaps("receivers"),
        ]
        return [CachedPasses("transport-table", tuple(sorted(vars(p).items())), inner)]
