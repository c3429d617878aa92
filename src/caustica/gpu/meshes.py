"""Meshes on the GPU: one vertex/index buffer pair per mesh, one vertex array per program."""
from __future__ import annotations

import os
import re
from collections import OrderedDict

import numpy as np

from ..errors import closest_name
from ..scene.transform import normal_matrix
from .shaders import ShaderError, declared_uniforms

IDLE_FRAMES = 8  # frames a GPU mesh stays after its last use (an animation makes a new mesh each frame)
MAX_MESHES = 4096  # GPU meshes kept at most, however recently used
# Strict uniforms (the tests turn them on): writing a uniform that the program's source does not
# declare is an error (a misspelling); one declared but optimised away by the driver stays silent.
STRICT_UNIFORMS = os.environ.get("CAUSTICA_STRICT_UNIFORMS") == "1"
UV_ATTRIBUTE = "in_uv"  # a mesh's texture coordinates (Mesh.uvs)


class GpuMesh:
    """Interleaved object-space positions and normals plus triangle indices (and the uvs, where the
    mesh has them, as the attribute UV_ATTRIBUTE)."""

    def __init__(self, ctx, mesh):
        data = np.hstack([mesh.vertices, mesh.normals]).astype("f4")
        self.vbo = ctx.buffer(data.tobytes())
        self.ibo = ctx.buffer(local_face_order(mesh.vertices, mesh.faces).astype("i4").tobytes())
        self.ctx = ctx
        self._arrays: dict[tuple, object] = {}
        self.attributes: dict[str, tuple[object, int]] = {}  # shader input name -> (buffer, components)
        self.vertex_count = len(mesh.vertices)
        self.last_used = 0  # MeshCache's frame count when last handed out
        if mesh.uvs is not None:  # read by textured receivers' programs only (common/albedo_vertex.glsl)
            self.set_attribute(UV_ATTRIBUTE, mesh.uvs)

    def set_attribute(self, name: str, values: np.ndarray) -> None:
        """An extra per-vertex float attribute (e.g. Wyman's d_N) bound to shader input ``name``."""
        values = np.asarray(values, dtype="f4").reshape(self.vertex_count, -1)
        if name in self.attributes:
            self.attributes[name][0].release()
        self.attributes[name] = (self.ctx.buffer(values.tobytes()), values.shape[1])
        for vao in self._arrays.values():
            vao.release()
        self._arrays.clear()

    def vertex_array(self, program):
        extra = tuple(name for name in self.attributes if name in program)
        key = (program.glo, extra)
        vao = self._arrays.get(key)
        if vao is not None and vao.program is not program:  # a GL name is reused once its program is gone
            vao.release()
            vao = None
        if vao is None:
            layout = "3f 3f" if "in_normal" in program else "3f 12x"
            names = ["in_position", "in_normal"] if "in_normal" in program else ["in_position"]
            content = [(self.vbo, layout, *names)]
            content += [(self.attributes[n][0], f"{self.attributes[n][1]}f", n) for n in extra]
            vao = self.ctx.vertex_array(program, content, self.ibo, index_element_size=4)
            self._arrays[key] = vao
        return vao

    def render(self, program) -> None:
        self.vertex_array(program).render()

    def release(self) -> None:
        for vao in self._arrays.values():
            vao.release()
        for buffer, _ in self.attributes.values():
            buffer.release()
        self.vbo.release()
        self.ibo.release()


