"""Light maps of the environment's light on the diffuse receivers, baked with ``exact``'s rays, looked up in real time.

The raster techniques light diffuse surfaces with the environment's SH irradiance, unoccluded, or with a
few lobes' shadow maps (passes/shading/environment.py); neither has the sky's light refracted by glass
onto the floor (its caustic), and the lobes cost a frame several times plain's. For a static scene the
floor's share of that light does not depend on the camera, so it is computed once per scene state and read
by the shading with one texture fetch: a light map, the oldest precomputation of global illumination
(Heckbert 1990, "Adaptive radiosity textures for bidirectional ray tracing"; here gathered, not shot).

Each texel of the floor's top rectangle (and of the faces of box-shaped diffuse objects: walls, table tops,
boxes; of both sides of the rectangle of a plane holding flat objects: a backdrop, a chart's squares), and each
vertex of a curved receiver (a sphere, a scanned mesh: at most VERTEX_CAP of them, the others interpolated from
their baked neighbours; passes/shading/environment.py bake_plan says which), gathers the irradiance of the
*ambient* environment (the image
without its sun where the sun is a directional light of its own, which keeps its sharp shadow and its caustic
map) with ``exact``'s cosine rays (:func:`~caustica.raytrace.paths.cosine_gather`): occluded by every object,
through glass and off mirrors (the sky's caustic and the glass's tinted shadow) and one bounce of
interreflection, where the bounced surface is lit by the scene's lights, the sun and the ambient
environment's SH. The rays carry a control variate: each adds what it brings less what the open sky brings
along it, and the open floor's irradiance is added back in closed form (a sum over the environment's
texels), so a texel nothing shadows is exact and the noise stays where objects are.

Texels whose centre lies inside an opaque object (under a box resting on the floor: the ray straight up leaves the
object through its back face) take their nearest outside neighbours' mean, so bilinear filtering at an
object's foot does not blend in the black of its inside. Texels inside glass (under a clear cube standing on the
floor) are gathered as the others, their rays starting in the glass: the floor there is lit through it. The faces of
glass that lie on the receiver it stands on (:func:`standing_plane`) are left out of the rays' scene: glass and
floor touch there, so a ray inside the glass meets the floor, not an interface coplanar with it (which Embree would
pick, or not, by its BVH build).

Deterministic: the ray patterns are hashed from each texel's position (environment_light.rotated_pattern).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..cache import kept_on
from ..progress import progress
from ..scene.codes import MATERIAL_GLASS
from ..scene.environment import Environment, texel_grid
from ..scene.mesh import Mesh
from .embree_scene import ray_scene_for
from .environment_light import environment_light
from .paths import EnvironmentSampling, Materials, cosine_gather

BAKE_SIZE = 64  # texels a side of the floor's light map
BAKE_SAMPLES = 256  # cosine rays a texel
FACE_SIZE = 16  # texels a side of each face of a box's light maps
VERTEX_CAP = 2048  # vertices of one mesh baked at most; the others take their baked neighbours' weighted mean
PLANE_TOLERANCE = 1e-4  # a mesh is flat when its vertices lie within this share of its size off one plane
CONTACT_TOLERANCE = 1e-3  # of glass's bounding radius: how far off a receiver's plane its touching vertices lie
STANDING_SHARE = 0.01  # glass stands on a receiver where faces of at least this share of its area lie on it


@dataclass(frozen=True)
class LightMap:
    """The irradiance of the ambient environment on a rectangle facing ``normal``: corner ``origin``, edges
    ``u`` (along the columns) and ``v`` (along the rows), world units; ``irradiance[j, i]`` at origin + (i + 1/2)
    u / columns + (j + 1/2) v / rows. Radiance is albedo / pi times it (intensity_scale not applied)."""

    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    normal: np.ndarray
    irradiance: np.ndarray  # (rows, columns, 3) float32

    def texel_centres(self) -> np.ndarray:
        """(rows, columns, 3) world positions of the texels' centres."""
        rows, columns = self.irradiance.shape[:2]
        s, t = (np.arange(columns) + 0.5) / columns, (np.arange(rows) + 0.5) / rows
        return self.origin + s[None, :, None] * self.u + t[:, None, None] * self.v


