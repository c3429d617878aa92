"""Product-shot scenes made as a user makes them: Blender, Principled BSDF, Blender's own glTF exporter.

Run with a Python that has Blender as a module (``pip install bpy==5.0.1`` in a venv of its own):

    /work/bpy-venv/bin/python bench/product_shots/make_scenes.py [--out DIR] [--size 256]

For each scene it writes into DIR (default ``bench/product_shots/scenes``):

- ``NAME.glb``: Blender's glTF export (lights and camera included, lighting mode "Standard": point and spot
  watts / 4 pi x 683 cd, sun W/m^2 x 683 lux, which caustica's reader divides by 683 back to W/sr and W/m^2);
- ``NAME.toml``: the scene caustica loads: the .glb and its environment (glTF holds none), black or the studio
  image ``studio.exr``;
- ``NAME.blend`` (into ``--blend-dir``, default ``$CAUSTICA_CACHE/product_shots/blend`` or
  ``~/.cache/caustica/product_shots/blend``): the Blender scene the Cycles reference renders
  (``cycles_reference.py``);
- ``NAME.regions.npz``: per pixel, the object its centre ray hits first (Blender's ray cast, -1 for the
  background), the material region of each object, and the pixels lit through glass (a shadow ray from the
  first opaque hit to a light meets glass first);

and the textures (``wood_color.png``, ``wood_normal.png``) and the environment in caustica's convention
(``studio.exr``) and Blender's (``studio_blender.exr``, the columns turned a quarter: Blender's u is caustica's
+ 0.25 once glTF's Y-up is Blender's Z-up).

The lights are punctual (point and spot radius 0, sun angle 0), as glTF holds them; everything else is as a
user leaves it: no tangents exported, default sampler, Principled inputs only where the shot needs them.
"""
from __future__ import annotations

import argparse
import math
import os
import struct
import sys
import zlib
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "scripts"))
from make_blender_gltf import principled  # noqa: E402  (the tests' Blender files use the same helper)

TEXTURE_SIZE = 256
GOLD = (1.0, 0.766, 0.336)
ALUMINIUM = (0.913, 0.922, 0.924)
CHROME = (0.8, 0.8, 0.82)