def local_face_order(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``faces`` sorted along a Morton curve through their centroids, so that consecutive triangles
    share vertices: a CPU rasterizer shades a vertex once per batch of consecutive indices that uses
    it (an icosphere's subdivision order made llvmpipe shade each vertex about six times; this order
    1.5 to 2). The image does not depend on the order of a depth-tested draw."""
    centroids = vertices[faces].mean(axis=1)
    low, span = centroids.min(axis=0), np.ptp(centroids, axis=0)
    cells = ((centroids - low) / np.where(span > 0, span, 1.0) * 1023).astype(np.int64)

    def spread(x):  # the 10 bits of x to every third bit
        x = (x | x << 16) & 0x030000FF
        x = (x | x << 8) & 0x0300F00F
        x = (x | x << 4) & 0x030C30C3
        return (x | x << 2) & 0x09249249

    codes = spread(cells[:, 0]) | spread(cells[:, 1]) << 1 | spread(cells[:, 2]) << 2
    return faces[np.argsort(codes, kind="stable")]


class MeshCache:
    """GpuMesh per mesh content (vertices and faces), shared across frames; a mesh unused for
    ``idle_frames`` frames (``end_frame`` counts them) is released, and at most ``max_meshes`` are kept."""

    def __init__(self, ctx, idle_frames: int = IDLE_FRAMES, max_meshes: int = MAX_MESHES):
        self.ctx = ctx
        self.idle_frames, self.max_meshes = int(idle_frames), int(max_meshes)
        self.frame = 0
        self._meshes: OrderedDict[str, GpuMesh] = OrderedDict()  # least recently used first

    def get(self, mesh) -> GpuMesh:
        key = mesh.content_hash()
        gpu_mesh = self._meshes.get(key)
        if gpu_mesh is None:
            gpu_mesh = self._meshes[key] = GpuMesh(self.ctx, mesh)
            while len(self._meshes) > self.max_meshes:
                self._drop(next(iter(self._meshes)))
        self._meshes.move_to_end(key)
        gpu_mesh.last_used = self.frame
        return gpu_mesh

    def end_frame(self) -> None:
        """Count a frame; release the meshes not drawn in the last ``idle_frames`` frames."""
        self.frame += 1
        # Least recently used first, so last_used only grows along the dict: stop at the first recent one.
        while self._meshes and self.frame - next(iter(self._meshes.values())).last_used > self.idle_frames:
            self._drop(next(iter(self._meshes)))

    def _drop(self, key: str) -> None:
        self._meshes.pop(key).release()

    def __len__(self) -> int:
        return len(self._meshes)

    def release(self) -> None:
        for m in self._meshes.values():
            m.release()
        self._meshes.clear()


def mat4_bytes(m: np.ndarray) -> bytes:
    """A row-major numpy matrix as GLSL's column-major bytes."""
    return np.asarray(m, dtype="f4").T.tobytes()


def _member(program, name: str):
    """The program's uniform ``name``, or None (moderngl's ``in`` walks every member); with
    STRICT_UNIFORMS, a ShaderError when the program's source does not declare ``name``."""
    try:
        return program[name]
    except KeyError:
        declared = declared_uniforms(program) if STRICT_UNIFORMS else None
        if declared is not None:
            base = re.split(r"[\[.]", name, maxsplit=1)[0]
            if base not in declared:
                raise ShaderError(f"uniform '{name}' is not declared in the program's shaders{closest_name(base, declared)}") from None
        return None


def set_uniform(program, name: str, value) -> None:
    """Write a uniform if the program uses it (drivers drop unused ones)."""
    member = _member(program, name)
    if member is None:
        return
    if isinstance(value, np.ndarray):
        matrix = value.ndim == 2 and value.shape[0] == value.shape[1] and member.array_length == 1
        dtype = "f4" if value.dtype.kind == "f" else "i4"
        # numpy is row-major, GLSL matrices column-major.
        member.write(np.ascontiguousarray((value.T if matrix else value).astype(dtype)).tobytes())
    else:
        member.value = value


def set_object_transform(program, world_from_object: np.ndarray) -> None:
    """Write the shared mesh vertex stage's object matrices: ``world_from_object`` and its normal matrix."""
    set_uniform(program, "world_from_object", world_from_object)
    set_uniform(program, "world_normal_from_object", normal_matrix(world_from_object))


def write_uniform_array(program, name: str, values: np.ndarray) -> None:
    """Write the leading entries of a uniform array if the program uses it (drivers may shorten
    arrays to what a shader reads)."""
    member = _member(program, name)
    if member is not None:
        member.write(np.ascontiguousarray(values[: max(member.array_length, 1)]).tobytes())


def bind_samplers(program, names, textures, first_unit: int = 0) -> None:
    """Bind ``textures`` to consecutive units from ``first_unit`` and point the sampler uniforms
    ``names`` (in the same order) at them."""
    for unit, (name, texture) in enumerate(zip(names, textures), start=first_unit):
        texture.use(unit)
        set_uniform(program, name, unit)
