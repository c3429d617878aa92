"""Scenes of Kakimoto et al. (per-vertex reflection and refraction), as built-in presets.

Mirrors are tessellated height fields (:func:`curved_mirror`): the paper's
49-vertex door mirror is ``resolution=6``. A test chart (:func:`test_chart`)
is a checkerboard of small coloured quads, one diffuse object per colour
Every preset function takes ``markers=True`` to add the paper's red marker
balls at the exact hits of the reflector vertices' rays (:func:`add_markers`),
and most take ``resolution`` (mirror cells a side, lens rings).
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .camera import Camera
from .environment import procedural_environment
from .lights import DirectionalLight
from .materials import Diffuse, Glass, Mirror
from .mesh import Mesh
from .scene import Scene, SceneObject
from .shapes import biconcave_lens, biconvex_lens, box, plane, sphere
from .transform import Transform

# fig. 15: one IOR per colour channel; the preset's Abbe number gives about these in `exact`.
ABERRATION_IOR_RGB = (1.60, 1.61, 1.62)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _frame_to(normal, up_hint=(0.0, 1.0, 0.0)) -> np.ndarray:
    """Rotation taking +Y to ``normal``, +Z towards ``up_hint`` (columns: x, y, z axes)."""
    y = _unit(normal)
    hint = np.asarray(up_hint, dtype=np.float64)
    if abs(np.dot(hint, y)) > 0.99:
        hint = np.array([0.0, 0.0, 1.0]) if abs(y[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    z = _unit(hint - np.dot(hint, y) * y)
    return np.stack([np.cross(y, z), y, z], axis=1)


def curved_mirror(width: float = 1.0, depth: float = 1.0, radius: float = math.inf, resolution: int = 6,
                  shape: str = "sphere", x_range=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A mirror height field facing +Y over [-width/2, width/2] x [-depth/2, depth/2] (x, z).

    ``shape``: 'sphere' (radius > 0 convex towards +Y, < 0 concave, inf flat),
    'cylinder' (curved along x only), 'saddle' (y = (x^2 - z^2) / (2 radius)).
    ``x_range`` overrides the x extent (for patches cut from one surface).
    Returns (vertices, normals, faces) with (resolution + 1)^2 vertices.
    """
    n = int(resolution) + 1
    x0, x1 = x_range if x_range is not None else (-width / 2.0, width / 2.0)
    x, z = np.meshgrid(np.linspace(x0, x1, n), np.linspace(-depth / 2.0, depth / 2.0, n), indexing="ij")
    k = 0.0 if not np.isfinite(radius) else 1.0 / radius
    if shape == "saddle":
        y, gx, gz = (x * x - z * z) * k / 2.0, x * k, -z * k
    else:
        r2 = x * x + (z * z if shape == "sphere" else 0.0)
        if k == 0.0:
            y, gx, gz = np.zeros_like(x), np.zeros_like(x), np.zeros_like(x)
        else:
            root = np.sqrt(radius * radius - r2)
            y = np.sign(radius) * (root - abs(radius))
            gx = -np.sign(radius) * x / root
            gz = -np.sign(radius) * (z / root if shape == "sphere" else 0.0 * z)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    normals = np.stack([-gx, np.ones_like(y), -gz], axis=-1).reshape(-1, 3)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).reshape(-1)
    b, c, d = a + 1, a + n + 1, a + n  # rows follow x, columns z: (d/dz) x (d/dx) = +Y
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return vertices, normals, faces


def mirror_object(name: str, part, center, normal, up_hint=(0.0, 1.0, 0.0), color=(0.95, 0.95, 0.95)) -> SceneObject:
    """A mirror height field placed in the world: its +Y towards ``normal``, centred at ``center``."""
    vertices, normals, faces = part
    rotation = _frame_to(normal, up_hint)
    mesh = Mesh(vertices @ rotation.T + np.asarray(center, dtype=np.float64), normals @ rotation.T, faces, name=name)
    return SceneObject(name, mesh, Mirror(color=list(color)))


