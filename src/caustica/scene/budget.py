"""A scene's budget: how many objects, triangles and bytes of mesh data one scene may hold.

Pure data, no GL. Every loader (TOML ``[[objects]]``, glTF nodes, mesh files) checks against these limits
BEFORE it does the work the limit guards (counting a file's entries before building them, reading a mesh
file's header before its body), so an oversized input fails within a second with one line that states the
limit, instead of loading for minutes. Each check raises :class:`SceneError` (or the ``error`` given, e.g.
:class:`MeshError`).

The limits are module constants read at call time: a program that needs more may raise them
(``caustica.scene.budget.MAX_OBJECTS = 50_000``) before loading.

- ``MAX_OBJECTS``: objects in one scene (each is drawn, planned and traced on its own);
- ``MAX_NODES``: nodes of one glTF hierarchy (with or without meshes);
- ``MAX_SCENE_TRIANGLES``: triangles of every object together, a mesh shared by N objects counting N times
  (each instance is drawn and traced); one mesh holds at most ``rules.MAX_TRIANGLES``;
- ``MAX_MESH_BYTES``: the mesh arrays the scene holds (:func:`mesh_bytes`), a shared mesh counted once;
- ``MAX_MESH_FILE_BYTES``: the size of one mesh file, checked before it is read.

Use :class:`SceneBudget` for running totals while loading one scene, or the ``check_*`` functions directly.
"""
from __future__ import annotations

from ..errors import SceneError

MAX_OBJECTS = 10_000
MAX_NODES = 1 << 20
MAX_SCENE_TRIANGLES = 1 << 24
MAX_MESH_BYTES = 1 << 30
MAX_MESH_FILE_BYTES = 1 << 29

# Bytes a loaded mesh keeps per vertex (float32 position, normal and uv) and per triangle (three int32).
VERTEX_BYTES = 4 * (3 + 3 + 2)
TRIANGLE_BYTES = 4 * 3


def _size(count: int) -> str:
    """A byte count for messages: '1.0 GiB', '512 MiB'."""
    for unit, scale in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if count >= scale:
            return f"{count / scale:.3g} {unit}"
    return f"{count} bytes"


def mesh_bytes(vertices: int, triangles: int) -> int:
    """The bytes a loaded mesh of ``vertices`` vertices and ``triangles`` triangles holds (an estimate
    from VERTEX_BYTES and TRIANGLE_BYTES, uvs included)."""
    return int(vertices) * VERTEX_BYTES + int(triangles) * TRIANGLE_BYTES


def check_objects(count: int, what: str = "the scene has", error=SceneError) -> None:
    """Refuse more than MAX_OBJECTS objects: ``what`` is e.g. "scene.toml has" or "model.glb would make"."""
    if count > MAX_OBJECTS:
        raise error(f"{what} {count:,} objects, above the limit of {MAX_OBJECTS:,} a scene; merge objects that "
                    "share a material into one mesh")


def check_nodes(count: int, what: str, error=SceneError) -> None:
    """Refuse a hierarchy of more than MAX_NODES nodes (``what``: e.g. "model.glb has")."""
    if count > MAX_NODES:
        raise error(f"{what} {count:,} nodes, above the limit of {MAX_NODES:,}; flatten the hierarchy "
                    "(e.g. apply its transforms) and re-export")


def check_triangles(total: int, what: str = "the scene's objects hold", error=SceneError) -> None:
    """Refuse more than MAX_SCENE_TRIANGLES triangles over all objects (instances of a shared mesh each count)."""
    if total > MAX_SCENE_TRIANGLES:
        raise error(f"{what} {total:,} triangles in all, above the limit of {MAX_SCENE_TRIANGLES:,} a scene; "
                    "use fewer objects or coarser meshes (fewer subdivisions)")


def check_bytes(total: int, what: str = "the scene's meshes take", error=SceneError) -> None:
    """Refuse mesh data beyond MAX_MESH_BYTES (``total`` from :func:`mesh_bytes`, shared meshes once)."""
    if total > MAX_MESH_BYTES:
        raise error(f"{what} about {_size(total)}, above the limit of {_size(MAX_MESH_BYTES)} of mesh data a "
                    "scene; use coarser (decimated) meshes")


def check_file_size(size: int, what: str, error=SceneError) -> None:
    """Refuse a mesh file larger than MAX_MESH_FILE_BYTES before reading it (``what``: e.g. "mesh file x.obj")."""
    if size > MAX_MESH_FILE_BYTES:
        raise error(f"{what} is {_size(size)}, above the limit of {_size(MAX_MESH_FILE_BYTES)} a mesh file; "
                    "use a coarser (decimated) mesh or a binary format (.ply, .stl, .glb)")


class SceneBudget:
    """Running totals of one scene being loaded: call :meth:`objects` with the count of entries before
    building them, then :meth:`mesh` once per object as its mesh is known (before the next one is built).
    ``source`` names the input in messages (e.g. "scene.toml")."""

    def __init__(self, source: str = "the scene", error=SceneError):
        self.source, self.error = source, error
        self.object_count = self.triangles = self.bytes = 0
        self._meshes: dict[int, object] = {}  # kept alive, so that no id is reused

    def objects(self, count: int) -> None:
        """Add ``count`` objects (SceneError past MAX_OBJECTS)."""
        self.object_count += int(count)
        check_objects(self.object_count, f"{self.source} has", self.error)

    def mesh(self, mesh, where: str = "") -> None:
        """Add one object drawing ``mesh`` (a Mesh, or anything with ``vertices`` and ``faces``): its
        triangles always, its bytes the first time this very mesh object is seen."""
        self.triangles += len(mesh.faces)
        upto = f" up to {where}" if where else ""
        check_triangles(self.triangles, f"{self.source}'s objects{upto} hold", self.error)
        if id(mesh) not in self._meshes:
            self._meshes[id(mesh)] = mesh
            self.bytes += mesh_bytes(len(mesh.vertices), len(mesh.faces))
            check_bytes(self.bytes, f"{self.source}'s meshes{upto} take", self.error)
