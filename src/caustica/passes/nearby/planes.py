"""Wyman's options for what T2 meets after the glass ("intersecting T2 with other geometry"), the ``nearby``
parameter of image-space and depth-search: the diffuse planar objects as shader planes, a camera-view texture of the
scene without refractors for the image-space searches, or the impostors (Hu and Qin 2.2)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...gpu.meshes import set_uniform
from ...parameters import Params, param
from ...render.bindings import MAX_PLANE_TEXTURES, MAX_PLANES, bind_planes
from ...render.frame import Channel, Frame, Pass
from ...render.offscreen import offscreen_channels, scene_subset
from ...scene import rules
from ...scene.textures import texture_of
from ..shading.surfaces import RefractorSurfaces, ShadeBackground, ShadeSurfaces
from .impostors import pack_texture
from .rectangles import planar_rectangle

NEARBY_MODES = ("none", "impostors", "planes", "search-linear", "search-binary", "search-secant")


@dataclass
class NearbyPlane:
    """A diffuse planar object as the shader's planes see it (impostors.glsl, NEARBY_PLANES)."""

    center: np.ndarray
    normal: np.ndarray
    half_u: np.ndarray  # half extents along the rectangle's sides
    half_v: np.ndarray
    color: np.ndarray  # albedo (times the texture's mean where the texture cannot be mapped)
    texture: np.ndarray | None = None  # mapped affinely: uv = uv_origin + s uv_axes[0] + t uv_axes[1]
    uv_origin: np.ndarray = field(default_factory=lambda: np.zeros(2))  # uv at the centre
    uv_axes: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))  # d uv / d s, d uv / d t (s, t: -1..1)


def nearby_planes(scene) -> list[NearbyPlane]:
    """The diffuse planar objects, at most MAX_PLANES; the first MAX_PLANE_TEXTURES textured ones whose
    uvs are an affine map of the rectangle keep their texture, the others take its mean colour."""
    planes = []
    for obj in scene.objects_of("diffuse"):
        rect = planar_rectangle(obj)
        if rect is None:
            continue
        plane = NearbyPlane(*rect, np.asarray(obj.material.color, np.float64))
        texture = texture_of(obj)
        mapping = affine_uvs(obj, plane) if texture is not None else None
        if mapping is not None and sum(p.texture is not None for p in planes) < MAX_PLANE_TEXTURES:
            plane.texture, (plane.uv_origin, plane.uv_axes) = texture, mapping
        elif texture is not None:
            plane.color = plane.color * texture.reshape(-1, 3).mean(axis=0, dtype=np.float64)
        planes.append(plane)
    return planes[:MAX_PLANES]


def affine_uvs(obj, plane: NearbyPlane, tolerance: float = 1e-4):
    """(uv at the centre, (d uv / d s, d uv / d t)) when ``obj``'s uvs are an affine function of the
    rectangle coordinates s, t (-1..1 along half_u, half_v) within ``tolerance``, else None."""
    mesh = obj.world_mesh()
    q = mesh.vertices.astype(np.float64) - plane.center
    st = np.stack([q @ plane.half_u / (plane.half_u @ plane.half_u), q @ plane.half_v / (plane.half_v @ plane.half_v)], 1)
    design = np.hstack([np.ones((len(st), 1)), st])
    fit, *_ = np.linalg.lstsq(design, mesh.uvs.astype(np.float64), rcond=None)
    if np.abs(design @ fit - mesh.uvs).max() > tolerance:
        return None
    return fit[0], fit[1:]


def plane_defines(frame: Frame) -> dict:
    """PLANE_TEXTURES for this frame's shaders: how many of its planes are textured (no define for none)."""
    count = sum(p.texture is not None for p in nearby_planes(frame.scene))
    return {"PLANE_TEXTURES": count} if count else {}