def open_irradiance(image: np.ndarray, normal=(0.0, 1.0, 0.0)) -> np.ndarray:
    """(3,) irradiance a surface facing ``normal`` receives from the equirectangular ``image`` with nothing in
    the way: sum over texels of radiance max(0, cos) solid angle."""
    directions, solid_angle = texel_grid(*image.shape[:2])
    cos = np.maximum(directions @ np.asarray(normal, np.float64), 0.0)
    return np.einsum("hwc,hw->c", image.astype(np.float64), cos * solid_angle)


def bake_floor(scene, floor, ambient: Environment, sun=None, size: int = BAKE_SIZE,
               samples: int = BAKE_SAMPLES) -> LightMap:
    """The :class:`LightMap` of ``floor``'s top face (one of ``scene.objects``, flat, horizontal) under the
    ``ambient`` environment; ``sun`` (a DirectionalLight or None) lights the surfaces the rays bounce off, as the
    scene's lights do."""
    low, high = floor.world_mesh().bounds.astype(np.float64)
    origin = np.array([low[0], high[1], low[2]])
    rectangle = (origin, np.array([high[0] - low[0], 0.0, 0.0]), np.array([0.0, 0.0, high[2] - low[2]]),
                 np.array([0.0, 1.0, 0.0]))
    return bake_rectangles(scene, [rectangle], (size, size), ambient, sun, samples, floor.name)[0]


def box_faces(obj) -> list[tuple] | None:
    """The six faces of ``obj`` as rectangles (origin, u, v, outward normal; world units), or None where its mesh
    is not a box: every vertex at a corner of its bounding box (a box under any rotation, scale, translation)."""
    mesh = obj.mesh
    low, high = mesh.vertices.min(axis=0).astype(np.float64), mesh.vertices.max(axis=0).astype(np.float64)
    tolerance = 1e-6 * max(float(np.linalg.norm(high - low)), 1e-30)
    at_corner = (np.abs(mesh.vertices - low) <= tolerance) | (np.abs(mesh.vertices - high) <= tolerance)
    if not at_corner.all() or np.any(high - low <= tolerance):
        return None
    world = obj.world_from_object()
    to_world = lambda p: world[:3, :3] @ p + world[:3, 3]  # noqa: E731
    normal_from_object = np.linalg.inv(world[:3, :3]).T
    faces = []
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        for side, corner in ((-1.0, low), (1.0, high)):
            origin = low.copy()
            origin[axis] = corner[axis]
            u, v = np.zeros(3), np.zeros(3)
            u[a], v[b] = high[a] - low[a], high[b] - low[b]
            n = np.zeros(3)
            n[axis] = side
            n = normal_from_object @ n
            faces.append((to_world(origin), to_world(origin + u) - to_world(origin),
                          to_world(origin + v) - to_world(origin), n / np.linalg.norm(n)))
    return faces


def plane_of(obj) -> tuple[np.ndarray, np.ndarray] | None:
    """(a point, the unit normal the faces turn to) of ``obj``'s world mesh where every vertex lies within
    PLANE_TOLERANCE of its size off one plane (a wall, a backdrop, a chart's squares), else None."""
    mesh = obj.world_mesh()
    vertices = mesh.vertices.astype(np.float64)
    triangles = vertices[mesh.faces]
    normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]).sum(axis=0)
    length, size = float(np.linalg.norm(normal)), float(np.linalg.norm(np.ptp(vertices, axis=0)))
    if not length > 0.0 or not size > 0.0:
        return None
    normal /= length
    centre = vertices.mean(axis=0)
    if np.abs((vertices - centre) @ normal).max() > PLANE_TOLERANCE * size:
        return None
    return centre, normal


def plane_rectangle(objects: list, centre: np.ndarray, normal: np.ndarray) -> tuple:
    """The rectangle (origin, u, v, normal) in the plane (``centre``, ``normal``) that holds every vertex of
    ``objects`` (coplanar): edges along the world axis nearest the plane, and the normal's cross with it."""
    axis = np.eye(3)[int(np.argmin(np.abs(normal)))]
    u = axis - (axis @ normal) * normal
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    vertices = np.concatenate([o.world_mesh().vertices.astype(np.float64) for o in objects]) - centre
    s, t = vertices @ u, vertices @ v
    origin = centre + s.min() * u + t.min() * v
    return origin, (s.max() - s.min()) * u, (t.max() - t.min()) * v, normal


