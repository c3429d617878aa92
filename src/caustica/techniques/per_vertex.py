"""``per-vertex``: per-vertex reflection and refraction (Kakimoto, Tatsukawa, Chun, Nishita).

"Real-time reflection and refraction on a per-vertex basis". For every mirror
and lens in the scene, each frame:

1. Rays per vertex (3.1 step 1): the eye ray mirrored about the vertex normal;
   for glass, refracted at the front vertex and again where Embree finds the
   back surface (4.5). Only the vertices of eye-facing lens faces issue rays.
2. The exact nearest hit P of every ray with the scene, by Embree (3.1 step 3.1).
3. The least-squares virtual viewpoint E and the view volume that holds every
   reflected segment between its near and far planes (3.2, 3.3); the up vector
   on a principal curvature direction for saddles and cylinders (4.3). A
   reflector whose frustum field of view exceeds ``fov_threshold`` is split
   into patches that share their boundary vertices, each with its own E (4.1).
   Made adaptive (ours; 4.1 leaves it for future work): a mirror's patch is
   also split while its map hides the exact hits of more than ``split_hidden``
   of the mirror's vertices (an object seen from E in front of what the ray
   meets, the inconsistency of section 6, fig. 16: a smaller patch has its E
   nearer its lines). ``refine`` > 0 (ours) also splits mesh edges across
   reflected edges and hit/escape borders (per_vertex/refine.py).
4. The reflection map: the scene without the reflector, rendered from E with
   the off-axis frustum (ShadeSurfaces, the same shading as the eye view; the
   frame's caustic maps where their light can land in the map's view,
   passes/caustics.maps_reaching). The paper's map is square and fixed (``map_size``); by default (``map_size`` 0,
   our extension) it holds ``map_density`` texels per screen pixel the patch
   covers, shaped like the frustum, since on a CPU rasterizer this second
   render is most of the frame's cost (the default density: docs/measured-defaults.md).
   Hits between a concave mirror (or a convex lens) and E, the zooming region,
   get a second map looking back at the reflector with the reversed depth test
   (4.2, fig. 8-9). Mirrors inside a map are themselves rendered per vertex
   from E down to ``depth`` levels (multiple reflection, 4.4); below that they
   reflect the environment.
5. The reflector drawn over the eye view with texture coordinates Q, the
   projection of each exact hit into the map (3.4): exact at every vertex,
   interpolated between them. A lens adds Fresnel reflection of the
   environment at the front surface, weighs the map by the exit Fresnel
   factor and Beer-Lambert absorption per vertex, and with one IOR per channel
   (``ior_rgb``, or the glass's Abbe number) gives each channel its own
   texture coordinates into one shared map (chromatic aberration, fig. 15).

Steps 1-3 are kept while scene, camera and parameters stay the same (a still
frame traces no ray). Mirrors inside a map (``depth`` 2 and more) keep the
paper's method: their eye is E, so their rays are not the light's paths.

With ``cache`` the refraction vectors (step 1 for lenses) are reused while the
lens stays fixed relative to the eye (section 5); the scene hits, viewpoint and
texture coordinates are still recomputed every frame.

Limits (the paper's): accurate at vertices only, so coarse meshes blur and bend
the reflection between them; occlusion seen from E can differ from occlusion
along a reflected ray (section 6, fig. 16; exact only for planar mirrors; the
adaptive patches shrink it, the edges of an object seen from E near the mirror
still move by up to a few pixels);
objects between the reflector and the near plane are clipped; hits next to the
converging point of a concave mirror or convex lens stretch the map; a lens
shows only its twice-refracted ray (no internal reflections beyond TIR), and
nothing seen through glass in a map is refracted twice.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import moderngl
import numpy as np

from ..cache import LruCache, material_state_key, scene_state_key, state_key
from ..gpu.meshes import set_object_transform, set_uniform
from ..passes.caustics.maps import maps_reaching
from ..passes.shading.lights import light_passes
from ..passes.shading.surfaces import RefractorSurfaces, ShadeBackground, ShadeSurfaces
from ..per_vertex.patches import Patch, split_patches
from ..per_vertex.preparation import (Reflector, lens_lines, refine_mirror, reflector_kind, screen_pixels,
                                      texture_coordinates, volume_fit)
from ..per_vertex.rays import reflection_rays, trace_lines
from ..per_vertex.refine import Traced
from ..per_vertex.viewpoint import UP_MODES, ViewVolume, hidden
from ..raytrace.embree_scene import ray_scene_for
from ..raytrace.optics import normalize
from ..render.frame import Channel, Frame, Pass
from ..render.offscreen import OffscreenCamera, render_offscreen, scene_subset
from ..scene.rules import IOR_RANGE
from ..scene.scene import Scene
from .base import param
from .env_map import ShadowedParams
from .raster import RasterTechnique

LAST_STATS: dict = {}  # the last frame's figures: per-vertex ms, ray-issuing vertices (the mesh's, refined), patches, maps
_REFLECTORS = LruCache(16)  # steps 1-3 of a frame, kept while scene, camera and parameters stay the same


@dataclass
class PerVertexParams(ShadowedParams):
    """Parameters of ``per-vertex``; defaults follow Kakimoto et al."""

    map_size: int = param(0, range=(16, 8192), special={0: "sized to the reflector"}, unit="texels",
                          paper="Kakimoto et al. 3.4", help="reflection map texels a side (square, the paper's)")
    map_density: float = param(1.0, range=(0.05, 64.0), unit="texels per pixel",
                               help="map_size 0: map texels per screen pixel the reflector covers (ours; 0.5 blurred "
                                    "a curved mirror's reflection)")
    depth: int = param(1, range=(0, 8), unit="levels", paper="Kakimoto et al. 4.4",
                       help="reflector levels rendered per vertex: 2 shows a mirror in a mirror")
    fov_threshold: float = param(100.0, range=(1.0, 179.0), unit="degrees", paper="Kakimoto et al. 4.1",
                                 help="split a reflector into patches while a frustum is wider")
    max_patches: int = param(8, range=(1, 256), paper="Kakimoto et al. 4.1", help="at most this many patches per reflector")
    up: str = param("auto", choices=UP_MODES, paper="Kakimoto et al. 4.3",
                    help="frustum up vector: 'principal' curvature direction, 'camera', or the smaller of both")
    zoom_region: bool = param(True, paper="Kakimoto et al. 4.2",
                              help="reversed map for hits between a concave reflector and E")
    ior_rgb: tuple | None = param(None, kind="rgb", range=IOR_RANGE, special={None: "the glass's"},
                                  hint=" (glass is about 1.5, water 1.33, diamond 2.42; below 1 for an air bubble)",
                                  paper="Kakimoto et al. fig. 15", help="lens IOR per channel (fig. 15: 1.60, 1.61, 1.62)")
    cache: bool = param(False, paper="Kakimoto et al. section 5",
                        help="keep refraction vectors while each lens is fixed relative to the eye")
    lenses: bool = param(True, paper="Kakimoto et al. 4.5", help="glass objects refract per vertex (False: env-map shading)")
    max_interfaces: int = param(4, range=(1, 32), paper="Kakimoto et al. 4.5",
                                help="lens: interfaces followed inside (TIR reflects)")
    split_hidden: float = param(0.003, range=(0.0, 1.0), special={1.0: "never: the field-of-view rule alone"},
                                paper="Kakimoto et al. 4.1, fig. 6, 16",
                                help="mirrors: also split a patch while its map hides the exact hits of more than "
                                     "this fraction of the mirror's vertices (ours)")
    refine: float = param(0.0, range=(0.0, 64.0), unit="pixels", special={0: "the mesh's own vertices, as the paper"},
                          paper="Kakimoto et al. 4.1, fig. 6",
                          help="mirrors: split mesh edges across reflected edges and where the interpolated "
                               "reflection strays this far from the exact one (ours)")
    refine_levels: int = param(4, range=(0, 8), unit="levels", paper="Kakimoto et al. 4.1, fig. 6",
                               help="mirrors: most times refine halves an edge of the mesh")


def prepare_reflector(scene, index: int, eye, camera_up, ray_scene, params: PerVertexParams,
                      eye_from_world: np.ndarray | None = None, camera=None, nested: bool = False) -> Reflector:
    """Steps 1-3 for ``scene.objects[index]``: rays, exact hits, patches, texture coordinates (CPU).

    ``eye_from_world`` (the eye camera's view matrix) keys the lens cache of ``params.cache``. With
    ``camera`` (the eye camera: its size and clip matrix), a mirror's mesh is refined on its screen
    (``params.refine``); the vertices it adds follow the mesh's in ``points`` and ``channels``.
    A mirror seen in another's map (``nested``, 4.4) keeps the paper's method: its eye is a virtual
    viewpoint, so its rays are not the light's paths and the corrections that trust them (patches split
    where the map hides a hit, refinement) stay off.
    """
    obj = scene.objects[index]
    lens = reflector_kind(obj, params) == "lens"
    mesh = obj.world_mesh()
    points, normals = mesh.vertices.astype(np.float64), normalize(mesh.normals.astype(np.float64))
    faces = mesh.faces
    if lens:
        # Eye-facing faces only (counter-clockwise outside): their vertices issue rays.
        a, b, c = (points[faces[:, k]] for k in range(3))
        faces = faces[np.einsum("ij,ij->i", np.cross(b - a, c - a), (a + b + c) / 3.0 - eye) < 0]
    vertex_ids, local = np.unique(faces, return_inverse=True)
    faces_local = local.reshape(-1, 3)
    p, n = points[vertex_ids], normals[vertex_ids]
    local_points, local_normals = obj.mesh.vertices[vertex_ids], obj.mesh.normals[vertex_ids]
    hits = None
    if not lens:
        origins, dirs = reflection_rays(eye, p, n)
        lines, hits = trace_lines(ray_scene, origins, dirs)
        channels, weight, valid = [lines], np.tile(obj.material.color, (len(p), 1)), np.ones(len(p), bool)
    else:
        channels, weight, valid = lens_lines(scene, index, obj, eye, p, n, ray_scene, params, eye_from_world)
    reflector = Reflector(index, lens, vertex_ids, faces_local, channels, weight, valid, p, local_points, local_normals)
    fit = volume_fit(reflector, scene, p, n, eye, camera_up, params)
    green = reflector.channels[min(1, len(reflector.channels) - 1)]
    hides = None
    map_scene = None if lens or nested else ray_scene_for(scene_without(scene, index))  # what its maps show
    if params.split_hidden < 1.0 and map_scene is not None:

        def hides(vertices, volume) -> bool:
            count = hidden([volume], np.zeros(len(vertices), np.int64), lines.subset(vertices), map_scene).sum()
            return bool(count > params.split_hidden * len(p))
    reflector.patches = split_patches(reflector.faces, green.directions, fit, params.fov_threshold, params.max_patches,
                                      hides)
    if map_scene is not None and camera is not None and params.refine > 0 and params.refine_levels > 0:
        refine_mirror(reflector, n, Traced(lines, hits.object_index, hits.normal), eye, camera, ray_scene, map_scene,
                       scene.bounds(), params)
    texture_coordinates(reflector)
    return reflector


class PerVertexReflectors(Pass):
    """Mirrors and lenses per vertex: exact hits, virtual viewpoints, reflection maps, warped textures."""

    reads = ("color", "exit_direction", "depth", "light_samples", "shadow_maps")
    # The receivers' light maps and caustics, for the reflection maps (a mirror shows the caustic on the floor)
    optional = {"environment_bake": None, "caustic_maps": None, "caustic_tiles": None}
    writes = (Channel("color", "rgba32f", "linear radiance seen by the camera, reflectors warped per vertex"),)

    def __init__(self, params: PerVertexParams, depth: int):
        self.params = params
        self.depth = depth

    def run(self, frame: Frame) -> None:
        params, scene = self.params, frame.scene
        targets = [i for i, obj in enumerate(scene.objects) if reflector_kind(obj, params)]
        if self.depth <= 0 or not targets:
            return
        camera = frame.camera
        eye = np.asarray(camera.position, dtype=np.float64)
        start = time.perf_counter()
        eye_from_world = camera.view_from_world()
        # Everything steps 1-3 read: a still frame (a paused viewer, a re-render) traces no ray again.
        nested = self.depth < params.depth
        key = (scene_state_key(scene), material_state_key(scene), state_key(params), nested, tuple(camera.size),
               *(np.asarray(m, np.float64).tobytes() for m in (eye, camera.up, eye_from_world, camera.clip_from_world())))
        reflectors = _REFLECTORS.get(key)
        if reflectors is None:
            ray_scene = ray_scene_for(scene)
            reflectors = _REFLECTORS[key] = [prepare_reflector(scene, i, eye, camera.up, ray_scene, params,
                                                               eye_from_world, camera, nested) for i in targets]
        cpu_ms = (time.perf_counter() - start) * 1000.0
        # First pass: one map (two with a zooming region) per patch, the reflector left out.
        start = time.perf_counter()
        maps = []
        for reflector in reflectors:
            subscene = scene_without(scene, reflector.index)
            maps.append([self._maps(frame, subscene, patch.volume, zoom.any(),
                                    map_texels(frame.camera, reflector.points, patch, params))
                         for patch, zoom in zip(reflector.patches, reflector.zoom)])
        map_ms = (time.perf_counter() - start) * 1000.0
        # Second pass: the reflectors over the eye view.
        for reflector, patch_maps in zip(reflectors, maps):
            for k, (forward, backward) in enumerate(patch_maps):
                _draw_patch(frame, reflector, k, forward, backward, self.params)
        if self.depth == self.params.depth:
            LAST_STATS.clear()
            LAST_STATS.update(per_vertex_ms=cpu_ms, map_ms=map_ms, reflectors=reflectors,
                              ray_vertices=int(sum(len(r.vertex_ids) for r in reflectors)),
                              refined_vertices=int(sum(len(r.points) for r in reflectors)),
                              patches=int(sum(len(r.patches) for r in reflectors)))

    def _maps(self, frame: Frame, subscene: Scene, volume: ViewVolume, zoom: bool, size: tuple[int, int]):
        """The forward reflection map and, for a zooming region, the reversed one."""
        forward = render_map(frame, subscene, volume, self.params, self.depth - 1, size, reverse=False)
        backward = None
        if zoom and self.params.zoom_region and volume.has_zoom:
            backward = render_map(frame, subscene, volume, self.params, 0, size, reverse=True)
        return forward, backward


# Map sides an automatic size rounds up to, so that few distinct sizes enter the texture pool as the view moves.
_MAP_SIDES = (32, 48, 64, 96, 128, 192, 256, 384, 512, 768, 1024, 1536, 2048)


def map_texels(camera, points: np.ndarray, patch: Patch, params: PerVertexParams) -> tuple[int, int]:
    """Reflection map size (width, height) for one patch.

    A fixed ``map_size`` gives the paper's square map. ``map_size`` 0 (our extension, not in
    the paper) spends ``map_density`` texels per screen pixel the patch covers, shaped
    like the frustum, so that a small or distant mirror does not pay for a full-size
    second render while the map keeps its texel density where the mirror is seen.
    """
    if params.map_size:
        return params.map_size, params.map_size
    pixels = screen_pixels(camera, points, clamp=True)
    if np.isnan(pixels[patch.vertices]).any():  # the patch reaches behind the eye: no footprint to measure
        covered = float(camera.size[0] * camera.size[1])
    else:
        a, b, c = (pixels[patch.faces[:, k]] for k in range(3))
        (ux, uy), (vx, vy) = (b - a).T, (c - a).T
        covered = 0.5 * float(np.abs(ux * vy - uy * vx).sum())
    left, right, bottom, top = patch.volume.bounds
    aspect = (right - left) / max(top - bottom, 1e-9)
    texels = max(params.map_density * covered, 1.0)
    width, height = np.sqrt(texels * aspect), np.sqrt(texels / aspect)
    return tuple(next((s for s in _MAP_SIDES if s >= side), _MAP_SIDES[-1]) for side in (width, height))


def render_map(frame: Frame, subscene: Scene, volume: ViewVolume, params: PerVertexParams, depth: int,
               size: tuple[int, int], reverse: bool = False):
    """Render ``subscene`` from the virtual viewpoint into a pooled rgba32f map of ``size`` (bilinear, clamped)."""
    view = volume.view_from_world
    clip_from_world = volume.clip_from_world(reverse)
    camera = OffscreenCamera(volume.position, size, view[1, :3].copy(), view, clip_from_world)
    # The caustic maps only where their light can land in the map's view: elsewhere their lookups add nothing.
    reaching = maps_reaching(frame.optional("caustic_maps"), frame.read("light_samples"), clip_from_world)
    color = render_offscreen(frame, subscene, camera, view_passes(params, depth),
                             share=("environment_bake", *(("caustic_maps",) if reaching else ()), "caustic_tiles"),
                             params=params)["color"]
    color.filter = (moderngl.LINEAR, moderngl.LINEAR)
    color.repeat_x = color.repeat_y = False
    return color


def view_passes(params: PerVertexParams, depth: int) -> list:
    """The eye view or a reflection map with reflectors ``depth`` levels deep: back faces (they only
    give absorbing glass its thickness, as in env-map), the shading of everything that is not drawn
    per vertex (reflectors are, while ``depth`` > 0), then the reflectors per vertex."""
    shaded = None if depth == 0 else (lambda obj: reflector_kind(obj, params) is None)
    return [RefractorSurfaces("back", "farthest", absorbing_only=True), ShadeSurfaces(objects=shaded),
            ShadeBackground(), PerVertexReflectors(params, depth)]


def scene_without(scene: Scene, index: int) -> Scene:
    """``scene`` less one object (cached, so that its Embree scene is built once)."""
    return scene_subset(scene, [i for i in range(len(scene.objects)) if i != index])


def _draw_patch(frame: Frame, reflector: Reflector, k: int, forward, backward, params: PerVertexParams) -> None:
    """Draw one patch over the eye view with its texture coordinates, depth-tested against it."""
    gpu, ctx = frame.gpu, frame.gpu.ctx
    patch = reflector.patches[k]
    obj = frame.scene.objects[reflector.index]
    uv, zoom = reflector.uv[k], reflector.zoom[k]
    data = np.hstack([reflector.local_points[patch.vertices], reflector.local_normals[patch.vertices], uv[0], uv[1],
                      uv[2], zoom[:, None].astype(np.float64), reflector.weight[patch.vertices]]).astype("f4")
    remap = np.full(len(reflector.points), -1, np.int64)
    remap[patch.vertices] = np.arange(len(patch.vertices))
    indices = remap[patch.faces].astype("i4")
    # One variant per case (the shader's LENS, ZOOM, DISPERSION): CPU rasterizers run every branch.
    defines = {"LENS": int(reflector.lens), "ZOOM": int(backward is not None),
               "DISPERSION": int(len(reflector.channels) > 1)}
    program = gpu.shaders.program("passes/shading/per_vertex_surface.vert", "passes/shading/per_vertex_surface.frag", defines)
    vbo, ibo = frame.own(ctx.buffer(data.tobytes())), frame.own(ctx.buffer(indices.tobytes()))
    # skip_errors: a variant's linker drops the attributes it does not read (uv_r, uv_b, zoom).
    vao = frame.own(ctx.vertex_array(program, [(vbo, "3f 3f 2f 2f 2f 1f 3f", "in_position", "in_normal", "in_uv_r",
                                      "in_uv_g", "in_uv_b", "in_zoom", "in_weight")], ibo, index_element_size=4,
                           skip_errors=True))
    fbo = gpu.targets.framebuffer([frame.read("color"), frame.read("exit_direction")], frame.read("depth"))
    fbo.use()
    gpu.environment_texture(frame.scene.environment).use(0)
    forward.use(1)
    (backward or forward).use(2)
    m = obj.world_from_object()
    for name, value in (("environment", 0), ("reflection_map", 1), ("zoom_map", 2),
                        ("intensity_scale", float(frame.scene.intensity_scale)),
                        ("environment_pixel_angle", frame.camera.pixel_angle())):
        set_uniform(program, name, value)
    set_object_transform(program, m)
    set_uniform(program, "clip_from_world", frame.camera.clip_from_world())
    set_uniform(program, "camera_position", np.asarray(frame.camera.position, dtype="f4"))
    ior = params.ior_rgb if params.ior_rgb is not None else getattr(obj.material, "ior_rgb", np.ones(3))
    set_uniform(program, "ior_rgb", np.asarray(ior, dtype="f4"))
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.depth_func = "<="
    ctx.polygon_offset = (-1.0, -1.0)
    if reflector.lens:
        ctx.enable(moderngl.CULL_FACE)
        ctx.front_face, ctx.cull_face = "ccw", "back"
    vao.render()
    ctx.disable(moderngl.CULL_FACE)
    ctx.polygon_offset = (0.0, 0.0)
    ctx.depth_func = "<"


class PerVertex(RasterTechnique):
    name = "per-vertex"
    summary = "Mirrors and lenses exact at every vertex: least-squares viewpoint, warped reflection map (Kakimoto)"
    Params = PerVertexParams

    def build_passes(self, params):
        return [*light_passes(params.shadow_map_size), *view_passes(params, params.depth)]
