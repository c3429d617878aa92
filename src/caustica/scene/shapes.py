"""Procedural meshes with analytic normals, in object space, centred at the origin.

Faces are counter-clockwise seen from outside. Closed shapes are watertight once
coincident vertices are merged: hard edges (box edges, cylinder caps, lens rims)
repeat their vertices with each side's own normal.

Most shapes are built from one of two parametric grids whose triangle normal is
dP/dcol x dP/drow: surfaces of revolution about +Y (columns go around the axis,
rows follow a profile walked counter-clockwise in the (r, y) half plane, so the
normal points outward) and tubes around a closed curve.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import short
from . import rules
from .mesh import Mesh, split_at_midpoints


MAX_WAVE_SAMPLES = 1 << 24  # grid vertices times waves of a water surface (each a float64 in a few arrays)


# Grid helpers ------------------------------------------------------------------


def _positive(**values) -> None:
    """ValueError naming the first parameter that is not a positive number of at most rules.MAX_COORDINATE."""
    for name, value in values.items():
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            arr = np.array(np.nan)
        if not np.all(np.isfinite(arr) & (arr > 0) & (arr <= rules.MAX_COORDINATE)):
            raise ValueError(f"{name} must be positive and at most {rules.MAX_COORDINATE:g} (got {short(value)})")


def _dims(size, n: int, name: str = "size") -> np.ndarray:
    """``size`` as ``n`` positive numbers (a single number stands for all of them)."""
    try:
        arr = np.asarray(size, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        arr = np.array([np.nan])
    if arr.size == 1:
        arr = np.repeat(arr, n)
    if arr.size != n:
        raise ValueError(f"{name} must be one number or {n} numbers (got {short(size)})")
    _positive(**{name: arr})
    return arr


def _count(name: str, value: int, minimum: int, maximum: int = rules.MAX_TRIANGLES) -> int:
    """An integer resolution parameter in [minimum, maximum]."""
    return rules.integer(value, name, minimum, maximum)


def _budget(triangles: int, **params) -> None:
    """ValueError naming the resolution parameters when they would make more than rules.MAX_TRIANGLES triangles."""
    rules.triangles(triangles, " and ".join(f"{k} {v}" for k, v in params.items()) + " would make",
                    f"lower {' or '.join(params)}")


def _grid_faces(rows: int, cols: int, wrap_rows: bool = False, wrap_cols: bool = False) -> np.ndarray:
    """Two triangles per grid cell of a row-major vertex grid; normal = d/dcol x d/drow."""
    i, j = np.meshgrid(np.arange(rows if wrap_rows else rows - 1), np.arange(cols if wrap_cols else cols - 1),
                       indexing="ij")
    i, j = i.reshape(-1), j.reshape(-1)
    i1, j1 = (i + 1) % rows, (j + 1) % cols
    a, b, c, d = i * cols + j, i * cols + j1, i1 * cols + j1, i1 * cols + j
    return np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)])


def _merge(parts, name: str) -> Mesh:
    """One mesh from (vertices, normals, faces) parts, each indexing its own vertices."""
    offsets = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
    vertices = np.concatenate([p[0] for p in parts])
    normals = np.concatenate([p[1] for p in parts])
    faces = np.concatenate([p[2] + off for p, off in zip(parts, offsets)])
    return Mesh(vertices, normals, faces, name=name)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _revolve(r, y, nr, ny, segments: int, closed: bool = False):
    """Surface of revolution about +Y of a profile (r, y) with profile normals (nr, ny).

    The profile must run counter-clockwise in the (r, y) half plane for outward
    normals. Profile points with r = 0 are poles: their ring collapses to one
    vertex. ``closed`` joins the last profile point back to the first.
    """
    r, y, nr, ny = (np.asarray(a, dtype=np.float64) for a in (r, y, nr, ny))
    phi = 2.0 * np.pi * np.arange(segments) / segments
    s, c = np.sin(phi)[None, :], np.cos(phi)[None, :]
    shape = (len(r), segments)
    vertices = np.stack([r[:, None] * s, np.broadcast_to(y[:, None], shape), r[:, None] * c], axis=-1).reshape(-1, 3)
    normals = np.stack([nr[:, None] * s, np.broadcast_to(ny[:, None], shape), nr[:, None] * c], axis=-1).reshape(-1, 3)
    faces = _grid_faces(len(r), segments, wrap_rows=closed, wrap_cols=True)
    # Collapse each pole ring onto its first vertex, drop the degenerate triangles, compact.
    index = np.arange(len(vertices)).reshape(len(r), segments)
    index[r == 0.0] = index[r == 0.0][:, :1]
    faces = index.reshape(-1)[faces]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])]
    used, faces = np.unique(faces, return_inverse=True)
    return vertices[used], normals[used], faces.reshape(-1, 3)


def _strip(points, normal, segments: int):
    """A revolved straight profile segment with one constant profile normal (a flat or cylindrical band)."""
    (r0, y0), (r1, y1) = points
    return _revolve([r0, r1], [y0, y1], [normal[0]] * 2, [normal[1]] * 2, segments)


def _y_to_z(part):
    """Rotate a part by +90 degrees about X so that +Y becomes +Z (winding is kept)."""
    vertices, normals, faces = part
    swap = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    return vertices @ swap.T, normals @ swap.T, faces


# Shapes ------------------------------------------------------------------------


def sphere(radius: float = 1.0, subdivisions: int = 4) -> Mesh:
    """Icosphere: an icosahedron subdivided ``subdivisions`` times, exactly radial normals."""
    _positive(radius=radius)
    subdivisions = _count("subdivisions", subdivisions, 0, 64)
    _budget(20 * 4**subdivisions, subdivisions=subdivisions)
    t = (1.0 + math.sqrt(5.0)) / 2.0
    vertices = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=np.float64)
    faces = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                      [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                      [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    vertices = _unit(vertices)
    for _ in range(subdivisions):
        # Split every edge once at its midpoint (shared by both faces), four triangles per face.
        edges, faces = split_at_midpoints(faces, len(vertices))
        vertices = np.concatenate([vertices, _unit(vertices[edges].mean(axis=1))])
    return Mesh(vertices * radius, vertices, faces, name="sphere", analytic_sphere=(np.zeros(3), float(radius)))


def plane(size=(2.0, 2.0), resolution: int = 1, repeat=(1.0, 1.0)) -> Mesh:
    """A ``size`` = (width along X, depth along Z) rectangle at y = 0 facing +Y, ``resolution`` cells a side.

    Its uvs span [0, repeat]: u along +X, v along +Z, so that a texture seen from above with -Z up on the
    screen (a floor seen from the front) stands upright, ``repeat`` times along each side."""
    repeat = _dims(repeat, 2, "repeat")
    return heightfield(size, resolution, lambda x, z: (np.zeros_like(x),) * 3, "plane", uvs=repeat)


def heightfield(size, resolution: int, height, name: str, uvs=None) -> Mesh:
    """Grid over the XZ rectangle ``size``; ``height(x, z)`` returns (y, dy/dx, dy/dz); with ``uvs`` (two
    repeats), texture coordinates ((x / width + 1/2) uvs[0], (z / depth + 1/2) uvs[1])."""
    width, depth = _dims(size, 2)
    n = _count("resolution", resolution, 1) + 1
    _budget(2 * (n - 1) ** 2, resolution=n - 1)
    # Rows follow X and columns Z, so that d/dcol x d/drow = +Z x +X = +Y.
    x, z = np.meshgrid(np.linspace(-width / 2, width / 2, n), np.linspace(-depth / 2, depth / 2, n), indexing="ij")
    y, dydx, dydz = height(x, z)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    normals = _unit(np.stack([-dydx, np.ones_like(y), -dydz], axis=-1)).reshape(-1, 3)
    uv = None if uvs is None else (np.stack([x / width + 0.5, z / depth + 0.5], axis=-1) * uvs).reshape(-1, 2)
    return Mesh(vertices, normals, _grid_faces(n, n), name=name, uvs=uv)


def box(size=(1.0, 1.0, 1.0)) -> Mesh:
    """Axis-aligned box of edge lengths ``size``: 24 vertices, flat face normals, each face's uvs
    spanning [0, 1]^2."""
    half = _dims(size, 3) / 2.0
    vertices, normals, faces, uvs = [], [], [], []
    for axis in range(3):
        u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3  # e_u x e_v = e_axis
        for sign in (1.0, -1.0):
            normal = np.zeros(3)
            normal[axis] = sign
            corners = []
            for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):  # CCW about e_axis
                p = np.zeros(3)
                p[axis], p[u_axis], p[v_axis] = sign * half[axis], du * sign * half[u_axis], dv * half[v_axis]
                corners.append(p)
                uvs.append([(du + 1) / 2, (1 - dv) / 2])
            base = len(vertices)
            vertices += corners
            normals += [normal] * 4
            faces += [[base, base + 1, base + 2], [base, base + 2, base + 3]]
    return Mesh(np.array(vertices) * 1.0, np.array(normals), np.array(faces), name="box", uvs=np.array(uvs))


def torus(major_radius: float = 1.0, minor_radius: float = 0.3, segments: int = 96, sides: int = 48) -> Mesh:
    """Torus about the Y axis (lying in the XZ plane) with analytic normals."""
    _positive(major_radius=major_radius, minor_radius=minor_radius)
    if minor_radius >= major_radius:
        raise ValueError(f"minor_radius ({minor_radius}) must be smaller than major_radius ({major_radius})")
    sides, segments = _count("sides", sides, 3), _count("segments", segments, 3)
    _budget(2 * sides * segments, segments=segments, sides=sides)
    theta = 2.0 * np.pi * np.arange(sides) / sides
    nr, ny = np.cos(theta), np.sin(theta)  # counter-clockwise around the tube cross-section
    part = _revolve(major_radius + minor_radius * nr, minor_radius * ny, nr, ny, segments, closed=True)
    return _merge([part], "torus")


def torus_knot(p: int = 2, q: int = 3, radius: float = 1.0, tube_radius: float = 0.15,
               segments: int = 256, sides: int = 24) -> Mesh:
    """A tube of ``tube_radius`` around the (p, q) torus knot of outer radius ``radius``, about Y.

    The curve winds p times around the Y axis and q times through the hole:
    rho(t) = radius (2 + cos qt) / 3, height radius sin(qt) / 3. Normals come
    from a parallel-transport frame along the curve, closed up by spreading the
    leftover twist evenly.
    """
    _positive(radius=radius, tube_radius=tube_radius)
    p, q = _count("p", p, 1, 1000), _count("q", q, 1, 1000)
    if math.gcd(p, q) != 1:
        raise ValueError(f"p ({p}) and q ({q}) must be coprime for a knot (a single closed curve)")
    n, m = _count("segments", segments, 8), _count("sides", sides, 3)
    _budget(2 * n * m, segments=n, sides=m)
    # Curve and tangent (analytic derivative).
    t = 2.0 * np.pi * np.arange(n) / n
    rho, drho = radius * (2.0 + np.cos(q * t)) / 3.0, -radius * q * np.sin(q * t) / 3.0
    curve = np.stack([rho * np.cos(p * t), radius * np.sin(q * t) / 3.0, rho * np.sin(p * t)], axis=-1)
    tangent = _unit(np.stack([drho * np.cos(p * t) - p * rho * np.sin(p * t), radius * q * np.cos(q * t) / 3.0,
                              drho * np.sin(p * t) + p * rho * np.cos(p * t)], axis=-1))
    # Parallel transport a normal along the curve (rotate it from one tangent to the next).
    normal = np.empty_like(curve)
    start = np.cross(tangent[0], [0.0, 1.0, 0.0])
    normal[0] = _unit(start if np.linalg.norm(start) > 1e-6 else np.cross(tangent[0], [1.0, 0.0, 0.0]))
    for k in range(1, n + 1):
        transported = _transport(normal[k - 1], tangent[k - 1], tangent[k % n])
        if k < n:
            normal[k] = transported
    # Spread the twist left when the frame comes back to the start evenly over the loop.
    twist = math.atan2(np.dot(np.cross(transported, normal[0]), tangent[0]), np.dot(transported, normal[0]))
    angle = twist * np.arange(n) / n
    binormal = np.cross(tangent, normal)
    normal, binormal = (np.cos(angle)[:, None] * normal + np.sin(angle)[:, None] * binormal,
                        -np.sin(angle)[:, None] * normal + np.cos(angle)[:, None] * binormal)
    # Tube: columns around the cross-section, rows along the curve.
    phi = 2.0 * np.pi * np.arange(m) / m
    out = np.cos(phi)[None, :, None] * normal[:, None, :] + np.sin(phi)[None, :, None] * binormal[:, None, :]
    vertices = (curve[:, None, :] + tube_radius * out).reshape(-1, 3)
    return Mesh(vertices, out.reshape(-1, 3), _grid_faces(n, m, wrap_rows=True, wrap_cols=True), name="torus-knot")


def _transport(v: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Rotate ``v`` by the minimal rotation that takes unit tangent t0 to t1 (Rodrigues)."""
    axis = np.cross(t0, t1)
    sin, cos = np.linalg.norm(axis), float(np.dot(t0, t1))
    if sin < 1e-12:
        return v
    axis /= sin
    rotated = v * cos + np.cross(axis, v) * sin + axis * np.dot(axis, v) * (1.0 - cos)
    return _unit(rotated - np.dot(rotated, t1) * t1)


