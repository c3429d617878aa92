"""``impostor-caustics``: caustics through the impostors (Hu and Qin, TVCG 2007, section 3).

Per light sample, each frame, no readback:

1. Photon buffer (3.1, fig. 19a-b): the reflectors/refractors rendered from
   the light (a pinhole at the light aimed at their bounding sphere,
   ``photon_buffer`` texels a side) with the ``impostors`` technique's shading
   (depth-search's two interfaces for glass, the mirror's reflection), every
   ray meeting the rectangles of ``passes/nearby/impostors.py``: each texel outputs
   the throughput (exact Fresnel at both interfaces, Beer-Lambert) and
   (u, v, k) of the rectangle it hit. Diffuse objects are drawn too, so they
   occlude the light.
2. Caustic textures (3.2, fig. 19c): a compute shader adds each photon's flux
   (intensity x the texel's solid angle x throughput) around texel (u, v) of
   rectangle k's tile (``caustic_size`` a side), spread evenly over the
   footprint of its photon-buffer texel there (the parallelogram to the
   landing points of its neighbours, the shorter step where they disagree)
   in bilinear sub-photons at most a texel apart. The paper adds it to one
   texel, which rings against a photon grid as fine as the tile
   (tests/test_caustic_radiometry.py) and, where rays grazing a ball land
   farther apart than the filter reaches, leaves dark notches between the
   photon rows (tests/test_impostor_caustic_footprint.py). Integer atomics on 64-bit
   fixed-point sums (``passes/caustics/fixed_flux.py``: the bytes do not depend on the
   order of the adds); the paper's glReadPixels path is replaced by this.
   Then the filter
   c(u, v) = s sum_{i,j=-k..k} p(u+i, v+j) sqrt(1 + 2k^2 - (i^2 + j^2)) with
   ``filter_k`` and ``filter_s``; p is the flux per unit rectangle area. The
   paper's s = 0.01 scales photon counts to colours; ``filter_s`` None (ours,
   the default) sets s = 1 / sum sqrt(...), so the filtered irradiance
   integrates to the photons' flux (energy conserved) and compares with
   Mitsuba in W/m^2. The filter's reach is k texels of a tile spanning the
   receiver's whole rectangle, so a small ``caustic_size`` on a large floor
   blurs a focused caustic (the default: docs/measured-defaults.md).
3. Caustics on receivers (3.3, fig. 21-23), as the paper does it: while the
   camera view shades a diffuse object, each fragment looks up the tiles of
   that object by the rectangles' parallel projections (a planar receiver is
   its rectangle: the paper's direct texture) and scales by |N . axis| on the
   side facing the caster (the ``caustic_tiles`` contract of
   ``passes/caustics/maps.py``; ``shaders/common/caustics.glsl``). Until
   2026-11-23 this went through light-space receiver maps (the
   ``caustic_maps`` contract): 6 x 512^2 texels per point light, three times
   the cost of the rest of the caustics on llvmpipe, and a resampling.

Composes with any view technique (``impostors+impostor-caustics`` shows nearby
objects and caustics; alone it uses depth-search). Reflective and refractive
caustics; several lights (one photon buffer each); water surfaces are one
interface (depth-search's back buffer is empty there, so T2 = T1).

Limits: the impostors' (a caustic lands where the ray meets the object's
rectangle-and-depth stand-in); one layer of casters (light through two glass
objects is followed only as far as the first one's impostors); the photon
buffer's resolution (the paper: 128^2 acceptable); no visibility test from the
rectangle to the receiver (as in the paper: a part of a receiver facing the
caster but hidden from it by the receiver itself takes its tile's caustic);
Wyman's nearby planes seen through glass show no caustic; point lights
inside the casters' bounding sphere make none; glass standing on a receiver
passes no light through the face lying on it (caustic mapping, photon splats
and the transport table land it: passes/shading/glass_contact.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.meshes import bind_samplers, set_uniform, write_uniform_array
from ..gpu.shaders import run_compute
from ..passes.caustics.fixed_flux import splat_fixed_point
from ..passes.caustics.maps import CausticTiles
from ..passes.nearby.impostors import BuildImpostors
from ..passes.shading.lights import without_light_passes
from ..render.bindings import MAX_CAUSTIC_TILES
from ..render.frame import Channel, Frame, Pass
from ..render.offscreen import aimed_camera, render_offscreen
from ..scene.codes import LIGHT_DIRECTIONAL, LIGHT_SPOT
from .base import param
from .composite import CausticTechnique
from .impostors import ImpostorParams, impostor_view_passes, texture_passes

CELL = 4  # occupancy block size of the flux atlases (texels a side)
# A directional light's photon buffer is a pinhole this many bounding radii back: its rays diverge, so a
# receiver h behind the casters gets (D / (D + h))^2 of the light (at 50 radii, 8 percent too little on
# a floor 1.2 below a ball of radius 0.5, measured: test_caustic_radiometry); at 1000, under 0.5 percent.
FAR_PINHOLE = 1000.0


@dataclass
class ImpostorCausticsParams(ImpostorParams):
    """Parameters of ``impostor-caustics`` (and the impostors it traces against)."""

    photon_buffer: int = param(256, range=(8, 4096), unit="texels", paper="Hu and Qin 3.1, fig. 24e",
                               help="photon buffer texels a side (the paper: 128 acceptable; larger is finer)")
    caustic_size: int = param(512, range=(8, 4096), unit="texels", paper="Hu and Qin 3.2",
                              help="caustic texture texels a side per rectangle")
    filter_k: int = param(2, range=(0, 16), unit="texels", paper="Hu and Qin 3.2", help="caustic filter half width")
    internal_bounces: int = param(0, range=(0, 0), paper="Hu and Qin 3.1",
                                  help="0 only: the photon buffer keeps one exit per texel, so light reflected "
                                       "inside is not followed",
                                  hint=": the photon buffer keeps one exit per texel (Hu and Qin 3.1); in a "
                                       "combination give the view's as impostors.internal_bounces")
    filter_s: float | None = param(None, kind="float", range=(0.0, 1e6), ends="(]", paper="Hu and Qin 3.2",
                                   special={None: "1 / sum of the weights, energy conserving"}, help="caustic filter scale")

    def __post_init__(self):
        super().__post_init__()
        if self.merge_planes:
            raise ValueError("merge_planes: impostor-caustics keeps one rectangle per receiver (its caustic texture's); "
                             "leave it false")



def filter_weights(k: int) -> np.ndarray:
    """The (2k+1)^2 weights sqrt(1 + 2k^2 - (i^2 + j^2)) of the caustic texture filter."""
    i = np.arange(-k, k + 1)
    return np.sqrt(1.0 + 2.0 * k * k - (i[:, None] ** 2 + i[None, :] ** 2))


def photon_camera(sample, casters, size: int):
    """The photon buffer's pinhole at the light, aimed at the casters' bounding sphere; None if inside it."""
    points = np.concatenate([o.world_mesh().vertices.astype(np.float64) for o in casters])
    center = 0.5 * (points.min(axis=0) + points.max(axis=0))
    radius = float(np.linalg.norm(points - center, axis=1).max()) * 1.02 + 1e-9
    if sample.type == LIGHT_DIRECTIONAL:
        position = center - np.asarray(sample.direction) * FAR_PINHOLE * radius
    else:
        position = np.asarray(sample.position, np.float64)
    distance = float(np.linalg.norm(center - position))
    if distance <= radius * 1.01:
        return None
    half = radius * distance / np.sqrt(distance**2 - radius**2)  # the sphere's silhouette on the plane through its centre
    up = np.array([0.0, 1.0, 0.0]) if abs((center - position)[1]) < 0.9 * distance else np.array([1.0, 0.0, 0.0])
    return aimed_camera(position, center, up, half, half, max(distance - 1.5 * radius, 1e-3 * distance),
                        distance + 1.5 * radius, (size, size))


class ImpostorPhotons(Pass):
    """3.1: per light, the photon buffer: throughput rgb and (u, v, k + 1, hit) of the rectangle each texel's ray met."""

    reads = ("light_samples", "shadow_maps", "impostors")
    writes = (Channel("impostor_photons", "rgba32f x2 + host[light]",
                      "per light: (throughput, record, camera, sample) or None"),)

    def __init__(self, params: ImpostorCausticsParams):
        self.params = params

    def run(self, frame: Frame) -> None:
        casters = [o for o in frame.scene.objects if o.material.kind in ("glass", "mirror")]
        out = []
        for sample in frame.read("light_samples"):
            camera = photon_camera(sample, casters, self.params.photon_buffer) if casters else None
            if camera is None:
                out.append(None)
                continue
            passes = without_light_passes(impostor_view_passes(self.params, 0, output=2, photon=True))
            passes = [p for p in passes if not isinstance(p, BuildImpostors)]
            kept = render_offscreen(frame, frame.scene, camera, passes, keep=("color", "exit_direction"),
                                    share=("impostors", "impostor_world"))
            out.append((kept["color"], kept["exit_direction"], camera, sample))
        frame.write("impostor_photons", out)