def receiver_rectangles(obj) -> list[tuple]:
    """(origin, u, v, unit normal of the front side) of each flat side the diffuse ``obj`` offers: a box's six
    faces, outward; a flat object's plane, both sides; none otherwise."""
    faces = box_faces(obj)
    if faces is not None:
        return faces
    plane = plane_of(obj)
    if plane is None:
        return []
    origin, u, v, normal = plane_rectangle([obj], *plane)
    return [(origin, u, v, normal), (origin, u, v, -normal)]


def contact_tolerance(points: np.ndarray) -> float:
    """How far off a receiver's plane the glass whose vertices (or bounds) are ``points`` still touches it:
    CONTACT_TOLERANCE of its bounding radius."""
    return CONTACT_TOLERANCE * 0.5 * float(np.linalg.norm(np.ptp(np.asarray(points, np.float64), axis=0)))


def standing_plane(scene, glass) -> np.ndarray | None:
    """(4,) float64: the front normal n and offset w (n . x = w on it) of the flat diffuse receiver (a flat object, a
    box's face) that ``glass`` stands on: faces of it making at least STANDING_SHARE of its area lie on that plane
    (their vertices within CONTACT_TOLERANCE of its radius) and inside the receiver's rectangle, no vertex behind
    it; None where it stands on none (a ball touches in a point)."""
    mesh = glass.world_mesh()
    vertices = mesh.vertices.astype(np.float64)
    tolerance = contact_tolerance(vertices)
    area = None
    for other in scene.objects:
        if other is glass or other.material.kind != "diffuse":
            continue
        for origin, u, v, normal in receiver_rectangles(other):
            height = (vertices - origin) @ normal
            touching = np.abs(height) <= tolerance
            if height.min() < -tolerance or touching.sum() < 3:
                continue
            if area is None:
                corners = vertices[mesh.faces]
                area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
            lying = touching[mesh.faces].all(axis=1)
            if area[lying].sum() < STANDING_SHARE * area.sum():
                continue
            touching = vertices[mesh.faces[lying].ravel()] - origin
            st = np.stack([touching @ u / (u @ u), touching @ v / (v @ v)])
            if st.min() >= -CONTACT_TOLERANCE and st.max() <= 1.0 + CONTACT_TOLERANCE:
                return np.append(normal, origin @ normal)
    return None


def without_standing_faces(scene):
    """``scene`` with each glass object's faces that lie on the receiver it stands on (:func:`standing_plane`) taken
    out of its mesh, or ``scene`` itself where no glass stands on one; kept on the scene while its state stays."""
    return kept_on(scene, "_without_standing_faces", standing_key(scene), lambda: _without_standing_faces(scene))


def standing_key(scene) -> tuple:
    """What :func:`standing_plane` depends on: each object's mesh, placement and material kind (cheap per frame)."""
    return tuple((id(o.mesh), o.mesh.content_hash(), o.world_from_object().tobytes(), o.material.kind)
                 for o in scene.objects)


def _without_standing_faces(scene):
    objects, changed = list(scene.objects), False
    for i, obj in enumerate(objects):
        plane = standing_plane(scene, obj) if obj.material.kind == "glass" else None
        if plane is None:
            continue
        world = obj.world_mesh()
        on_plane = np.abs(world.vertices.astype(np.float64) @ plane[:3] - plane[3]) <= contact_tolerance(world.vertices)
        keep = ~on_plane[obj.mesh.faces].all(axis=1)
        mesh = obj.mesh
        objects[i] = replace(obj, mesh=Mesh(mesh.vertices, mesh.normals, mesh.faces[keep], mesh.name + "-standing",
                                            uvs=mesh.uvs))
        changed = True
    return replace(scene, objects=objects) if changed else scene