def cylinder(radius: float = 1.0, height: float = 2.0, segments: int = 64, caps: bool = True) -> Mesh:
    """Cylinder about the Y axis from y = -height/2 to height/2; smooth side, flat caps."""
    _positive(radius=radius, height=height)
    segments, h = _count("segments", segments, 3), height / 2.0
    _budget(6 * segments, segments=segments)
    parts = [_strip([(radius, -h), (radius, h)], (1.0, 0.0), segments)]
    if caps:
        parts += [_strip([(0.0, -h), (radius, -h)], (0.0, -1.0), segments),
                  _strip([(radius, h), (0.0, h)], (0.0, 1.0), segments)]
    return _merge(parts, "cylinder")


def ring(inner_radius: float = 0.8, outer_radius: float = 1.0, height: float = 0.5, segments: int = 128) -> Mesh:
    """Closed annular tube about Y: outer wall, inner wall (facing the axis), top and bottom annuli."""
    _positive(inner_radius=inner_radius, outer_radius=outer_radius, height=height)
    if inner_radius >= outer_radius:
        raise ValueError(f"inner_radius ({inner_radius}) must be smaller than outer_radius ({outer_radius})")
    segments, h, ri, ro = _count("segments", segments, 3), height / 2.0, inner_radius, outer_radius
    _budget(8 * segments, segments=segments)
    # The cross-section rectangle, counter-clockwise: bottom, outer wall, top, inner wall.
    parts = [_strip([(ri, -h), (ro, -h)], (0.0, -1.0), segments), _strip([(ro, -h), (ro, h)], (1.0, 0.0), segments),
             _strip([(ro, h), (ri, h)], (0.0, 1.0), segments), _strip([(ri, h), (ri, -h)], (-1.0, 0.0), segments)]
    return _merge(parts, "ring")