def _quads(centres, size: float, normal_axis: int = 2) -> Mesh:
    """Axis-aligned square quads facing +Z (``normal_axis`` 2) centred at ``centres``."""
    centres = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
    h = size / 2.0
    corners = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
    vertices = (centres[:, None, :] + corners[None]).reshape(-1, 3)
    base = 4 * np.arange(len(centres))[:, None]
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]])
    normals = np.tile([0.0, 0.0, 1.0], (len(vertices), 1))
    return Mesh(vertices, normals, faces, name="chart")


CHART_COLORS = {
    "white": (0.85, 0.85, 0.85), "dark": (0.08, 0.08, 0.08), "red": (0.8, 0.1, 0.1), "green": (0.1, 0.7, 0.15),
    "blue": (0.1, 0.2, 0.8), "yellow": (0.85, 0.75, 0.1),
}


def test_chart(center=(0.0, 0.0, 0.0), size: float = 2.0, cells: int = 12) -> list[SceneObject]:
    """A checkerboard test chart facing +Z at ``center``: one diffuse object per colour

    Squares overlap by 0.1 percent, so that no ray slips between them. Dark and white alternate; the four quadrants' corner squares and the centre
    cross carry red, green, blue and yellow so that orientation (a reversed image) shows.
    """
    cell = size / cells
    coords = (np.arange(cells) - (cells - 1) / 2.0) * cell
    groups: dict[str, list] = {name: [] for name in CHART_COLORS}
    mid = cells // 2
    for i, x in enumerate(coords):
        for j, y in enumerate(coords):
            name = "white" if (i + j) % 2 else "dark"
            if i < 2 and j >= cells - 2:
                name = "red"  # top left
            elif i >= cells - 2 and j >= cells - 2:
                name = "green"  # top right
            elif i < 2 and j < 2:
                name = "blue"  # bottom left
            elif i in (mid - 1, mid) and j in (mid - 1, mid):
                name = "yellow"
            groups[name].append(np.asarray(center, dtype=np.float64) + [x, y, 0.0])
    return [SceneObject(f"chart-{name}", _quads(points, cell * 1.001), Diffuse(color=list(CHART_COLORS[name])))
            for name, points in groups.items() if points]


def _sky(name, camera, objects, lights=(), markers: bool = False) -> Scene:
    scene = Scene(camera=camera, objects=list(objects), lights=list(lights),
                  environment=procedural_environment("sky-checker"), name=name)
    return add_markers(scene) if markers else scene


_SUN = DirectionalLight(direction=[-0.4, -1.0, -0.3], intensity=[2.5, 2.5, 2.5])


def _street(length: float = 40.0) -> list[SceneObject]:
    """A street of coloured boxes behind the car (+Z), a grey road and pavements."""
    objects = [SceneObject("road", plane((30.0, length + 10.0)), Diffuse(color=[0.35, 0.35, 0.37]),
                           Transform(position=[0.0, 0.0, length / 2.0]))]
    rng = np.random.default_rng(7)
    palette = [(0.8, 0.2, 0.15), (0.2, 0.5, 0.8), (0.85, 0.75, 0.2), (0.25, 0.7, 0.3), (0.7, 0.7, 0.72),
               (0.6, 0.3, 0.7)]
    for side in (-1.0, 1.0):
        z = 3.0
        k = 0
        while z < length:
            depth, height = rng.uniform(2.0, 4.0), rng.uniform(2.0, 7.0)
            objects.append(SceneObject(f"house{int(side)}-{k}", box((3.0, height, depth)),
                                       Diffuse(color=list(palette[(k + (side > 0)) % len(palette)])),
                                       Transform(position=[side * 5.5, height / 2.0, z + depth / 2.0])))
            z += depth + rng.uniform(0.3, 1.5)
            k += 1
    for k, (x, z, color) in enumerate([(-1.8, 8.0, (0.9, 0.1, 0.1)), (1.5, 14.0, (0.1, 0.3, 0.9)),
                                       (-1.0, 22.0, (0.95, 0.95, 0.95))]):
        objects.append(SceneObject(f"car-{k}", box((1.8, 1.4, 4.0)), Diffuse(color=list(color)),
                                   Transform(position=[x, 0.7, z])))
    return objects