def bake_rectangles(scene, rectangles: list[tuple], size: tuple[int, int], ambient: Environment, sun=None,
                    samples: int = BAKE_SAMPLES, label: str = "") -> list[LightMap]:
    """A :class:`LightMap` of ``size`` (columns, rows) per rectangle (origin, u, v, normal) under the ``ambient``
    environment (see the module docstring), texels inside an opaque object filled from their neighbours, those
    inside glass gathered from within it."""
    columns, rows = size
    # The rays see the ambient environment; the surfaces they bounce off are lit by the lights and the sun.
    lit = replace(scene, lights=[*scene.lights, *([sun] if sun is not None else [])], intensity_scale=1.0)
    rays = ray_scene_for(without_standing_faces(scene))
    materials = Materials.of(scene)
    glass = materials.kind == MATERIAL_GLASS
    sampling = EnvironmentSampling(environment_light(ambient, bright=0.0), samples, 0, True)
    maps = [LightMap(o, u, v, n, np.zeros((rows, columns, 3), np.float32)) for o, u, v, n in rectangles]
    with progress(len(maps) * rows * columns, f"baking the environment's light on {label} ({len(maps)} x "
                  f"{columns}x{rows} texels, {samples} rays)", unit="texels") as bar:
        for k, light_map in enumerate(maps):
            points = light_map.texel_centres().reshape(-1, 3)
            normal = np.broadcast_to(light_map.normal, points.shape)
            inside = _inside(rays, points + normal * rays.epsilon)
            in_glass = np.where(inside >= 0, glass[np.maximum(inside, 0)], False)
            shadowed = cosine_gather(rays, lit, points, normal, normal, sampling, materials, materials.ior_rgb[:, 0],
                                     less_open=True, done=bar.update, medium=np.where(in_glass, inside, -1))
            irradiance = open_irradiance(ambient.image, light_map.normal) + np.pi * shadowed
            opaque = (inside >= 0) & ~in_glass
            filled = _fill(irradiance.reshape(rows, columns, 3), opaque.reshape(rows, columns))
            maps[k] = replace(light_map, irradiance=np.maximum(filled, 0.0).astype(np.float32))
    return maps


def _inside(rays, origins: np.ndarray) -> np.ndarray:
    """Per origin, the index of the closed object it lies inside (the ray straight up leaves it through a back
    face), -1 where none."""
    up = np.tile([0.0, 1.0, 0.0], (len(origins), 1))
    hits = rays.intersect(origins, up)
    return np.where(hits.hit & (hits.geometric_normal[:, 1] > 0.0), hits.object_index, -1)


def _fill(values: np.ndarray, invalid: np.ndarray) -> np.ndarray:
    """``values`` (n, n, 3) with each ``invalid`` texel replaced, ring by ring from the valid ones, by the mean
    of its valid 4-neighbours."""
    values, invalid = values.copy(), invalid.copy()
    if invalid.all():
        return values
    while invalid.any():
        valid = ~invalid
        total = np.zeros_like(values)
        count = np.zeros(invalid.shape)
        for axis, shift in ((0, 1), (0, -1), (1, 1), (1, -1)):
            moved_valid = np.roll(valid, shift, axis=axis)
            moved = np.roll(values, shift, axis=axis)
            edge = [slice(None)] * 2
            edge[axis] = 0 if shift == 1 else -1
            moved_valid[tuple(edge)] = False  # no wrapping around
            total += np.where(moved_valid[..., None], moved, 0.0)
            count += moved_valid
        reached = invalid & (count > 0)
        values[reached] = total[reached] / count[reached][:, None]
        invalid &= ~reached
    return values


def bake_vertices(scene, obj, ambient: Environment, sun=None, samples: int = BAKE_SAMPLES,
                  cap: int = VERTEX_CAP) -> tuple[np.ndarray, int]:
    """((vertices, 3) float32, baked): the irradiance of the ``ambient`` environment at each vertex of ``obj``'s
    mesh, on the side its normals face (gathered as a rectangle's texel is: occluded, through glass, one bounce,
    the open irradiance in closed form). A mesh of more than ``cap`` vertices bakes ``cap`` or fewer of them
    (one per cell of a grid and normal direction, _spread) and gives every other vertex the mean of its four
    nearest baked ones, weighted by inverse distance and by how far their normals agree; ``baked`` says how
    many were baked."""
    mesh = obj.world_mesh()
    points, normals = mesh.vertices.astype(np.float64), mesh.normals.astype(np.float64)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    chosen = _spread(points, normals, cap)
    lit = replace(scene, lights=[*scene.lights, *([sun] if sun is not None else [])], intensity_scale=1.0)
    rays = ray_scene_for(without_standing_faces(scene))
    materials = Materials.of(scene)
    sampling = EnvironmentSampling(environment_light(ambient, bright=0.0), samples, 0, True)
    with progress(len(chosen), f"baking the environment's light on {obj.name} ({len(chosen)} of {len(points)} "
                  f"vertices, {samples} rays)", unit="vertices") as bar:
        at, towards = points[chosen], normals[chosen]
        shadowed = cosine_gather(rays, lit, at, towards, towards, sampling, materials, materials.ior_rgb[:, 0],
                                 less_open=True, done=bar.update)
    baked = np.maximum(open_irradiances(ambient.image, towards) + np.pi * shadowed, 0.0)
    if len(chosen) == len(points):
        return baked.astype(np.float32), len(chosen)
    return _spread_to(points, normals, chosen, baked).astype(np.float32), len(chosen)