def _spherical_cap(aperture: float, pole_y: float, rim_y: float, convex: bool, rings: int):
    """Profile (r, y, nr, ny) of a spherical cap from its pole (0, pole_y) to its rim (aperture, rim_y).

    The sphere through both points has its centre on the axis on the rim's side
    of the pole; the normal points away from the centre when ``convex``.
    """
    sag = rim_y - pole_y
    radius = (aperture**2 + sag**2) / (2.0 * abs(sag))
    direction = math.copysign(1.0, sag)  # from the pole towards the centre
    centre = pole_y + direction * radius
    theta = np.linspace(0.0, math.atan2(aperture, radius - abs(sag)), rings + 1)
    r, y = radius * np.sin(theta), centre - direction * radius * np.cos(theta)
    r[0], r[-1], y[0], y[-1] = 0.0, aperture, pole_y, rim_y  # exact ends, so rims meet their neighbours
    sign = 1.0 if convex else -1.0
    return r, y, sign * np.sin(theta), -sign * direction * np.cos(theta)


def _lens(name: str, aperture: float, center_y: float, edge_y: float, convex: bool, segments: int, rings: int) -> Mesh:
    """Two mirror-image spherical caps (poles at +-center_y, rims at +-edge_y) joined by a band, axis Z."""
    return _lens_faces(name, aperture, (-center_y, -edge_y, convex), (center_y, edge_y, convex), segments, rings)