def door_mirror(resolution: int = 6, radius: float = 1.2, markers: bool = False, size=(512, 512)) -> Scene:
    """fig. 1 and 5: a moderately curved convex door mirror (7 x 7 = 49 vertices) over a street of boxes.

    The driver's eye is 0.8 right of and 0.6 ahead of a 0.26 x 0.18 mirror of curvature radius
    ``radius``, turned so that it shows the street behind the car.
    """
    eye = np.array([0.0, 1.2, 0.0])
    center = np.array([-0.8, 1.1, -0.6])
    incoming = _unit(center - eye)
    outgoing = _unit([0.12, -0.03, 1.0])
    normal = _unit(outgoing - incoming)
    mirror = mirror_object("door-mirror", curved_mirror(0.26, 0.18, radius, resolution), center, normal)
    camera = Camera(position=eye, look_at=center, fov_y=16.0, size=size)
    return _sky("door-mirror", camera, [mirror, *_street()], [_SUN], markers)


def _gallery(z_wall: float = 5.0) -> list[SceneObject]:
    """What the mirror series reflects: a floor, a chart behind the camera, coloured boxes nearby."""
    objects = [SceneObject("floor", plane((12.0, 12.0)), Diffuse(color=[0.6, 0.6, 0.6]),
                           Transform(position=[0.0, -1.0, 2.0]))]
    chart = test_chart(center=(0.0, 0.5, z_wall), size=4.0, cells=10)
    for obj in chart:  # face the mirror (-Z): mirror the quads about their plane's normal
        mesh = obj.mesh
        flipped = Mesh(mesh.vertices, -mesh.normals, mesh.faces[:, ::-1], name=mesh.name)
        objects.append(SceneObject(obj.name, flipped, obj.material))
    for k, (x, y, z, color) in enumerate([(-0.9, -0.6, 1.2, (0.9, 0.2, 0.1)), (0.8, -0.5, 0.8, (0.1, 0.6, 0.9)),
                                          (0.0, -0.7, 1.8, (0.2, 0.8, 0.2))]):
        objects.append(SceneObject(f"block-{k}", box((0.4, 0.6, 0.4)), Diffuse(color=list(color)),
                                   Transform(position=[x, y, z])))
    return objects


