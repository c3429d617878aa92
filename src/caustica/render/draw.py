"""Drawing helpers every pass shares: objects with the shared vertex stage, back-face culling of solids,
the refractors' face buffers, full-screen passes."""
from __future__ import annotations

from contextlib import contextmanager

import moderngl
import numpy as np

from ..gpu.meshes import set_object_transform, set_uniform
from ..scene.tangents import mesh_tangents
from .frame import Frame

TANGENT_ATTRIBUTE = "in_tangent"  # a normal-mapped mesh's tangent frames (common/albedo_vertex.glsl)


def draw_objects(frame: Frame, program, objects, clip_from_world: np.ndarray) -> None:
    """Draw objects with the shared mesh vertex stage."""
    set_uniform(program, "clip_from_world", clip_from_world)
    for obj in objects:
        set_object_transform(program, obj.world_from_object())
        frame.gpu.meshes.get(obj.mesh).render(program)


def attach_tangents(gpu, mesh) -> None:
    """Give ``mesh``'s GPU copy its tangent frames (scene/tangents.py mesh_tangents) as TANGENT_ATTRIBUTE,
    once; a mesh without uvs has none."""
    gpu_mesh = gpu.meshes.get(mesh)
    if TANGENT_ATTRIBUTE not in gpu_mesh.attributes:
        tangents = mesh_tangents(mesh)
        if tangents is not None:
            gpu_mesh.set_attribute(TANGENT_ATTRIBUTE, tangents)


@contextmanager
def culled_back_faces(ctx, obj, clip_from_world: np.ndarray):
    """Cull back faces while drawing a solid (Mesh.is_solid) wholly in front of the near plane:
    each back face then lies behind a front face of the same solid, but a rasterizer still shades
    those it draws before the front face covering them. Same image, about half the fragments of a
    closed refractor (a CPU rasterizer pays for each). Skipped for mirroring transforms."""
    cull = culls_back_faces(obj, clip_from_world)
    if cull:
        ctx.front_face = "ccw"
        ctx.cull_face = "back"
        ctx.enable(moderngl.CULL_FACE)
    try:
        yield
    finally:
        if cull:
            ctx.disable(moderngl.CULL_FACE)


def culls_back_faces(obj, clip_from_world: np.ndarray) -> bool:
    """Whether ShadeSurfaces culls ``obj``'s back faces seen through ``clip_from_world``."""
    return (obj.mesh.is_solid() and _in_front_of_near_plane(obj.world_mesh().bounds, clip_from_world)
            and np.linalg.det(clip_from_world @ obj.world_from_object()) < 0.0)  # GL's perspective/ortho sign


def _in_front_of_near_plane(bounds: np.ndarray, clip_from_world: np.ndarray) -> bool:
    """Whether the box ``bounds`` (2, 3) lies wholly beyond the near plane (the eye then lies outside it)."""
    clip = clip_corners(bounds, clip_from_world)
    return bool(np.all(clip[:, 3] > 0.0) and np.all(clip[:, 2] > -clip[:, 3]))


def fullscreen_pass(frame: Frame, texture, shader: str, defines: dict, k: int, fmt: str = "rgba32f",
                    inputs: dict | None = None):
    """A fullscreen pass of ``shader`` reading ``texture`` (as ``source``) and ``inputs`` ({sampler name:
    texture}) into a new ``fmt`` texture k times smaller, lent to ``frame``."""
    import moderngl

    from ..gpu.meshes import set_uniform

    gpu = frame.gpu
    width, height = texture.size
    out = frame.texture((width // k, height // k), fmt)
    gpu.targets.framebuffer([out]).use()
    gpu.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
    program = gpu.shaders.program("common/fullscreen.vert", shader, defines)
    for unit, (name, source) in enumerate({"source": texture, **(inputs or {})}.items()):
        source.use(unit)
        set_uniform(program, name, unit)
    gpu.draw_fullscreen(program)
    return out


_CORNER_SIDES = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])  # min (0) or max (1) per axis


def clip_corners(bounds: np.ndarray, clip_from_world: np.ndarray) -> np.ndarray:
    """The eight corners of the box ``bounds`` (2, 3) in clip coordinates, (8, 4); of each box of a stack
    (..., 2, 3), (..., 8, 4)."""
    corners = np.asarray(bounds, np.float64)[..., _CORNER_SIDES, np.arange(3)]  # (..., 8, 3)
    return np.concatenate([corners, np.ones(corners.shape[:-1] + (1,))], axis=-1) @ np.asarray(clip_from_world,
                                                                                                np.float64).T


def screen_rect(bounds: np.ndarray, camera) -> np.ndarray:
    """The NDC rectangle (x0, y0, x1, y1) covering the box ``bounds`` (2, 3) with a pixel to spare,
    clamped to the viewport (all of it when the box reaches behind the eye)."""
    clip = clip_corners(bounds, camera.clip_from_world())
    if np.any(clip[:, 3] <= 1e-9):
        return np.array([-1.0, -1.0, 1.0, 1.0], "f4")
    ndc = clip[:, :2] / clip[:, 3:]
    pixel = 2.0 / np.asarray(camera.size, np.float64)
    return np.clip(np.concatenate([ndc.min(axis=0) - pixel, ndc.max(axis=0) + pixel]), -1.0, 1.0).astype("f4")


def draw_refractor_buffer(frame: Frame, program, fmt: str, face: str = "front", order: str = "nearest",
                          objects=None):
    """Draw the glass objects' (or ``objects``') ``face`` faces, keeping the ``order`` one per pixel,
    into a pooled camera-sized ``fmt`` target cleared to 0; returns the target."""
    gpu, ctx = frame.gpu, frame.gpu.ctx
    target = frame.texture(frame.camera.size, fmt)
    with frame.scratch(frame.camera.size, "depth") as depth:
        fbo = gpu.targets.framebuffer([target], depth)
        fbo.use()
        farthest = order == "farthest"
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0 if farthest else 1.0)
        ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.front_face = "ccw"
        ctx.cull_face = "front" if face == "back" else "back"
        ctx.depth_func = ">" if farthest else "<"
        objects = frame.scene.objects_of("glass") if objects is None else objects
        if objects:
            draw_objects(frame, program, objects, frame.camera.clip_from_world())
        ctx.depth_func = "<"
        ctx.cull_face = "back"
        ctx.disable(moderngl.CULL_FACE)
    return target