def _lens_faces(name: str, aperture: float, back, front, segments: int, rings: int) -> Mesh:
    """A lens along Z from its back and front faces, each (pole height, rim height, convex): a spherical cap
    through its pole and rim, flat where they are level; a band joins the rims where the front's lies higher."""
    segments, rings = _count("segments", segments, 3), _count("rings", rings, 1)
    _budget(4 * segments * rings + 2 * segments, segments=segments, rings=rings)
    (bottom, bottom_rim, back_convex), (top, top_rim, front_convex) = back, front
    # Counter-clockwise in (r, y): the back face from its pole out, the rim band, the front face back to its pole.
    if bottom_rim == bottom:
        parts = [_strip([(0.0, bottom), (aperture, bottom)], (0.0, -1.0), segments)]
    else:
        parts = [_revolve(*_spherical_cap(aperture, bottom, bottom_rim, back_convex, rings), segments)]
    if top_rim > bottom_rim:
        parts.append(_strip([(aperture, bottom_rim), (aperture, top_rim)], (1.0, 0.0), segments))
    if top_rim == top:
        parts.append(_strip([(aperture, top), (0.0, top)], (0.0, 1.0), segments))
    else:
        parts.append(_revolve(*(values[::-1] for values in _spherical_cap(aperture, top, top_rim, front_convex, rings)),
                              segments))
    return _merge([_y_to_z(part) for part in parts], name)