class CausticTextures(Pass):
    """3.2: photons into per-rectangle flux tiles (fixed-point integer atomics), then the sqrt(1 + 2k^2 - (i^2 + j^2)) filter."""

    reads = ("impostors", "impostor_photons")
    writes = (Channel("caustic_textures", "rgba32f", "rectangles' caustic tiles side by side: irradiance across each axis"),)

    def __init__(self, params: ImpostorCausticsParams):
        self.params = params

    def run(self, frame: Frame) -> None:
        impostors = frame.read("impostors").all()[:MAX_CAUSTIC_TILES]
        size = self.params.caustic_size
        width = size * max(len(impostors), 1)

        def dispatch(bind, bound: int) -> None:
            program = frame.gpu.shaders.compute("passes/caustics/impostor_caustic_splat.comp", {"FLUX_BOUND": bound})
            bind(program)
            set_uniform(program, "tile_size", size)
            set_uniform(program, "tile_count", len(impostors))
            set_uniform(program, "intensity_scale", float(frame.scene.intensity_scale) or 1.0)
            for entry in frame.read("impostor_photons"):
                if entry is None or not impostors:
                    continue
                throughput, record, camera, sample = entry
                splat_photons(frame, program, throughput, record, camera, sample)

        flux = splat_fixed_point(frame, (width, size), dispatch)
        caustic = filter_tiles(frame, flux, size, [imp.texel_area(size) for imp in impostors], self.params.filter_k,
                               self.params.filter_s)
        frame.write("caustic_textures", caustic)