def open_irradiances(image: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(n, 3): :func:`open_irradiance` for each of ``normals`` (n, 3), 256 at a time."""
    directions, solid_angle = texel_grid(*image.shape[:2])
    weighted = image.astype(np.float64).reshape(-1, 3) * solid_angle.reshape(-1, 1)
    directions = directions.reshape(-1, 3)
    out = np.empty((len(normals), 3))
    for start in range(0, len(normals), 256):
        cos = np.maximum(normals[start:start + 256] @ directions.T, 0.0)
        out[start:start + 256] = cos @ weighted
    return out


def _spread(points: np.ndarray, normals: np.ndarray, cap: int) -> np.ndarray:
    """Indices of at most ``cap`` of ``points``, all where there are no more: the first vertex in each cell of
    the coarsest-first grids (cells halved in number until they fit) and of each of the six axis directions its
    normal is nearest, so that both sides of a thin part keep a vertex."""
    if len(points) <= cap:
        return np.arange(len(points))
    low, extent = points.min(axis=0), max(float(np.ptp(points, axis=0).max()), 1e-30)
    side = np.abs(normals).argmax(axis=1) * 2 + (normals[np.arange(len(normals)), np.abs(normals).argmax(axis=1)] > 0)
    cells = int(np.ceil((cap / 6.0) ** (1.0 / 2.0))) * 2  # a surface fills about cells^2 of cells^3
    while True:
        index = np.minimum(((points - low) / extent * cells).astype(np.int64), cells - 1)
        key = ((index[:, 0] * cells + index[:, 1]) * cells + index[:, 2]) * 6 + side
        _, first = np.unique(key, return_index=True)
        if len(first) <= cap or cells <= 1:
            return np.sort(first)
        cells = max(1, int(cells / 1.25))


def _spread_to(points: np.ndarray, normals: np.ndarray, chosen: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Per vertex, the mean of ``values`` at its four nearest ``chosen`` vertices, weighted by 1 / (distance +
    a hundredth of the mean spacing) times max(0, the normals' cosine)^2 (the nearest alone where none agrees);
    the chosen keep theirs."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points[chosen])
    distance, nearest = tree.query(points, k=min(4, len(chosen)))
    distance, nearest = distance.reshape(len(points), -1), nearest.reshape(len(points), -1)
    spacing = max(float(distance[:, -1].mean()), 1e-30)
    agree = np.maximum(np.einsum("ij,ikj->ik", normals, normals[chosen][nearest]), 0.0) ** 2
    weight = agree / (distance + 0.01 * spacing)
    weight[weight.sum(axis=1) <= 0.0, 0] = 1.0
    out = np.einsum("ik,ikc->ic", weight, values[nearest]) / weight.sum(axis=1, keepdims=True)
    out[chosen] = values
    return out


def same_plane(plane, known, offset_tolerance: float, normal_tolerance: float = 1e-6) -> bool:
    """Whether ``plane`` and ``known`` ((a point, a unit normal) each; either side) are one plane: their normals
    parallel within ``normal_tolerance`` and the point of ``plane`` within ``offset_tolerance`` of ``known``'s."""
    return (abs(abs(float(np.dot(plane[1], known[1]))) - 1.0) < normal_tolerance
            and abs(float(np.dot(plane[0] - known[0], known[1]))) < offset_tolerance)
