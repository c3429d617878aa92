"""Impostors for reflected and refracted rays (Hu and Qin 2.2): nearby objects as textured rectangles with depth.

Hu and Qin, "Interactive reflections, refractions and caustics with impostors"
(TVCG 2007), 2.2.1: each object near a reflector/refractor R stands in as a
rectangle RECT_k with a texture TEX_k (radiance and depth) rendered from R's
centre towards the object's centre by a parallel projection (fig. 12-13). The
rectangle lies through the object's centre (``rect_offset`` moves it towards R,
fig. 17's RECT'_k), perpendicular to the axis from R's centre to the object, a
square of the object's bounding radius; a planar object (a floor, a wall) is
its own rectangle, with its normal as the axis, so its texture is exact; so is
a thin slab (a table top modelled as a box, SLAB_RATIO), by its face towards R.

The parallel projection is a pinhole ``distance_factor`` bounding radii behind
the rectangle (1/distance_factor rad at most from parallel; 1.1 degrees with
the default 50): every camera-view pass (front/back refractor buffers, depth
search, shading) then works unchanged inside the impostor texture, which is
what recursion (an impostor of a reflector rendered with impostors itself,
fig. 1b, 24g) needs. The shader (``shaders/common/impostors.glsl``) projects
with the same matrix, so the lookup and the texture agree exactly.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import moderngl
import numpy as np

from ...cache import state_key
from ...errors import SceneError
from ...gpu.meshes import set_uniform
from ...render.bindings import MAX_IMPOSTORS
from ...render.frame import Channel, Frame, Pass
from ...render.offscreen import aimed_camera, offscreen_channels, scene_subset
from .rectangles import atlas_cell, atlas_grid, axis_basis, coplanar_groups, flat_patch, object_sphere, slab_rectangle


@dataclass
class Impostor:
    """RECT_k and TEX_k of one object as one reflector sees it."""

    index: int  # of the object in the world scene
    center: np.ndarray  # rectangle centre
    axis: np.ndarray  # projection direction w (reflector -> object; a plane's normal pointing away)
    half_u: np.ndarray  # rectangle half extents (world vectors, perpendicular to axis)
    half_v: np.ndarray
    radius: float  # object's bounding radius
    origin: np.ndarray  # pinhole of the (near-parallel) projection
    slab: tuple[float, float]  # object's depth range from origin along axis
    camera: object  # OffscreenCamera of the texture
    planar: bool
    texture: object = None  # the reflector's atlas, rgba32f: radiance rgb, depth from origin along axis (0: empty)
    cell: tuple[int, int] = (0, 0)  # texel offset of this rectangle's square in the atlas
    others: tuple = ()  # world indices of the coplanar patches drawn into this rectangle with ``index`` (merge_planes)
    flat: bool = False  # a flat patch (no thickness) lying on the rectangle: Prect is its hit (2.2.1)

    def texel_area(self, resolution: int) -> float:
        """Area on the rectangle of one texel of a ``resolution``-square texture over it (scene units squared)."""
        return 4.0 * float(np.linalg.norm(self.half_u) * np.linalg.norm(self.half_v)) / resolution**2


@dataclass
class ImpostorSet:
    """Every reflector's rectangles; ``base`` numbers them globally (photon buffer k)."""

    by_reflector: dict = field(default_factory=dict)  # world object index -> list[Impostor]
    base: dict = field(default_factory=dict)  # world object index -> global index of its first rectangle
    world: object = None

    def pooled(self):
        """The atlases, one per reflector that has rectangles."""
        return [group[0].texture for group in self.by_reflector.values() if group]

    def all(self) -> list[Impostor]:
        return [imp for group in self.by_reflector.values() for imp in group]


