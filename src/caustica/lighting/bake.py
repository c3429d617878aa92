"""Planning and packing the light maps of the environment's light on the diffuse receivers: which receivers
get a map (a floor, box faces, flat rectangles) or per-vertex irradiance, the bake by exact's rays
(raytrace/environment_bake.py), and the one atlas the shaders read (docs/environment-light.md)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cache import LruCache, kept_on, material_state_key, scene_state_key
from ..progress import detail
from ..raytrace.environment_light import environment_light
from .environment import environment_sun, scene_floor

MAX_BAKE_SIZE = 1024  # texels a side of the floor's light map, at most


ATLAS_WIDTH = 1024  # texels a row of the bake's atlas at least (the vertices' rows)


TABLE_TEXELS = 5  # texels a rectangle takes in the atlas's table (rectangle_rows: origin and slack, u', v', normal, tile)


MAX_OBJECT_RECTS = 6  # lighting.glsl's: the rectangles of one object (a box's faces) set as its uniforms


_BAKES = LruCache(4)  # the bakes of the scenes rendered last (not the camera: a move bakes nothing)


@dataclass(frozen=True)
class Receiver:
    """How one diffuse object's share of the environment's light is baked (bake_plan): ``kind`` "floor" (its
    top face), "box" (its six faces), "plane" (both sides of the rectangle of its plane, shared with the
    coplanar objects of ``group``) or "vertices" (per vertex, ``baked`` of its ``vertices`` where capped)."""

    kind: str
    group: int = -1  # "plane": the index of its plane among bake_plan's groups
    vertices: int = 0  # "vertices": the mesh's
    baked: int = 0  # "vertices": how many are baked (the others interpolated), at most VERTEX_CAP


@dataclass(frozen=True)
class BakePlan:
    """Per scene object its :class:`Receiver` (None: not diffuse, nothing to bake), the floor (or None) and the
    coplanar groups of flat objects (lists of scene object indices)."""

    receivers: tuple
    floor: object
    planes: tuple


def bake_plan(scene) -> BakePlan:
    """What :func:`scene_bake` bakes for ``scene`` (docs/environment-light.md, "Light maps on every diffuse
    receiver"): the floor's top (scene_floor), the faces of box-shaped objects (box_faces), the rectangle of each
    plane holding flat objects (plane_of: walls, backdrops, a chart's squares, coplanar ones sharing it), the
    vertices of every other diffuse mesh (capped at VERTEX_CAP). Cached on the scene by its state."""
    return kept_on(scene, "_bake_plan_cache", (scene_state_key(scene), tuple(o.material.kind for o in scene.objects)),
                   lambda: _bake_plan(scene))


def _bake_plan(scene) -> BakePlan:
    from ..raytrace.environment_bake import VERTEX_CAP, _spread, box_faces, plane_of, same_plane

    floor = scene_floor(scene)
    size = float(np.linalg.norm(np.ptp(scene.bounds(), axis=0))) if scene.objects else 1.0
    receivers, planes, plane_keys = [], [], []
    for index, obj in enumerate(scene.objects):
        if obj.material.kind != "diffuse":
            receivers.append(None)
        elif obj is floor:
            receivers.append(Receiver("floor"))
        elif box_faces(obj) is not None:
            receivers.append(Receiver("box"))
        elif (flat := plane_of(obj)) is not None:
            group = next((k for k, known in enumerate(plane_keys) if same_plane(flat, known, 1e-4 * size)), None)
            if group is None:
                group = len(planes)
                planes.append([])
                plane_keys.append(flat)
            planes[group].append(index)
            receivers.append(Receiver("plane", group))
        else:
            mesh = obj.world_mesh()
            count = len(mesh.vertices)
            baked = count if count <= VERTEX_CAP else len(_spread(mesh.vertices.astype(np.float64),
                                                                  mesh.normals.astype(np.float64), VERTEX_CAP))
            receivers.append(Receiver("vertices", vertices=count, baked=baked))
    return BakePlan(tuple(receivers), floor, tuple(tuple(g) for g in planes))


@dataclass(frozen=True)
class SceneBake:
    """The bake of a scene state (:func:`scene_bake`): the LightMaps (raytrace/environment_bake.py: the floor's
    top first where there is one, then each box's six faces, then each plane's two sides), per scene object the
    range of its maps (first, count; (0, 0) for none) and its per-vertex irradiance ((vertices, 3) or None), and
    the seconds the bake took."""

    maps: list
    ranges: tuple
    vertices: tuple
    seconds: float


def scene_bake(scene, sun_taken: bool, size: int, samples: int | None = None) -> SceneBake:
    """The :class:`SceneBake` of every diffuse receiver of ``scene`` (bake_plan) under the ambient environment
    (without its sun where ``sun_taken``): the floor's top ``size`` texels a side, box faces FACE_SIZE, a plane's
    rectangle ``size`` along its longer side where it spans the scene (in proportion, FACE_SIZE at least,
    otherwise), VERTEX_CAP vertices of a mesh at most; kept for the next frame of the same geometry, materials
    and environment."""
    from ..raytrace.environment_bake import BAKE_SAMPLES

    samples = BAKE_SAMPLES if samples is None else samples
    key = (scene_state_key(scene), material_state_key(scene), bool(sun_taken), int(size), int(samples))
    bake = _BAKES.get(key)
    if bake is None:
        bake = _BAKES[key] = _scene_bake(scene, sun_taken, int(size), int(samples))
    return bake


def _scene_bake(scene, sun_taken: bool, size: int, samples: int) -> SceneBake:
    import time

    from ..raytrace.environment_bake import (FACE_SIZE, bake_floor, bake_rectangles, bake_vertices, box_faces, plane_of,
                                             plane_rectangle)

    start = time.perf_counter()
    plan = bake_plan(scene)
    sun = environment_sun(scene.environment).light if sun_taken else None
    ambient = environment_light(scene.environment).rest if sun_taken else scene.environment
    objects = scene.objects
    maps, ranges, vertices = [], [(0, 0)] * len(objects), [None] * len(objects)
    if plan.floor is not None:
        maps.append(bake_floor(scene, plan.floor, ambient, sun, size, samples))
        ranges[next(i for i, o in enumerate(objects) if o is plan.floor)] = (0, 1)
    boxes = [i for i, r in enumerate(plan.receivers) if r is not None and r.kind == "box"]
    if boxes:
        faces = [face for i in boxes for face in box_faces(objects[i])]
        label = ", ".join(objects[i].name for i in boxes)
        for k, i in enumerate(boxes):
            ranges[i] = (len(maps) + 6 * k, 6)
        maps += bake_rectangles(scene, faces, (FACE_SIZE, FACE_SIZE), ambient, sun, samples, label)
    extent = float(np.ptp(scene.bounds(), axis=0).max())
    for group in plan.planes:
        members = [objects[i] for i in group]
        origin, u, v, normal = plane_rectangle(members, *plane_of(members[0]))
        lengths = np.array([np.linalg.norm(u), np.linalg.norm(v)])
        columns, rows = np.maximum(np.round(min(size, max(FACE_SIZE, size * lengths.max() / extent))
                                            * lengths / lengths.max()), 1).astype(int)
        sides = [(origin, u, v, normal), (origin, u, v, -normal)]
        for i in group:
            ranges[i] = (len(maps), 2)
        maps += bake_rectangles(scene, sides, (int(columns), int(rows)), ambient, sun, samples,
                                ", ".join(o.name for o in members))
    for i, receiver in enumerate(plan.receivers):
        if receiver is not None and receiver.kind == "vertices":
            vertices[i] = bake_vertices(scene, objects[i], ambient, sun, samples)[0]
    seconds = time.perf_counter() - start
    texels = sum(m.irradiance.shape[0] * m.irradiance.shape[1] for m in maps)
    points = sum(r.baked for r in plan.receivers if r is not None and r.kind == "vertices")
    detail(f"the environment's light baked in {seconds:.1f} s: {len(maps)} light maps ({texels} texels) and "
           f"{points} vertices, {samples} rays each")
    return SceneBake(maps, tuple(ranges), tuple(vertices), seconds)


def light_maps(scene, sun_taken: bool, size: int, samples: int | None = None) -> list:
    """The LightMaps of :func:`scene_bake` (the floor's top first where the scene has a floor)."""
    return scene_bake(scene, sun_taken, size, samples).maps


def rectangle_rows(maps: list, tiles: np.ndarray) -> np.ndarray:
    """(maps, TABLE_TEXELS, 4) float32: per light map (origin, slack: how far off its plane a point may lie), (u /
    |u|^2, 0), (v / |v|^2, 0), (normal, 0), (its tile: x0, y0, columns, rows): lighting.glsl's rectangle, as the
    atlas's table holds it and as an object's uniforms give it."""
    rows = np.zeros((len(maps), TABLE_TEXELS, 4), np.float32)
    for k, (light_map, tile) in enumerate(zip(maps, tiles)):
        u, v = light_map.u, light_map.v
        rows[k, 0] = (*light_map.origin, 1e-3 * min(np.linalg.norm(u), np.linalg.norm(v)))
        rows[k, 1, :3], rows[k, 2, :3] = u / max(float(u @ u), 1e-300), v / max(float(v @ v), 1e-300)
        rows[k, 3, :3], rows[k, 4] = light_map.normal, tile
    return rows


def bake_atlas(bake: SceneBake) -> tuple[np.ndarray, np.ndarray, int, int, tuple, np.ndarray]:
    """(image, rectangle_rows, table_row, vertex_row, per-object entries, tiles) of :class:`EnvironmentBake`'s
    rgba32f texture."""
    tiles, (width, height) = atlas_tiles(bake.maps) if bake.maps else (np.zeros((0, 4), np.int64), (0, 0))
    width = max(width, ATLAS_WIDTH)
    table_row, vertex_row = height, height + len(bake.maps)
    firsts, total = [], 0
    for values in bake.vertices:
        firsts.append(-1 if values is None else total)
        total += 0 if values is None else len(values)
    image = np.zeros((vertex_row + -(-total // width), width, 4), np.float32)
    image[:height, :, :3] = atlas_image(bake.maps, tiles, (width, height)) if bake.maps else 0.0
    rectangles = rectangle_rows(bake.maps, tiles)
    image[table_row:vertex_row, :TABLE_TEXELS] = rectangles
    flat = image[vertex_row:].reshape(-1, 4)
    for first, values in zip(firsts, bake.vertices):
        if values is not None:
            flat[first:first + len(values), :3] = values
    entries = tuple((*bake.ranges[i], firsts[i]) for i in range(len(firsts)))
    return image, rectangles, table_row, vertex_row, entries, tiles


def atlas_tiles(maps: list) -> tuple[np.ndarray, tuple[int, int]]:
    """(tiles, (width, height)): where each map lies in one atlas, (x0, y0, columns, rows) in texels: the first
    at the left, the others in columns to its right, top to bottom."""
    first_rows, first_columns = maps[0].irradiance.shape[:2]
    height = max([first_rows] + [m.irradiance.shape[0] for m in maps[1:]])
    tiles, x, y, column_width = [(0, 0, first_columns, first_rows)], first_columns, 0, 0
    for light_map in maps[1:]:
        rows, columns = light_map.irradiance.shape[:2]
        if y + rows > height:
            x, y, column_width = x + column_width, 0, 0
        tiles.append((x, y, columns, rows))
        y, column_width = y + rows, max(column_width, columns)
    return np.array(tiles, np.int64), (x + column_width, height)


def atlas_image(maps: list, tiles: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(height, width, 3) float32: the maps placed at their tiles."""
    image = np.zeros((shape[1], shape[0], 3), np.float32)
    for light_map, (x0, y0, columns, rows) in zip(maps, tiles):
        image[y0:y0 + rows, x0:x0 + columns] = light_map.irradiance
    return image
