"""Make tests/data/gltf/*.glb with Blender's own glTF exporter (not run in CI).

Needs Blender as a Python module (Python 3.11: ``pip install bpy==5.0.1`` in a venv of its own), then
``/path/to/bpy-venv/bin/python scripts/make_blender_gltf.py``. Each scene is small (a few KB):

- ``blender-glass-ball.glb``: a glass ball (Principled transmission 1, IOR 1.45, no volume: thin-walled by
  the glTF spec) over a floor, a point light "Key Light" and a camera "Main Camera";
- ``blender-materials.glb``: a double-sided diffuse plane "Backdrop", a single-sided one, and a cube whose
  Principled specular (Specular IOR Level 0.8, a tinted Specular Tint) gives KHR_materials_specular, a
  spot light "Rim Spot" and a sun "Sun", a camera "Side Camera";
- ``blender-two-materials.glb``: a cube "Twotone" with two materials (its top face "Top Coat", the rest
  "Body Paint"): one node whose mesh has two primitives.
"""
from __future__ import annotations

import math
from pathlib import Path

import bpy

OUT = Path(__file__).resolve().parent.parent / "tests" / "data" / "gltf"


def empty_scene() -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)


def principled(name: str, color=(0.8, 0.8, 0.8), **inputs) -> bpy.types.Material:
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    node = material.node_tree.nodes["Principled BSDF"]
    node.inputs["Base Color"].default_value = (*color, 1.0)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    return material


def add(obj_op, name: str, material: bpy.types.Material, **kwargs) -> bpy.types.Object:
    obj_op(**kwargs)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(material)
    return obj


def light(kind: str, name: str, location, rotation=(0.0, 0.0, 0.0), energy: float = 500.0) -> None:
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    obj = bpy.data.objects.new(name, data)
    obj.location, obj.rotation_euler = location, rotation
    bpy.context.scene.collection.objects.link(obj)


def camera(name: str, location, rotation) -> None:
    data = bpy.data.cameras.new(name)
    obj = bpy.data.objects.new(name, data)
    obj.location, obj.rotation_euler = location, rotation
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.camera = obj


def export(name: str) -> None:
    bpy.ops.export_scene.gltf(filepath=str(OUT / name), export_format="GLB", export_lights=True,
                              export_cameras=True, export_apply=True)


def glass_ball() -> None:
    empty_scene()
    glass = principled("Clear Glass", (1.0, 1.0, 1.0), **{"Transmission Weight": 1.0, "Roughness": 0.0,
                                                         "IOR": 1.45})
    add(bpy.ops.mesh.primitive_uv_sphere_add, "Ball", glass, segments=24, ring_count=12, radius=0.5,
        location=(0.0, 0.0, 0.5))
    add(bpy.ops.mesh.primitive_plane_add, "Floor", principled("Floor Paint", (0.7, 0.7, 0.7)), size=4.0)
    light("POINT", "Key Light", (1.0, -1.0, 3.0), energy=800.0)
    camera("Main Camera", (0.0, -4.0, 1.6), (math.radians(75.0), 0.0, 0.0))
    export("blender-glass-ball.glb")


def materials() -> None:
    empty_scene()
    backdrop = principled("Two Sided", (0.2, 0.4, 0.8))
    backdrop.use_backface_culling = False
    single = principled("One Sided", (0.8, 0.4, 0.2))
    single.use_backface_culling = True
    add(bpy.ops.mesh.primitive_plane_add, "Backdrop", backdrop, size=3.0, location=(0.0, 1.5, 1.5),
        rotation=(math.radians(90.0), 0.0, 0.0))
    add(bpy.ops.mesh.primitive_plane_add, "Ground", single, size=3.0)
    shiny = principled("Shiny Paint", (0.6, 0.1, 0.1), **{"Specular IOR Level": 0.8,
                                                         "Specular Tint": (1.0, 0.8, 0.6, 1.0), "Roughness": 0.3})
    add(bpy.ops.mesh.primitive_cube_add, "Box", shiny, size=0.8, location=(0.0, 0.0, 0.4))
    light("SPOT", "Rim Spot", (2.0, -2.0, 3.0), (math.radians(45.0), 0.0, math.radians(45.0)), energy=600.0)
    light("SUN", "Sun", (0.0, 0.0, 5.0), (math.radians(30.0), 0.0, 0.0), energy=3.0)
    camera("Side Camera", (3.0, -3.0, 2.0), (math.radians(70.0), 0.0, math.radians(45.0)))
    export("blender-materials.glb")


def two_materials() -> None:
    empty_scene()
    cube = add(bpy.ops.mesh.primitive_cube_add, "Twotone", principled("Body Paint", (0.2, 0.6, 0.3)), size=1.0,
               location=(0.0, 0.0, 0.5))
    cube.data.materials.append(principled("Top Coat", (0.9, 0.9, 0.1)))
    for face in cube.data.polygons:
        face.material_index = 1 if face.normal.z > 0.5 else 0
    light("POINT", "Lamp", (0.0, -2.0, 3.0))
    camera("Front Camera", (0.0, -4.0, 1.5), (math.radians(75.0), 0.0, 0.0))
    export("blender-two-materials.glb")


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    glass_ball()
    materials()
    two_materials()