def make_impostor(reflector_center: np.ndarray, obj, index: int, size: int, rect_offset: float = 0.0,
                  distance_factor: float = 50.0, merged=()) -> Impostor:
    """The rectangle of ``obj`` seen from ``reflector_center`` and the camera of its texture (2.2.1);
    ``merged``: the (world index, object) pairs of coplanar diffuse patches that share it (merge_planes)."""
    center, radius = object_sphere(obj)
    plane = slab_rectangle(obj, reflector_center) if obj.material.kind == "diffuse" else None
    thickness = 0.0
    flat = flat_patch(np.concatenate([o.world_mesh().vertices for _, o in [(index, obj), *merged]]).astype(np.float64)) \
        if merged else None
    if flat is not None:  # coplanar flat patches: one rectangle over their union, its normal away from the reflector
        rect_center, normal, half_u, half_v = flat
        plane = (rect_center, normal if np.dot(rect_center - reflector_center, normal) >= 0.0 else -normal,
                 half_u, half_v, 0.0)
    if plane is not None:
        rect_center, axis, half_u, half_v, thickness = plane
        radius = float(np.linalg.norm(half_u + half_v)) + 1e-9
        center = rect_center
        # Keep the texture square in texels but as large as the plane (never degenerate).
        half_u = half_u if np.linalg.norm(half_u) > 1e-6 * radius else axis_basis(axis)[0] * 1e-3 * radius
        half_v = half_v if np.linalg.norm(half_v) > 1e-6 * radius else axis_basis(axis)[1] * 1e-3 * radius
    else:
        axis = center - reflector_center
        axis = axis / np.linalg.norm(axis) if np.linalg.norm(axis) > 1e-9 else np.array([0.0, 0.0, -1.0])
        rect_center = center - axis * float(rect_offset) * radius
        u, v = axis_basis(axis)
        half_u, half_v = u * radius, v * radius
    distance = float(distance_factor) * radius
    origin = rect_center - axis * distance
    camera = aimed_camera(origin, rect_center, half_v, float(np.linalg.norm(half_u)), float(np.linalg.norm(half_v)),
                          max(distance - 3.0 * radius, 1e-3 * distance), distance + 3.0 * radius, (size, size))
    depth = float(np.dot(center - origin, axis))
    # A slab's texture holds its near face: its depth range is that face's, out to the far one.
    slab = ((depth - 0.01 * radius, depth + thickness + 0.01 * radius) if plane is not None
            else (depth - radius, depth + radius))
    return Impostor(index, rect_center, axis, half_u, half_v, radius, origin, slab, camera, plane is not None,
                    others=tuple(i for i, _ in merged), flat=plane is not None and thickness == 0.0)


def pack_texture(frame: Frame, color, depth, camera, origin, axis, radial: bool = False, into=None):
    """Radiance + depth (along ``axis`` from ``origin``, or the distance from it) in one pooled rgba32f
    texture, or in the square at texel offset ``cell`` of ``atlas`` with ``into=(atlas, cell)``."""
    gpu, ctx = frame.gpu, frame.gpu.ctx
    out, cell = into if into is not None else (frame.texture(camera.size, "rgba32f"), (0, 0))
    fbo = gpu.targets.framebuffer([out])
    fbo.use()
    fbo.viewport = (*cell, *camera.size)
    program = gpu.shaders.program("common/fullscreen.vert", "passes/nearby/impostor_pack.frag")
    color.use(0)
    depth.use(1)
    set_uniform(program, "color", 0)
    set_uniform(program, "depth", 1)
    set_uniform(program, "world_from_clip", np.linalg.inv(camera.clip_from_world()))
    set_uniform(program, "origin", np.asarray(origin, "f4"))
    set_uniform(program, "axis", np.asarray(axis, "f4"))
    set_uniform(program, "radial", int(radial))
    set_uniform(program, "cell", np.asarray(cell, "i4"))
    ctx.disable(moderngl.DEPTH_TEST)
    gpu.draw_fullscreen(program)
    ctx.enable(moderngl.DEPTH_TEST)
    out.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return out