def biconvex_lens(radius: float = 1.0, thickness: float = 0.4, edge_thickness: float = 0.0,
                  segments: int = 96, rings: int = 24) -> Mesh:
    """Symmetric biconvex lens along Z: aperture ``radius``, centre ``thickness``.

    Each face is a spherical cap of sag s = (thickness - edge_thickness) / 2 and
    curvature radius R = (radius^2 + s^2) / (2 s); with edge_thickness > 0 a
    cylindrical band joins the two rims.
    """
    _positive(radius=radius, thickness=thickness)
    if not 0.0 <= rules.number(edge_thickness, "edge_thickness") < thickness:
        raise ValueError(f"edge_thickness ({edge_thickness}) must lie in [0, thickness) (thickness is {thickness})")
    return _lens("biconvex-lens", radius, thickness / 2.0, edge_thickness / 2.0, True, segments, rings)


def biconcave_lens(radius: float = 1.0, center_thickness: float = 0.1, edge_thickness: float = 0.5,
                   segments: int = 96, rings: int = 24) -> Mesh:
    """Symmetric biconcave lens along Z: two concave spherical faces and a cylindrical rim band.

    Sag s = (edge_thickness - center_thickness) / 2, curvature radius
    R = (radius^2 + s^2) / (2 s).
    """
    _positive(radius=radius, center_thickness=center_thickness, edge_thickness=edge_thickness)
    if not edge_thickness > center_thickness:
        raise ValueError(f"edge_thickness ({edge_thickness}) must exceed center_thickness ({center_thickness})")
    if edge_thickness - center_thickness > 2.0 * radius:
        raise ValueError(f"edge_thickness - center_thickness ({edge_thickness - center_thickness}) must not exceed "
                         f"2 * radius ({2.0 * radius}): each face is at most a hemisphere")
    return _lens("biconcave-lens", radius, center_thickness / 2.0, edge_thickness / 2.0, False, segments, rings)