def cache_folder() -> Path:
    """Where generated files too large for the repository go: ``$CAUSTICA_CACHE/product_shots``."""
    root = os.environ.get("CAUSTICA_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "caustica") / "product_shots"


# ---- textures and environment (numpy) -------------------------------------------------------------------

def _periodic_noise(rng, size: int, cells: int) -> np.ndarray:
    """Smooth tileable noise in [-1, 1]: a random cells x cells lattice, bicubically interpolated, wrapping."""
    lattice = rng.uniform(-1.0, 1.0, (cells, cells))
    t = np.arange(size) * cells / size
    i = np.floor(t).astype(int)
    f = t - i
    s = f * f * (3.0 - 2.0 * f)
    rows = lattice[i % cells] * (1 - s)[:, None] + lattice[(i + 1) % cells] * s[:, None]
    return rows[:, i % cells] * (1 - s)[None, :] + rows[:, (i + 1) % cells] * s[None, :]


def wood_textures(size: int = TEXTURE_SIZE, seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """(base colour in sRGB [0,1], tangent-space normal map encoded n*0.5+0.5, green up the image), tileable:
    four planks along the image's x, growth rings warped by noise, grooves between the planks."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size] / size
    warp = 0.08 * _periodic_noise(rng, size, 4) + 0.02 * _periodic_noise(rng, size, 16)
    plank = np.floor(y * 4.0)
    rings = 0.5 + 0.5 * np.sin(2.0 * np.pi * (12.0 * (y + warp) + 3.0 * plank + 2.0 * np.sin(2 * np.pi * x)))
    fibre = 0.5 + 0.5 * _periodic_noise(rng, size, 64)
    t = np.clip(0.75 * rings ** 2 + 0.25 * fibre, 0.0, 1.0)[..., None]
    light, dark = np.array([0.62, 0.40, 0.22]), np.array([0.33, 0.17, 0.08])
    tone = 1.0 + 0.12 * ((plank * 0.37) % 1.0 - 0.5)[..., None]
    color = np.clip((dark + (light - dark) * (1.0 - t)) * tone, 0.0, 1.0)
    edge = np.abs((y * 4.0) % 1.0 - 0.5) * 2.0  # 1 at a plank seam
    height = 0.25 * rings + 0.1 * fibre - 2.0 * np.clip((edge - 0.94) / 0.06, 0.0, 1.0)
    strength = size / 32.0
    d_dx = (np.roll(height, -1, axis=1) - np.roll(height, 1, axis=1)) * 0.5 * strength
    d_drow = (np.roll(height, -1, axis=0) - np.roll(height, 1, axis=0)) * 0.5 * strength
    normal = np.stack([-d_dx, d_drow, np.ones_like(height)], axis=-1)  # up the image = -row: n_y = +dh/drow
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return color.astype(np.float32), (normal * 0.5 + 0.5).astype(np.float32)


def studio_environment(width: int = 256, height: int = 128) -> np.ndarray:
    """A studio in caustica's equirectangular convention (u = atan2(x, -z) / 2 pi, v = acos(y) / pi, +Y up):
    a dim warm floor, a grey gradient to the zenith, a large soft box above the front and a strip light at
    the side."""
    v, u = (np.mgrid[0:height, 0:width] + 0.5) / np.array([height, width])[:, None, None]
    theta, phi = v * np.pi, u * 2.0 * np.pi
    d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], axis=-1)
    up = d[..., 1:2]
    image = np.where(up > 0, 0.06 + 0.14 * up, 0.03 * np.array([1.0, 0.85, 0.7]))
    image = np.broadcast_to(image, d.shape).copy()

    def soft_box(center, size, radiance):
        center = np.asarray(center, float) / np.linalg.norm(center)
        inside = np.clip(1.0 - np.arccos(np.clip(d @ center, -1, 1)) / size, 0.0, 1.0)
        return np.clip(inside * 4.0, 0.0, 1.0)[..., None] * np.asarray(radiance)

    image += soft_box((0.3, 0.8, 0.5), 0.35, (6.0, 6.0, 5.6))
    image += soft_box((-0.9, 0.3, -0.2), 0.18, (3.0, 3.3, 4.0))
    return image.astype(np.float32)


def save_png(pixels: np.ndarray, path: Path) -> Path:
    """An (H, W, 3) array in [0, 1], row 0 at the top, as an 8-bit RGB PNG holding the values as given."""
    data = np.round(np.clip(pixels, 0.0, 1.0) * 255.0).astype(np.uint8)
    h, w = data.shape[:2]
    raw = b"".join(b"\x00" + data[row].tobytes() for row in range(h))

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    return path


def save_exr(pixels: np.ndarray, path: Path) -> Path:
    """An (H, W, 3) linear array, row 0 at the top, as a 32-bit float EXR (Blender's writer)."""
    h, w = pixels.shape[:2]
    image = bpy.data.images.new(path.stem, w, h, alpha=False, float_buffer=True)
    rgba = np.concatenate([pixels, np.ones((h, w, 1), np.float32)], axis=-1)[::-1]  # Blender: bottom row first
    image.pixels.foreach_set(rgba.ravel())
    settings = bpy.context.scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGB"
    image.save_render(str(path), scene=bpy.context.scene)
    bpy.data.images.remove(image)
    return path


def make_assets(out: Path) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    color, normal = wood_textures()
    save_png(color, out / "wood_color.png")
    save_png(normal, out / "wood_normal.png")
    env = studio_environment()
    save_exr(env, out / "studio.exr")
    save_exr(np.roll(env, env.shape[1] // 4, axis=1), out / "studio_blender.exr")


# ---- scene building (bpy) -------------------------------------------------------------------------------

def metal(name: str, color, roughness: float) -> bpy.types.Material:
    return principled(name, color, Metallic=1.0, Roughness=roughness)


def plastic(name: str, color, roughness: float) -> bpy.types.Material:
    return principled(name, color, Metallic=0.0, Roughness=roughness)


def glass(name: str = "Clear Glass") -> bpy.types.Material:
    return principled(name, (1.0, 1.0, 1.0), **{"Transmission Weight": 1.0, "Roughness": 0.0, "IOR": 1.5})


def wood(folder: Path) -> bpy.types.Material:
    """Principled with the wood base colour (sRGB) and normal map (Non-Color, through a Normal Map node)."""
    material = principled("Oiled Wood", Roughness=0.45)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    bsdf = nodes["Principled BSDF"]
    color = nodes.new("ShaderNodeTexImage")
    color.image = bpy.data.images.load(str(folder / "wood_color.png"))
    links.new(color.outputs["Color"], bsdf.inputs["Base Color"])
    normal_image = nodes.new("ShaderNodeTexImage")
    normal_image.image = bpy.data.images.load(str(folder / "wood_normal.png"))
    normal_image.image.colorspace_settings.name = "Non-Color"
    normal_map = nodes.new("ShaderNodeNormalMap")
    links.new(normal_image.outputs["Color"], normal_map.inputs["Color"])
    links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    return material


def link(name: str, mesh: bpy.types.Mesh, material, smooth: bool = True, location=(0, 0, 0)) -> bpy.types.Object:
    mesh.materials.append(material)
    if smooth:
        mesh.shade_smooth()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add(operator, name: str, material, smooth: bool = True, **kwargs) -> bpy.types.Object:
    operator(**kwargs)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(material)
    if smooth:
        obj.data.shade_smooth()
    return obj


def lathe(name: str, profile, segments: int = 40) -> bpy.types.Mesh:
    """A closed solid of revolution about +Z from (radius, z) points, bottom to top, the first and last on
    the axis (radius 0)."""
    profile = [(float(r), float(z)) for r, z in profile]
    vertices, faces, rings = [], [], []
    for r, z in profile:
        if r == 0.0:
            rings.append([len(vertices)])
            vertices.append((0.0, 0.0, z))
            continue
        ring = []
        for k in range(segments):
            a = 2.0 * math.pi * k / segments
            ring.append(len(vertices))
            vertices.append((r * math.cos(a), r * math.sin(a), z))
        rings.append(ring)
    for lower, upper in zip(rings, rings[1:]):
        for k in range(segments):
            k1 = (k + 1) % segments
            if len(lower) == 1:
                faces.append((lower[0], upper[k1], upper[k]))
            elif len(upper) == 1:
                faces.append((lower[k], lower[k1], upper[0]))
            else:
                faces.append((lower[k], lower[k1], upper[k1], upper[k]))
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    mesh.update()
    return mesh


def rounded_profile(radius: float, bottom: float, top: float, bevel: float, steps: int = 4):
    """(r, z) of a cylinder with rounded bottom and top edges (bevel radius ``bevel``)."""
    points = [(0.0, bottom)]
    for k in range(steps + 1):
        a = -math.pi / 2 + (math.pi / 2) * k / steps
        points.append((radius - bevel + bevel * math.cos(a), bottom + bevel + bevel * math.sin(a)))
    for k in range(steps + 1):
        a = (math.pi / 2) * k / steps
        points.append((radius - bevel + bevel * math.cos(a), top - bevel + bevel * math.sin(a)))
    points.append((0.0, top))
    return points


def bevelled_box(name: str, size, bevel: float, location, material) -> bpy.types.Object:
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=location)
    obj = bpy.context.active_object
    obj.name = name
    obj.scale = size
    bpy.ops.object.transform_apply(scale=True)
    modifier = obj.modifiers.new("Bevel", "BEVEL")
    modifier.width, modifier.segments = bevel, 3
    obj.data.materials.append(material)
    return obj


def floor(name: str, material, size: float = 6.0) -> bpy.types.Object:
    return add(bpy.ops.mesh.primitive_plane_add, name, material, smooth=False, size=size)


def light(kind: str, name: str, location, target=(0, 0, 0), energy: float = 500.0, color=(1, 1, 1),
          **settings) -> bpy.types.Object:
    data = bpy.data.lights.new(name, kind)
    data.energy, data.color = energy, color
    if kind in ("POINT", "SPOT"):
        data.shadow_soft_size = 0.0  # punctual, as glTF holds it
    if kind == "SUN":
        data.angle = 0.0
    for key, value in settings.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    obj.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.collection.objects.link(obj)
    return obj


def camera(name: str, location, target, lens: float = 50.0) -> None:
    data = bpy.data.cameras.new(name)
    data.lens = lens
    data.clip_start, data.clip_end = 0.05, 100.0
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    obj.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.camera = obj


def world(folder: Path, environment: str | None, strength: float = 1.0) -> None:
    """Black (no world light) or the studio image, in Blender's convention."""
    w = bpy.data.worlds.new("World")
    bpy.context.scene.world = w
    w.use_nodes = True
    background = w.node_tree.nodes["Background"]
    if environment is None:
        background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        background.inputs["Strength"].default_value = 0.0
        return
    texture = w.node_tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = bpy.data.images.load(str(folder / environment))
    texture.image.colorspace_settings.name = "Linear Rec.709"
    texture.interpolation = "Linear"
    w.node_tree.links.new(texture.outputs["Color"], background.inputs["Color"])
    background.inputs["Strength"].default_value = strength


# ---- the scenes: name -> (builder, environment, {object name: region}) -------------------------------

def bottle_on_plastic(folder: Path) -> dict:
    """A clear glass bottle with a gold cap (roughness 0.25) standing on a glossy dark plastic floor (0.2);
    a point key light and a spot rim light; black world."""
    body = [(0.0, 0.0), (0.26, 0.0), (0.29, 0.01), (0.30, 0.04), (0.30, 0.62), (0.28, 0.70), (0.20, 0.80),
            (0.12, 0.88), (0.10, 0.92), (0.10, 1.02), (0.0, 1.02)]
    link("Bottle", lathe("Bottle", body), glass())
    link("Cap", lathe("Cap", rounded_profile(0.115, 1.02, 1.16, 0.02)), metal("Gold Cap", GOLD, 0.25))
    floor("Floor", plastic("Dark Plastic", (0.03, 0.03, 0.035), 0.2))
    light("POINT", "Key", (1.6, -1.2, 2.4), energy=600.0)
    light("SPOT", "Rim", (-1.8, 1.6, 2.2), target=(0, 0, 0.5), energy=900.0, spot_size=math.radians(50.0),
          spot_blend=0.2)
    camera("Camera", (0.0, -3.4, 1.4), (0.0, 0.0, 0.55), lens=55.0)
    return {"Bottle": "glass", "Cap": "metal", "Floor": "plastic"}


def metal_balls(folder: Path) -> dict:
    """A chrome ball, a gold ball (0.25) and a rough aluminium ball (0.5) standing on a grey floor under a
    spot light; black world."""
    link_sphere = lambda name, material, x: add(bpy.ops.mesh.primitive_uv_sphere_add, name, material,  # noqa: E731
                                                segments=40, ring_count=20, radius=0.4, location=(x, 0.0, 0.4))
    link_sphere("Chrome Ball", metal("Chrome", CHROME, 0.0), -0.95)
    link_sphere("Gold Ball", metal("Gold", GOLD, 0.25), 0.0)
    link_sphere("Aluminium Ball", metal("Brushed Aluminium", ALUMINIUM, 0.5), 0.95)
    floor("Floor", plastic("Grey Floor", (0.45, 0.45, 0.45), 0.5))
    backdrop = add(bpy.ops.mesh.primitive_plane_add, "Backdrop", plastic("Backdrop Paint", (0.6, 0.55, 0.5), 0.6),
                   smooth=False, size=6.0, location=(0.0, 2.0, 3.0), rotation=(math.radians(90.0), 0.0, 0.0))
    light("SPOT", "Spot", (1.5, -2.5, 3.5), target=(0, 0, 0.3), energy=700.0, spot_size=math.radians(60.0),
          spot_blend=0.15)
    light("POINT", "Fill", (-2.5, -1.5, 1.5), energy=150.0)
    camera("Camera", (0.0, -4.2, 1.5), (0.0, 0.0, 0.4), lens=45.0)
    return {"Chrome Ball": "metal", "Gold Ball": "metal", "Aluminium Ball": "metal", "Floor": "plastic",
            backdrop.name: "plastic"}


def glass_on_wood(folder: Path) -> dict:
    """A glass ball and a rough aluminium can on a wooden table (base-colour texture and normal map) under a
    sun; black world."""
    add(bpy.ops.mesh.primitive_uv_sphere_add, "Glass Ball", glass(), segments=40, ring_count=20, radius=0.35,
        location=(-0.35, 0.1, 0.35))
    link("Can", lathe("Can", rounded_profile(0.22, 0.0, 0.6, 0.03)), metal("Brushed Aluminium", ALUMINIUM, 0.5),
         location=(0.5, 0.35, 0.0))
    table = bpy.data.meshes.new("Table")
    half, thick = (1.6, 1.1), 0.08
    corners = [(x, y, z) for z in (-thick, 0.0) for y in (-half[1], half[1]) for x in (-half[0], half[0])]
    table.from_pydata(corners, [], [(4, 5, 7, 6), (0, 2, 3, 1), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2),
                                    (1, 3, 7, 5)])
    uv = table.uv_layers.new(name="UVMap")
    for loop in table.loops:  # planar UVs: 1 texture repeat per 1.2 m, along x and the vertical
        p = Vector(corners[loop.vertex_index])
        n = table.polygons[[f.index for f in table.polygons if loop.index in f.loop_indices][0]].normal
        across = p.y if abs(n.z) > 0.5 else p.z
        along = p.x if abs(n.x) < 0.5 else p.y
        uv.data[loop.index].uv = (along / 1.2, across / 1.2)
    link("Table", table, wood(folder), smooth=False)
    light("SUN", "Sun", (2.0, -1.0, 3.0), target=(0, 0, 0), energy=3.0)
    light("POINT", "Fill", (-2.0, -2.0, 1.8), energy=120.0)
    camera("Camera", (0.4, -3.0, 1.7), (0.0, 0.1, 0.2), lens=45.0)
    return {"Glass Ball": "glass", "Can": "metal", "Table": "wood"}


def studio_metals(folder: Path) -> dict:
    """Chrome, gold and rough aluminium objects and a red glossy plastic one on a glossy dark floor, lit by a
    studio environment and a sun."""
    add(bpy.ops.mesh.primitive_uv_sphere_add, "Chrome Ball", metal("Chrome", CHROME, 0.0), segments=40,
        ring_count=20, radius=0.35, location=(-0.8, 0.2, 0.35))
    add(bpy.ops.mesh.primitive_torus_add, "Gold Ring", metal("Gold", GOLD, 0.25), major_radius=0.32,
        minor_radius=0.09, major_segments=48, minor_segments=16, location=(0.0, -0.3, 0.09))
    box = bevelled_box("Aluminium Block", (0.5, 0.5, 0.5), 0.04, (0.75, 0.35, 0.25),
                       metal("Brushed Aluminium", ALUMINIUM, 0.5))
    box.rotation_euler = (0.0, 0.0, math.radians(30.0))
    add(bpy.ops.mesh.primitive_monkey_add, "Red Plastic", plastic("Red Plastic", (0.6, 0.04, 0.03), 0.3),
        size=0.5, location=(0.05, 0.75, 0.35), rotation=(0.0, 0.0, math.radians(-20.0)))
    bpy.context.active_object.modifiers.new("Subdivision", "SUBSURF").levels = 1
    floor("Floor", plastic("Dark Plastic", (0.03, 0.03, 0.035), 0.2))
    light("SUN", "Sun", (1.0, -2.0, 3.0), target=(0, 0, 0), energy=2.0)
    camera("Camera", (0.0, -3.6, 1.9), (0.0, 0.2, 0.2), lens=45.0)
    return {"Chrome Ball": "metal", "Gold Ring": "metal", "Aluminium Block": "metal", "Red Plastic": "plastic",
            "Floor": "plastic"}


def glass_box_contact(folder: Path) -> dict:
    """A bevelled glass box standing on a light plastic floor with a gold rough ball (0.25) resting on top;
    a point light and the studio environment."""
    bevelled_box("Glass Box", (0.7, 0.7, 0.7), 0.05, (0.0, 0.0, 0.35), glass())
    add(bpy.ops.mesh.primitive_uv_sphere_add, "Gold Ball", metal("Gold", GOLD, 0.25), segments=32, ring_count=16,
        radius=0.2, location=(0.0, 0.0, 0.9))
    floor("Floor", plastic("Light Plastic", (0.7, 0.7, 0.68), 0.4))
    light("POINT", "Key", (1.2, -1.5, 2.5), energy=200.0)
    camera("Camera", (1.2, -3.0, 1.6), (0.0, 0.0, 0.45), lens=50.0)
    return {"Glass Box": "glass", "Gold Ball": "metal", "Floor": "plastic"}


def plastic_toys(folder: Path) -> dict:
    """Glossy plastics (a white monkey head, roughness 0.3; a blue cylinder, 0.15) and a gold cylinder (0.25)
    on a grey plastic floor (0.35) under a point and a spot light; black world."""
    monkey = add(bpy.ops.mesh.primitive_monkey_add, "White Plastic", plastic("White Plastic", (0.8, 0.8, 0.78), 0.3),
                 size=0.7, location=(-0.35, 0.0, 0.42), rotation=(math.radians(-10.0), 0.0, math.radians(15.0)))
    monkey.modifiers.new("Subdivision", "SUBSURF").levels = 1
    link("Blue Cylinder", lathe("Blue Cylinder", rounded_profile(0.2, 0.0, 0.5, 0.03)),
         plastic("Blue Plastic", (0.05, 0.15, 0.6), 0.15), location=(0.55, 0.3, 0.0))
    link("Gold Cylinder", lathe("Gold Cylinder", rounded_profile(0.12, 0.0, 0.3, 0.02)), metal("Gold", GOLD, 0.25),
         location=(0.45, -0.45, 0.0))
    floor("Floor", plastic("Grey Plastic", (0.3, 0.3, 0.32), 0.35))
    light("POINT", "Key", (-1.5, -2.0, 2.5), energy=400.0)
    light("SPOT", "Top", (0.8, 0.5, 3.0), target=(0.3, 0.0, 0.0), energy=400.0, spot_size=math.radians(55.0),
          spot_blend=0.2)
    camera("Camera", (0.3, -3.2, 1.5), (0.05, 0.0, 0.3), lens=50.0)
    return {"White Plastic": "plastic", "Blue Cylinder": "plastic", "Gold Cylinder": "metal", "Floor": "plastic"}


SCENES = {
    "bottle_on_plastic": (bottle_on_plastic, None),
    "metal_balls": (metal_balls, None),
    "glass_on_wood": (glass_on_wood, None),
    "studio_metals": (studio_metals, "studio"),
    "glass_box_contact": (glass_box_contact, "studio"),
    "plastic_toys": (plastic_toys, None),
}


# ---- regions (Blender's ray cast) -----------------------------------------------------------------------

GLASS_IOR = 1.5
MAX_INTERFACES = 8


def _lit_through_glass(scene, depsgraph, lights, regions_of, location, normal, towards) -> bool:
    """Whether a shadow ray from an opaque point (offset to the side ``towards`` comes from) to some light meets
    glass first."""
    start = location + normal * 1e-4 * (1 if normal.dot(towards) > 0 else -1)
    for lamp in lights:
        if lamp.data.type == "SUN":
            direction, reach = lamp.matrix_world.to_quaternion() @ Vector((0, 0, 1)), 1e4
        else:
            direction = lamp.matrix_world.translation - start
            reach = direction.length
            direction = direction.normalized()
        blocked, _, _, _, blocker, _ = scene.ray_cast(depsgraph, start, direction, distance=reach)
        if blocked and regions_of.get(blocker.name) == "glass":
            return True
    return False


def _through_glass(scene, depsgraph, regions_of, location, normal, direction):
    """The first opaque hit (location, normal, direction) of the refracted path from a glass hit (Snell's law
    at IOR 1.5, total internal reflection where it applies, the reflected path ignored), or None."""
    inside = False
    for _ in range(MAX_INTERFACES):
        n = normal if normal.dot(direction) < 0 else -normal
        eta = GLASS_IOR if inside else 1.0 / GLASS_IOR
        cos_i = -n.dot(direction)
        k = 1.0 - eta * eta * (1.0 - cos_i * cos_i)
        if k < 0.0:
            direction = direction + 2.0 * cos_i * n  # total internal reflection
        else:
            direction = (eta * direction + (eta * cos_i - math.sqrt(k)) * n).normalized()
            inside = not inside
        hit, location, normal, _, obj, _ = scene.ray_cast(depsgraph, location + direction * 1e-4, direction)
        if not hit:
            return None
        if regions_of[obj.name] != "glass":
            return location, normal, direction
    return None


def regions(regions_of: dict, size: int) -> dict:
    """Per pixel the first object its centre ray hits (index into ``names``, -1 none); ``through_glass``: the
    pixels whose first hit is opaque and lit through glass (a shadow ray to some light meets glass first);
    ``seen_through_glass``: glass pixels whose refracted path ends on an opaque point lit through glass. A path
    tracer cannot find the light of punctual lights at either (a delta light seen through specular glass)."""
    scene = bpy.context.scene
    depsgraph = bpy.context.evaluated_depsgraph_get()
    cam = scene.camera
    top_right, bottom_right, bottom_left, top_left = [cam.matrix_world @ c for c in cam.data.view_frame(scene=scene)]
    origin = cam.matrix_world.translation.copy()
    names = sorted(regions_of)
    lights = [o for o in scene.objects if o.type == "LIGHT"]
    ids = np.full((size, size), -1, np.int16)
    through_glass = np.zeros((size, size), bool)
    seen_through_glass = np.zeros((size, size), bool)
    for row in range(size):
        fy = (row + 0.5) / size
        left, right = top_left.lerp(bottom_left, fy), top_right.lerp(bottom_right, fy)
        for col in range(size):
            direction = (left.lerp(right, (col + 0.5) / size) - origin).normalized()
            hit, location, normal, _, obj, _ = scene.ray_cast(depsgraph, origin, direction)
            if not hit:
                continue
            ids[row, col] = names.index(obj.name)
            if regions_of[obj.name] != "glass":
                through_glass[row, col] = _lit_through_glass(scene, depsgraph, lights, regions_of, location, normal,
                                                             -direction)
                continue
            beyond = _through_glass(scene, depsgraph, regions_of, location, normal, direction)
            if beyond is not None:
                seen_through_glass[row, col] = _lit_through_glass(scene, depsgraph, lights, regions_of, beyond[0],
                                                                  beyond[1], -beyond[2])
    return {"ids": ids, "names": np.array(names), "regions": np.array([regions_of[n] for n in names]),
            "through_glass": through_glass, "seen_through_glass": seen_through_glass}


def make_scene(name: str, out: Path, blend_dir: Path, size: int, regions_only: bool = False) -> None:
    build, environment = SCENES[name]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    regions_of = build(out)
    world(out, None if environment is None else f"{environment}_blender.exr")
    for obj in list(scene.objects):  # apply modifiers so the ray cast and Cycles see the exported triangles
        if obj.type == "MESH" and obj.modifiers:
            bpy.context.view_layer.objects.active = obj
            for modifier in list(obj.modifiers):
                bpy.ops.object.modifier_apply(modifier=modifier.name)
    bpy.context.view_layer.update()
    np.savez_compressed(out / f"{name}.regions.npz", **regions(regions_of, size))
    if regions_only:
        return
    bpy.ops.export_scene.gltf(filepath=str(out / f"{name}.glb"), export_format="GLB", export_lights=True,
                              export_cameras=True, export_apply=True, export_import_convert_lighting_mode="SPEC")
    bpy.ops.wm.save_as_mainfile(filepath=str(blend_dir / f"{name}.blend"), compress=True, relative_remap=False)
    env = 'procedural = "black"' if environment is None else f'file = "{environment}.exr"'
    (out / f"{name}.toml").write_text(f'# made by bench/product_shots/make_scenes.py from {name}.blend\n'
                                      f'name = "{name}"\n\n[[objects]]\ngltf = "{name}.glb"\n\n'
                                      f'[environment]\n{env}\n')
    triangles = 0
    for obj in scene.objects:
        if obj.type == "MESH":
            obj.data.calc_loop_triangles()
            triangles += len(obj.data.loop_triangles)
    print(f"{name}: {triangles} triangles", flush=True)


def main() -> None:
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "scenes")
    parser.add_argument("--blend-dir", type=Path, default=cache_folder() / "blend")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--regions-only", action="store_true", help="only recompute NAME.regions.npz")
    args = parser.parse_args(argv)
    args.out = args.out.resolve()
    args.blend_dir = args.blend_dir.resolve()
    for folder in (args.out, args.blend_dir):
        folder.mkdir(parents=True, exist_ok=True)
    if not args.regions_only:
        make_assets(args.out)
    for name in args.scenes.split(","):
        make_scene(name, args.out, args.blend_dir, args.size, args.regions_only)


if __name__ == "__main__":
    main()