class BuildImpostors(Pass):
    """RECT_k and TEX_k for every reflector/refractor drawn in this frame (TVCG 2.2.1, fig. 12-13).

    ``texture_passes(depth)`` gives the passes that render one object into its
    texture (light samples and shadow maps come from this frame): with ``depth``
    > 0 a reflector's texture is itself rendered with impostors (recursion), at
    0 it sees the environment. The world the rectangles come from is the
    channel ``impostor_world`` when a parent frame set it, else this frame's scene.
    Does nothing when an earlier pass already wrote ``impostors``. The textures
    do not depend on the camera, so the top-level set is kept across frames until
    an object, material, light or the environment changes (the paper, 2.2.1:
    textures need updating only when the objects move).
    """

    reads = ("light_samples", "shadow_maps")
    # The textures show the caustics on the objects they stand for, and the floor's light map.
    optional = {"caustic_maps": None, "environment_bake": None}
    writes = (Channel("impostors", "rgba32f + host[reflector]", "per reflector: rectangles and an atlas of their textures "
                                                                     "(radiance, depth)"),)

    def __init__(self, texture_passes, size: int = 512, depth: int = 0, rect_offset: float = 0.0,
                 distance_factor: float = 50.0, max_impostors: int = MAX_IMPOSTORS, merge_planes: bool = False):
        self.texture_passes, self.size, self.depth = texture_passes, int(size), int(depth)
        self.rect_offset, self.distance_factor, self.max_impostors = rect_offset, distance_factor, max_impostors
        self.merge_planes = bool(merge_planes)

    def cache_key(self, frame: Frame):
        """The top-level set while the scene stays (recursive sub-frames share the parent's world and
        build theirs each time); None where an earlier pass wrote the impostors."""
        if "impostors" in frame.channels or "impostor_world" in frame.channels:
            return None
        return (self.size, self.depth, self.rect_offset, self.distance_factor, self.max_impostors, self.merge_planes,
                _impostor_state_key(frame.scene), frame.version("caustic_maps"), frame.version("environment_bake"))

    def run(self, frame: Frame) -> None:
        if "impostors" in frame.channels:
            return
        world = frame.channels.get("impostor_world", frame.scene)
        drawn = {id(o) for o in frame.scene.objects}
        result = ImpostorSet(world=world)
        base = 0
        for r, reflector in enumerate(world.objects):
            if id(reflector) not in drawn or reflector.material.kind not in ("glass", "mirror"):
                continue
            reflector_center, _ = object_sphere(reflector)
            others = sorted((i for i in range(len(world.objects)) if i != r),
                            key=lambda i: np.linalg.norm(object_sphere(world.objects[i])[0] - reflector_center))
            rectangles = coplanar_groups(world, others) if self.merge_planes else [[i] for i in others]
            group = [make_impostor(reflector_center, world.objects[first], first, self.size, self.rect_offset,
                                   self.distance_factor, [(i, world.objects[i]) for i in rest])
                     for first, *rest in rectangles[: self.max_impostors]]
            atlas = self.make_atlas(frame, len(group)) if group else None  # a reflector alone has none
            for k, impostor in enumerate(group):
                impostor.texture = atlas
                impostor.cell = atlas_cell(k, atlas.size[0] // self.size, self.size)
                self.render_texture(frame, world, impostor)
            result.by_reflector[r] = group
            result.base[r] = base
            base += len(group)
        frame.write("impostors", result)

    def make_atlas(self, frame: Frame, count: int):
        """One zeroed rgba32f texture holding a reflector's ``count`` impostor squares (atlas_cell)."""
        limit = frame.gpu.max_texture_size
        columns, rows = atlas_grid(count, self.size, limit)
        width, height = columns * self.size, rows * self.size
        if max(width, height) > limit:
            raise SceneError(f"impostor_size {self.size} with {count} rectangles needs a {width}x{height} atlas, "
                             f"above this GL's limit of {limit}; lower impostor_size or max_impostors")
        return frame.zeroed((width, height), "rgba32f")

    def render_texture(self, frame: Frame, world, impostor: Impostor) -> None:
        """TEX_k: the object alone through the impostor's camera, packed with its depth along the axis
        into its square of the atlas."""
        obj = world.objects[impostor.index]
        depth = self.depth if obj.material.kind in ("glass", "mirror") else 0
        frame.channels.setdefault("impostor_world", world)
        with offscreen_channels(frame, scene_subset(world, [impostor.index, *impostor.others]), impostor.camera,
                                self.texture_passes(depth), keep=("color", "depth"),
                                share=("impostor_world", "caustic_maps", "environment_bake")) as kept:
            pack_texture(frame, kept["color"], kept["depth"], impostor.camera, impostor.origin, impostor.axis,
                         into=(impostor.texture, impostor.cell))


def _impostor_state_key(scene) -> tuple:
    """What impostor textures depend on: geometry, placement, materials, lights, environment, and
    the objects themselves (an ImpostorSet names its scene's objects, which later passes match by
    identity; the cached set holds them, so their ids stay theirs)."""
    from ...cache import scene_state_key
    from ...gpu.device import array_digest

    return (scene_state_key(scene), tuple(state_key(o.material) for o in scene.objects), array_digest(scene.environment.image),
            scene.intensity_scale, tuple(id(o) for o in scene.objects))


def impostor_defines(frame: Frame) -> dict:
    """MAX_IMPOSTORS for this frame's shaders: the most rectangles any reflector has (at least 1); and
    IMPOSTORS_CURVED: 0 when every rectangle is a flat patch, whose lookup compiles without the seeds and
    steps (2.2.1: Prect is a flat patch's hit; a CPU rasterizer runs a loop's first pass even where no
    pixel needs it)."""
    impostors = frame.channels.get("impostors")
    groups = list(impostors.by_reflector.values()) if impostors is not None else []
    return {"MAX_IMPOSTORS": max([1, *(len(group) for group in groups)]),
            "IMPOSTORS_CURVED": int(any(not impostor.flat for group in groups for impostor in group))}


def world_index(frame: Frame, obj) -> int | None:
    """Index of a drawn object in the impostors' world scene."""
    world = frame.channels.get("impostor_world", frame.scene)
    return next((i for i, o in enumerate(world.objects) if o is obj), None)


# Wyman's options ----------------------------------------------------------------------------