def lens(radius: float = 1.0, front_radius: float = 2.0, back_radius: float = -2.0, center_thickness: float = 0.6,
         segments: int = 96, rings: int = 24) -> Mesh:
    """A spherical lens along Z, its front face towards +Z: aperture ``radius``, the faces' curvature radii in the
    optician's signs (``front_radius`` > 0 and ``back_radius`` < 0 bulge outwards, the other signs are concave, 0
    is flat), poles ``center_thickness`` apart; a cylindrical rim band joins the faces where their rims lie apart.
    Plano-convex (front 1, back 0), meniscus (front 1, back 1.5: a spectacle lens's form), and the symmetric
    lenses alike."""
    _positive(radius=radius, center_thickness=center_thickness)
    front_radius, back_radius = rules.number(front_radius, "front_radius"), rules.number(back_radius, "back_radius")
    for name, curvature in (("front_radius", front_radius), ("back_radius", back_radius)):
        if curvature != 0.0 and abs(curvature) < radius:
            raise ValueError(f"{name} ({curvature}) must be 0 (flat) or at least the aperture radius ({radius}) in "
                             f"size: each face is at most a hemisphere")

    def rim_height(pole: float, curvature: float) -> float:
        """Where a face of this curvature through ``pole`` meets the aperture (curvature > 0: centre below)."""
        if curvature == 0.0:
            return pole
        return pole - curvature + math.copysign(math.sqrt(curvature * curvature - radius * radius), curvature)

    top, bottom = center_thickness / 2.0, -center_thickness / 2.0
    top_rim, bottom_rim = rim_height(top, front_radius), rim_height(bottom, back_radius)
    if top_rim - bottom_rim < -1e-9 * radius:
        raise ValueError(f"the faces cross inside the aperture (the rim is {top_rim - bottom_rim:.4g} thick): "
                         f"make center_thickness larger or the faces flatter")
    if top_rim - bottom_rim <= 1e-9 * radius:
        bottom_rim = top_rim  # a knife edge: no band
    return _lens_faces("lens", radius, (bottom, bottom_rim, back_radius < 0.0), (top, top_rim, front_radius > 0.0),
                       segments, rings)


def water_heightfield(size=(4.0, 4.0), resolution: int = 128, amplitude: float = 0.05, waves: int = 4,
                      seed: int = 0, time: float = 0.0) -> Mesh:
    """A water surface facing +Y: the sum of ``waves`` travelling sine waves, |y| <= amplitude.

    Directions, wavelengths (0.15 to 0.5 of the larger side) and phases come
    from ``seed``; each wave moves at the deep-water speed (omega^2 = g k), so
    ``time`` animates it. Normals come from the analytic gradient.
    """
    amplitude = rules.number(amplitude, "amplitude", 0.0, rules.MAX_COORDINATE)
    time = rules.number(time, "time", -rules.MAX_COORDINATE, rules.MAX_COORDINATE, hint=" seconds")
    waves = _count("waves", waves, 1, 256)
    samples = (_count("resolution", resolution, 1) + 1) ** 2 * waves
    if samples > MAX_WAVE_SAMPLES:
        raise ValueError(f"resolution {resolution} and waves {waves} would evaluate {samples:,} wave samples, above "
                         f"the limit of {MAX_WAVE_SAMPLES:,}; lower resolution or waves")
    rng = np.random.default_rng(_count("seed", seed, 0, 2**63 - 1))
    angle = rng.uniform(0.0, 2.0 * np.pi, waves)
    wavelength = rng.uniform(0.15, 0.5, waves) * float(np.max(_dims(size, 2)))
    phase = rng.uniform(0.0, 2.0 * np.pi, waves)
    weight = rng.uniform(0.5, 1.0, waves)
    weight *= amplitude / weight.sum()
    k = 2.0 * np.pi / wavelength
    kx, kz, omega = k * np.cos(angle), k * np.sin(angle), np.sqrt(9.81 * k)

    def height(x, z):
        arg = x[..., None] * kx + z[..., None] * kz - omega * float(time) + phase
        s, c = np.sin(arg), np.cos(arg)
        return (s * weight).sum(-1), (c * weight * kx).sum(-1), (c * weight * kz).sum(-1)

    return heightfield(size, resolution, height, "water")


SHAPES = {
    "sphere": sphere,
    "plane": plane,
    "box": box,
    "torus": torus,
    "torus-knot": torus_knot,
    "cylinder": cylinder,
    "biconvex-lens": biconvex_lens,
    "biconcave-lens": biconcave_lens,
    "lens": lens,
    "water": water_heightfield,
    "ring": ring,
}
"""Shape names as scene files spell them."""