def mirror_series(radius: float = 2.0, resolution: int = 12, markers: bool = False, size=(512, 512)) -> Scene:
    """fig. 9: a 1.2 x 1.2 spherical mirror of curvature radius ``radius`` (> 0 convex,
    < 0 concave, inf flat) facing the camera, a chart behind the camera, blocks in between."""
    mirror = mirror_object("mirror", curved_mirror(1.2, 1.2, radius, resolution), [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    camera = Camera(position=[0.3, 0.4, 3.2], look_at=[0.0, 0.0, 0.0], fov_y=30.0, size=size)
    return _sky(f"mirror-series-{radius:g}", camera, [mirror, *_gallery()], [_SUN], markers)


def saddle_mirror(resolution: int = 12, radius: float = 1.5, shape: str = "saddle", markers: bool = False,
                  size=(512, 512)) -> Scene:
    """4.3 and fig. 10: a saddle (or, with ``shape`` 'cylinder', cylindrical) mirror."""
    mirror = mirror_object("mirror", curved_mirror(1.2, 1.2, radius, resolution, shape), [0.0, 0.0, 0.0],
                           [0.0, 0.0, 1.0])
    camera = Camera(position=[0.3, 0.4, 3.2], look_at=[0.0, 0.0, 0.0], fov_y=30.0, size=size)
    return _sky(f"{shape}-mirror", camera, [mirror, *_gallery()], [_SUN], markers)


def mirror_patches(resolution: int = 6, radius: float = 1.5, markers: bool = False, size=(512, 512)) -> Scene:
    """fig. 7: two adjacent mirrors cut from one convex surface, sharing the 7 vertices of their seam."""
    parts = [curved_mirror(1.2, 1.2, radius, resolution, x_range=r) for r in ((-0.6, 0.0), (0.0, 0.6))]
    mirrors = [mirror_object(f"mirror-{side}", part, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
               for side, part in zip(("left", "right"), parts)]
    camera = Camera(position=[0.3, 0.4, 3.2], look_at=[0.0, 0.0, 0.0], fov_y=30.0, size=size)
    return _sky("mirror-patches", camera, [*mirrors, *_gallery()], [_SUN], markers)


def mirror_in_mirror(resolution: int = 8, markers: bool = False, size=(512, 512)) -> Scene:
    """fig. 11: a mirror seen in a mirror. The camera faces a slightly convex mirror that
    reflects a second, flat mirror beside the camera, which shows coloured blocks."""
    first = mirror_object("mirror-front", curved_mirror(1.2, 1.0, 3.0, resolution), [0.0, 0.0, 0.0],
                          _unit([0.35, 0.0, 1.0]))
    second = mirror_object("mirror-side", curved_mirror(1.0, 1.0, math.inf, resolution), [1.7, 0.0, 2.2],
                           _unit([-1.0, 0.0, -0.15]))
    objects = [first, second, SceneObject("floor", plane((14.0, 14.0)), Diffuse(color=[0.6, 0.6, 0.6]),
                                          Transform(position=[0.0, -1.0, 0.0]))]
    for k, (z, color) in enumerate([(1.0, (0.9, 0.2, 0.1)), (2.2, (0.2, 0.8, 0.2)), (3.4, (0.1, 0.3, 0.9))]):
        objects.append(SceneObject(f"block-{k}", box((0.4, 0.8, 0.4)), Diffuse(color=list(color)),
                                   Transform(position=[-1.8, -0.6, z])))
    camera = Camera(position=[-0.4, 0.2, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=35.0, size=size)
    return _sky("mirror-in-mirror", camera, objects, [_SUN], markers)


def spectacle_lens(concave: bool = False, eye_distance: float = 0.7, chart_distance: float = 0.5, rings: int = 12,
                   segments: int = 48, ior: float = 1.5, abbe: float | None = None, markers: bool = False,
                   size=(512, 512), name: str | None = None) -> Scene:
    """fig. 12-14: a spectacle lens (radius 0.25, axis Z) between the eye and a test chart.

    Convex: thickness 0.1 (focal length about 0.72 at IOR 1.5); the chart ``chart_distance``
    behind the lens, inside the focal length, looks magnified and upright. Concave: centre
    0.03, edge 0.1 thick. fig. 13's reversed image: ``eye_distance`` 7.6, chart 2.0.
    """
    mesh = (biconcave_lens(0.25, 0.03, 0.1, segments, rings) if concave
            else biconvex_lens(0.25, 0.1, 0.01, segments, rings))
    lens = SceneObject("lens", mesh, Glass(ior=ior, abbe=abbe))
    chart_size = 0.8 if chart_distance < 1.0 else 1.6
    objects = [lens, *test_chart(center=(0.0, 0.0, -chart_distance), size=chart_size, cells=12)]
    fov = 2.0 * math.degrees(math.atan(0.3 / eye_distance))
    camera = Camera(position=[0.0, 0.0, eye_distance], look_at=[0.0, 0.0, 0.0], fov_y=fov, near=0.01, size=size)
    label = name or ("spectacle-concave" if concave else "spectacle-convex")
    return _sky(label, camera, objects, [], markers)


def aberration_lens(markers: bool = False, size=(512, 512), rings: int = 16, segments: int = 64) -> Scene:
    """fig. 15: a convex lens with colour aberration, IOR about 1.60/1.61/1.62 (red/green/blue) from an
    Abbe number of 31 (render with ``ior_rgb=ABERRATION_IOR_RGB`` for the paper's exact three)."""
    return spectacle_lens(False, 0.7, 0.5, rings, segments, ior=1.606, abbe=31.0, markers=markers, size=size,
                          name="aberration-lens")


def add_markers(scene: Scene, radius: float | None = None, color=(0.9, 0.05, 0.05)) -> Scene:
    """The paper's red marker balls: one at the exact hit of every mirror or lens vertex's ray.

    Lens vertices use the twice-refracted ray (green IOR). Returns a new scene with one extra
    object holding all the balls.
    """
    from ..per_vertex.rays import double_refraction, reflection_rays, trace_lines
    from ..raytrace.embree_scene import ray_scene_for

    ray_scene = ray_scene_for(scene)
    eye = scene.camera.position
    points = []
    for index, obj in enumerate(scene.objects):
        mesh = obj.world_mesh()
        p, n = mesh.vertices.astype(np.float64), mesh.normals.astype(np.float64)
        if obj.material.kind == "mirror":
            origins, dirs = reflection_rays(eye, p, n)
        elif obj.material.kind == "glass":
            facing = np.einsum("ij,ij->i", n, p - eye) < 0
            refracted = double_refraction(ray_scene, index, eye, p[facing], n[facing], float(obj.material.ior_rgb[1]))
            origins, dirs = refracted.origins[refracted.valid], refracted.directions[refracted.valid]
        else:
            continue
        lines, _ = trace_lines(ray_scene, origins, dirs)
        points.append(lines.hit_points[lines.finite])
    if not points or not len(np.concatenate(points)):
        return scene
    points = np.concatenate(points)
    if radius is None:
        radius = 0.004 * float(np.linalg.norm(np.ptp(scene.bounds(), axis=0)))
    ball = sphere(radius, subdivisions=1)
    count = len(ball.vertices)
    vertices = (ball.vertices[None].astype(np.float64) + points[:, None]).reshape(-1, 3)
    faces = (ball.faces[None] + count * np.arange(len(points))[:, None, None]).reshape(-1, 3)
    mesh = Mesh(vertices, np.tile(ball.normals, (len(points), 1)), faces, name="markers")
    marked = SceneObject("markers", mesh, Diffuse(color=list(color)))
    return Scene(camera=scene.camera, objects=[*scene.objects, marked], lights=scene.lights,
                 environment=scene.environment, intensity_scale=scene.intensity_scale, name=scene.name + "-markers")


def _variant(name: str, doc: str, make: Callable[[], Scene]) -> Callable[[], Scene]:
    """A preset built by another preset function with other arguments, under its own name."""

    def preset() -> Scene:
        scene = make()
        scene.name = name
        return scene

    preset.__doc__ = doc
    return preset


PER_VERTEX_PRESETS: dict[str, Callable[[], Scene]] = {
    "door-mirror": door_mirror,
    "mirror-convex": _variant("mirror-convex", "fig. 9: a convex mirror (curvature radius 2) of the convex-to-concave series.",
                              lambda: mirror_series(2.0)),
    "mirror-flat": _variant("mirror-flat", "fig. 9: the flat mirror of the series (the virtual viewpoint is the eye's mirror image).",
                            lambda: mirror_series(math.inf)),
    "mirror-concave": _variant("mirror-concave", "fig. 9: a concave mirror (curvature radius 2) with its zooming region.",
                               lambda: mirror_series(-2.0)),
    "saddle-mirror": saddle_mirror,
    "cylinder-mirror": _variant("cylinder-mirror", "4.3: a cylindrical mirror (up vector on a principal direction).",
                                lambda: saddle_mirror(shape="cylinder")),
    "mirror-patches": mirror_patches,
    "mirror-in-mirror": mirror_in_mirror,
    "spectacle-convex": spectacle_lens,
    "spectacle-concave": _variant("spectacle-concave", "fig. 14: a concave spectacle lens over the test chart.",
                                  lambda: spectacle_lens(concave=True, eye_distance=0.6)),
    "lens-far": _variant("lens-far", "fig. 13: a convex lens far from the eye shows the chart reversed.",
                         lambda: spectacle_lens(eye_distance=7.6, chart_distance=2.0, name="lens-far")),
    "aberration-lens": aberration_lens,
}
"""Presets of the per-vertex technique (Kakimoto et al.), merged into ``presets.PRESETS``."""