class NearbyView(Pass):
    """The scene without refractors from the camera, radiance + eye distance (Wyman's nearby-geometry texture)."""

    reads = ("light_samples", "shadow_maps")
    optional = {"environment_bake": None}  # the floor's light map, as the camera's view shows it
    writes = (Channel("nearby_view", "rgba32f", "camera view without refractors: radiance rgb, eye distance a (0: none)"),)

    def run(self, frame: Frame) -> None:
        scene = frame.scene
        keep = [i for i, o in enumerate(scene.objects) if o.material.kind != "glass"]
        with offscreen_channels(frame, scene_subset(scene, keep), frame.camera,
                                [RefractorSurfaces("back", "farthest"), ShadeSurfaces(), ShadeBackground()],
                                keep=("color", "depth"),
                                share=("environment_bake",)) as kept:
            packed = pack_texture(frame, kept["color"], kept["depth"], frame.camera, frame.camera.position,
                                  np.zeros(3), radial=True)
        frame.write("nearby_view", packed)


@dataclass
class NearbyParams(Params):
    """The ``nearby`` option of ``image-space`` and ``depth-search`` (Wyman, "intersecting T2 with other geometry").

    'none': the environment (their original behaviour); 'planes': the diffuse planar objects intersected
    in the shader; 'search-linear' / 'search-binary' / 'search-secant': image-space search along T2 in a
    camera-view texture of the scene without refractors, ``search_linear_steps`` uniform steps over
    ``search_distance`` (0: the scene's diagonal), then ``search_refine_steps`` binary or secant steps.
    """

    nearby: str = param("none", choices=tuple(m for m in NEARBY_MODES if m != "impostors"),
                        hint=" (impostors: use the 'impostors' technique)", paper="Wyman, intersecting T2 with other geometry",
                        help="what T2 meets after the glass: the environment, the diffuse planes, or a search of the scene")
    search_linear_steps: int = param(32, range=(1, 512), paper="Wyman, intersecting T2 with other geometry",
                                     help="search-*: uniform steps along T2 over search_distance")
    search_refine_steps: int = param(6, range=(0, 32), help="search-binary / search-secant: refining steps after the hit")
    search_distance: float = param(0.0, range=(0.0, rules.MAX_COORDINATE), unit="scene units", special={0.0: "the scene's diagonal"},
                                   help="search-*: how far along T2 the search looks")


@dataclass
class NearbyOption:
    """What a view technique adds for its ``nearby`` option: passes before shading, inputs, defines, uniforms,
    and defines from the frame (ShadeOptions.frame_defines)."""

    passes: list
    inputs: tuple
    defines: dict
    set_uniforms: object
    frame_defines: object = None


def nearby_option(nearby: str, params) -> NearbyOption:
    """Wyman's nearby-geometry options for ``image-space`` and ``depth-search`` ('none', 'planes', 'search-*')."""
    code = NEARBY_MODES.index(nearby)
    if nearby == "none":
        return NearbyOption([], (), {}, None)
    if nearby == "planes":
        return NearbyOption([], (), {"NEARBY": code}, lambda program, frame, obj: obj is None and bind_planes(program, nearby_planes(frame.scene), frame.gpu),
                            plane_defines)

    def set_search(program, frame, obj):
        if obj is not None:
            return
        set_uniform(program, "search_linear_steps", int(params.search_linear_steps))
        set_uniform(program, "search_refine_steps", int(params.search_refine_steps))
        diameter = float(np.linalg.norm(np.ptp(frame.scene.bounds(), axis=0)))
        set_uniform(program, "search_distance", float(params.search_distance or diameter))

    return NearbyOption([NearbyView()], ("nearby_view",), {"NEARBY": code}, set_search)


def chain_defines(*functions):
    """One frame_defines(frame) -> dict merging each non-None function's defines in turn (None if none)."""
    functions = [f for f in functions if f is not None]

    def call(frame):
        return {key: value for f in functions for key, value in f(frame).items()}

    return call if functions else None


def chain_uniforms(*functions):
    """One set_uniforms(program, frame, obj) calling each non-None function in turn."""
    functions = [f for f in functions if f is not None]

    def call(program, frame, obj):
        for f in functions:
            f(program, frame, obj)

    return call if functions else None