def splat_photons(frame: Frame, program, throughput, record, camera, sample) -> None:
    """One light's photon buffer into the fixed-point flux sums (impostor_caustic_splat.comp)."""
    clip = camera.clip_from_world()
    intensity = np.asarray(sample.intensity, np.float64)
    if sample.type == LIGHT_DIRECTIONAL:
        distance = float(np.linalg.norm(np.asarray(camera.position) - frame.scene.bounds().mean(axis=0)))
        intensity = intensity * distance**2  # irradiance through a far pinhole
    set_uniform(program, "light_position", np.asarray(camera.position, "f4"))
    set_uniform(program, "light_intensity", intensity.astype("f4"))
    set_uniform(program, "light_axis", np.asarray(sample.direction, "f4"))
    set_uniform(program, "light_cone", np.asarray(sample.cone_cos if sample.type == LIGHT_SPOT else (-2.0, -2.0), "f4"))
    set_uniform(program, "world_from_clip", np.linalg.inv(clip))
    set_uniform(program, "camera_forward", np.asarray(camera.forward, "f4"))
    n = camera.size[0]
    projection = clip @ np.linalg.inv(camera.view_from_world())  # clip_from_view
    set_uniform(program, "unit_area", float((2.0 / projection[0, 0] / n) * (2.0 / projection[1, 1] / camera.size[1])))
    throughput.use(0)
    record.use(1)
    set_uniform(program, "throughput", 0)
    set_uniform(program, "record", 1)
    run_compute(program, (n + 7) // 8, (camera.size[1] + 7) // 8)
    frame.gpu.ctx.memory_barrier()


def filter_tiles(frame: Frame, flux, size: int, texel_areas, k: int, s: float | None):
    """The 3.2 filter over three r32f flux atlases of ``size`` tiles: a pooled rgba32f atlas of irradiance."""
    width = flux[0].size[0]
    occupancy, flux_rgb = flux_occupancy(frame, flux)
    out = frame.zeroed((width, size), "rgba32f")  # blocks with no photon near stay 0
    program = frame.gpu.shaders.compute("passes/caustics/impostor_caustic_filter.comp", {"FILTER_K": int(k), "CELL": CELL})
    bind_samplers(program, ("flux_rgb", "occupancy"), (flux_rgb, occupancy))
    set_uniform(program, "tile_size", size)
    set_uniform(program, "filter_s", float(s if s is not None else 1.0 / filter_weights(k).sum()))
    areas = np.ones(MAX_CAUSTIC_TILES, "f4")
    areas[: len(texel_areas)] = texel_areas
    write_uniform_array(program, "texel_area", areas)
    out.bind_to_image(0, read=False, write=True)
    run_compute(program, (occupancy.size[0] + 7) // 8, (occupancy.size[1] + 7) // 8)  # a block per invocation
    frame.gpu.ctx.memory_barrier()
    return out


def flux_occupancy(frame: Frame, flux):
    """Pooled textures: the summed flux of each CELL x CELL block of the atlases (r32f; the filter skips
    texels with no photon within reach) and the three atlases packed into one (rgba32f)."""
    width, height = flux[0].size
    occupancy = frame.texture(((width + CELL - 1) // CELL, (height + CELL - 1) // CELL), "r32f")
    flux_rgb = frame.texture((width, height), "rgba32f")
    program = frame.gpu.shaders.compute("passes/caustics/impostor_caustic_occupancy.comp", {"CELL": CELL})
    bind_samplers(program, ("flux_r", "flux_g", "flux_b"), flux)
    occupancy.bind_to_image(0, read=False, write=True)
    flux_rgb.bind_to_image(1, read=False, write=True)
    run_compute(program, (occupancy.size[0] + 7) // 8, (occupancy.size[1] + 7) // 8)
    frame.gpu.ctx.memory_barrier()
    return occupancy, flux_rgb


class CausticTilesOnReceivers(Pass):
    """3.3: hand the caustic textures to the surface shading, where each receiver fragment looks up its
    objects' tiles by the rectangles' parallel projections (fig. 21-23; a planar receiver is its
    rectangle: the paper's direct texture). No light-space pass: the paper projects in the eye view."""

    reads = ("impostors", "caustic_textures")
    writes = (Channel("caustic_tiles", "rgba32f + host", "caustic textures with their rectangles and receivers"),)

    def __init__(self, params: ImpostorCausticsParams):
        self.params = params

    def run(self, frame: Frame) -> None:
        impostors = frame.read("impostors").all()[:MAX_CAUSTIC_TILES]
        world = frame.read("impostors").world or frame.scene
        atlas = frame.read("caustic_textures")
        tiles = CausticTiles(atlas, self.params.caustic_size,
                             np.array([imp.camera.clip_from_world() for imp in impostors]).reshape(-1, 4, 4),
                             np.array([imp.axis for imp in impostors], np.float64).reshape(-1, 3),
                             [world.objects[imp.index] for imp in impostors],
                             np.array([imp.texel_area(self.params.caustic_size) for imp in impostors]))
        frame.write("caustic_tiles", tiles)


class ImpostorCaustics(CausticTechnique):
    name = "impostor-caustics"
    summary = "Caustics through impostors: photon buffer (u, v, k), GPU caustic textures, sqrt filter (Hu and Qin 3)"
    Params = ImpostorCausticsParams

    def caustic_passes(self, params):
        build = BuildImpostors(lambda d: texture_passes(params, d), params.impostor_size, params.depth,
                               params.rect_offset, params.distance_factor, params.max_impostors)
        return [build, ImpostorPhotons(params), CausticTextures(params), CausticTilesOnReceivers(params)]
