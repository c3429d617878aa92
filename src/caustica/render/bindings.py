"""One table of the texture units and storage-buffer binding points the shading programs share, and the
binders that fill them.

A surface-shading program (ShadeSurfaces and every program including common/lighting.glsl, caustics.glsl or
impostors.glsl) reads the environment, its pass's input channels, the light samples' shadow maps, the caustic
maps (or tiles), the impostor atlas, a receiver's albedo texture, the environment lobes' atlases, the
environment's light maps, the nearby planes' textures and a glossy receiver's split-sum table, prefiltered
environment and material maps at once: each has its own units below, and
tests/test_architecture.py fails if two of them overlap. Programs of a single pass (full-screen resolves,
compute dispatches) bind their own few textures from unit 0 and are not in the table. Unit numbers need not
stay under GL_MAX_TEXTURE_IMAGE_UNITS (32 on llvmpipe and NVIDIA: the samplers one stage may use); they stay
under GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS (at least 48 in GL 3.3).
"""
from __future__ import annotations

import numpy as np

from ..gpu.meshes import set_uniform, write_uniform_array
from ..lighting.environment import MAX_LOBES
from ..lighting.samples import CUBE_FORWARD, CUBE_UP, MAX_LIGHTS, LightSample

MAX_INPUTS = 7  # input channels a ShadeSurfaces run binds as samplers (a deferred G-buffer takes the next two)
MAX_CAUSTIC_TILES = 16  # rectangles whose caustic textures one frame can carry (impostor_caustic_filter.comp's texel_area[16])
MAX_PLANE_TEXTURES = 4  # textured nearby planes with their own texture; more take the texture's mean colour
MAX_PLANES = 8  # nearby planes (impostors.glsl's NEARBY_PLANES)
MAX_IMPOSTORS = 8  # rectangles per reflector (cells of its atlas)
MAX_REFLECTION_PROBES = 4  # glossy receivers with a local probe of their own; the others share the nearest
SHADOW_NORMAL_OFFSET = 0.5  # texel widths at the receiver (lighting.glsl's shadow_bias; tests/test_shadows.py)

MATERIAL_MAPS = ("metallic_roughness_texture", "normal_texture", "occlusion_texture", "emission_texture")
"""A Principled receiver's maps besides its base colour's (the albedo unit), each the sampler of its name."""

TEXTURE_UNITS: dict[str, range] = {
    "environment": range(0, 1),
    "inputs": range(1, 1 + MAX_INPUTS),  # a pass's input channels, then a deferred G-buffer and its refine flags
    "shadow_maps": range(8, 8 + MAX_LIGHTS),
    "caustic_maps": range(16, 16 + MAX_LIGHTS),  # or, in their place, the caustic tiles' atlas at the first
    "impostor_atlas": range(24, 25),
    "albedo": range(25, 26),
    "environment_shadows": range(26, 30),  # the lobes' shadow atlas, their glass's, the bounce's, the nearest distances'
    "environment_bake": range(30, 31),
    "plane_textures": range(31, 31 + MAX_PLANE_TEXTURES),
    "brdf_table": range(35, 36),  # the split-sum (A, B) table of glossy receivers
    "prefiltered_environment": range(36, 37),  # the environment prefiltered per roughness level, or the object's probe
    "material_maps": range(37, 37 + len(MATERIAL_MAPS)),  # a glossy receiver's maps, in MATERIAL_MAPS' order
}
"""Texture units of the surface-shading programs by what they hold; no two ranges overlap."""

DISPATCH_BINDINGS = range(0, 3)
"""Storage binding points each compute shader declares for its own buffers (photons, their inputs, a parent
level), bound again at every dispatch."""

STORAGE_BINDINGS: dict[str, int] = {
    "fixed_point_flux": 3,  # fixed_point_flux.glsl's flux_words, beside any splat shader's own buffers
}
"""Storage binding points a shared include declares: none among DISPATCH_BINDINGS, no two alike."""


def first_unit(name: str) -> int:
    """The first texture unit of ``name`` in TEXTURE_UNITS."""
    return TEXTURE_UNITS[name].start


def bind_lights(program, samples: list[LightSample], maps: list, shadow_bias: float = SHADOW_NORMAL_OFFSET) -> None:
    """Set the lighting.glsl uniforms and bind the shadow maps to their units; ``shadow_bias`` is the
    receiver's normal offset in texel widths of its map."""
    first = first_unit("shadow_maps")
    count = len(samples)
    set_uniform(program, "light_count", count)
    set_uniform(program, "shadow_bias", shadow_bias)  # the environment lobes' maps take it too
    if count == 0:
        return

    def pad(rows, width):
        out = np.zeros((MAX_LIGHTS, width), dtype="f4")
        out[:count] = rows
        return out

    set_uniform(program, "light_type", np.array([s.type for s in samples] + [0] * (MAX_LIGHTS - count), dtype="i4"))
    set_uniform(program, "light_position", pad([s.position for s in samples], 3))
    set_uniform(program, "light_direction", pad([s.direction for s in samples], 3))
    set_uniform(program, "light_intensity", pad([s.intensity for s in samples], 3))
    set_uniform(program, "light_cone_cos", pad([s.cone_cos for s in samples], 2))
    clips = np.zeros((MAX_LIGHTS, 4, 4), dtype="f4")
    for i, s in enumerate(samples):
        clips[i] = s.clip_from_world if s.clip_from_world is not None else np.eye(4)
    if "light_clip_from_world" in program:
        program["light_clip_from_world"].write(np.ascontiguousarray(clips.transpose(0, 2, 1)).tobytes())
    set_uniform(program, "cube_forward", CUBE_FORWARD.astype("f4"))
    set_uniform(program, "cube_up", CUBE_UP.astype("f4"))
    units = []
    for i in range(MAX_LIGHTS):
        units.append(first + min(i, count - 1))
    for i, tex in enumerate(maps):
        tex.use(first + i)
    if "shadow_map" in program:
        program["shadow_map"].write(np.array(units, dtype="i4").tobytes())


def bind_caustic_maps(program, maps: list, distance_tolerance: float = 5e-3) -> None:
    """Set the caustics.glsl uniforms and bind the maps to their units."""
    first = first_unit("caustic_maps")
    kinds = np.zeros(MAX_LIGHTS, dtype="i4")
    clips = np.tile(np.eye(4, dtype="f4"), (MAX_LIGHTS, 1, 1))
    units = np.full(MAX_LIGHTS, first, dtype="i4")
    for i, caustic in enumerate(maps[:MAX_LIGHTS]):
        if caustic is None:
            continue
        kinds[i] = caustic.kind
        if caustic.clip_from_world is not None:
            clips[i] = caustic.clip_from_world
        caustic.texture.use(first + i)
        units[i] = first + i
    set_uniform(program, "caustic_kind", kinds)
    if "caustic_clip_from_world" in program:
        program["caustic_clip_from_world"].write(np.ascontiguousarray(clips.transpose(0, 2, 1)).tobytes())
    if "caustic_map" in program:
        program["caustic_map"].write(units.tobytes())
    set_uniform(program, "caustic_distance_tolerance", float(distance_tolerance))


def bind_caustic_tiles(program, tiles) -> None:
    """Set caustics.glsl's tile uniforms shared by every receiver (``tiles``: passes' CausticTiles) and bind
    the atlas to the caustic maps' first unit."""
    unit = first_unit("caustic_maps")
    count = min(len(tiles.receivers), MAX_CAUSTIC_TILES)
    clips = np.tile(np.eye(4, dtype="f4"), (MAX_CAUSTIC_TILES, 1, 1))
    axes = np.zeros((MAX_CAUSTIC_TILES, 3), "f4")
    clips[:count], axes[:count] = tiles.clip_from_world[:count], tiles.axes[:count]
    tiles.texture.use(unit)
    set_uniform(program, "caustic_tiles", unit)
    set_uniform(program, "caustic_tile_size", int(tiles.tile_size))
    write_uniform_array(program, "caustic_tile_clip_from_world", np.ascontiguousarray(clips.transpose(0, 2, 1)))
    write_uniform_array(program, "caustic_tile_axis", axes)


def bind_receiver_tiles(program, tiles, obj) -> None:
    """Which tiles the receiver ``obj`` (about to be drawn) looks up."""
    mine = [k for k in tiles.tiles_of(obj) if k < MAX_CAUSTIC_TILES]
    order = np.zeros(MAX_CAUSTIC_TILES, "i4")
    order[: len(mine)] = mine
    write_uniform_array(program, "receiver_tile", order)
    set_uniform(program, "receiver_tile_count", len(mine))


def bind_environment_shadows(program, shadows) -> None:
    """Set lighting.glsl's env_lobe_* uniforms (``shadows``: an EnvironmentShadows) and bind its atlas, the
    glass's where there is one, the bounce's and the nearest distances' to environment_shadows' four units."""
    unit = first_unit("environment_shadows")
    count = len(shadows.tiles)
    rows = {"env_lobe_origin": [t.position for t in shadows.tiles],
            "env_lobe_direction": [t.direction for t in shadows.tiles],
            "env_lobe_irradiance": shadows.lobes.irradiance,
            "env_lobe_span": np.repeat(shadows.lobes.span[:, None], 3, axis=1)}
    for name, values in rows.items():
        padded = np.zeros((MAX_LOBES, 3), "f4")
        padded[:count] = values
        write_uniform_array(program, name, padded)
    clips = np.tile(np.eye(4, dtype="f4"), (MAX_LOBES, 1, 1))
    clips[:count] = [t.clip_from_world for t in shadows.tiles]
    write_uniform_array(program, "env_lobe_clip_from_world", np.ascontiguousarray(clips.transpose(0, 2, 1)))
    set_uniform(program, "env_lobe_count", count)
    shadows.atlas.use(unit)
    set_uniform(program, "env_shadow_atlas", unit)
    if shadows.bounce is not None:
        shadows.bounce.use(unit + 2)
        set_uniform(program, "env_bounce_atlas", unit + 2)
    shadows.nearest.use(unit + 3)
    set_uniform(program, "env_nearest_atlas", unit + 3)
    if shadows.glass is not None:
        shadows.glass.use(unit + 1)
        set_uniform(program, "env_glass_atlas", unit + 1)


def bind_environment_bake(program, baked) -> None:
    """Set lighting.glsl's env_bake_layout and bind the bake's atlas (``baked``: an EnvironmentBake)."""
    unit = first_unit("environment_bake")
    set_uniform(program, "env_bake_layout", (baked.table_row, len(baked.maps), baked.vertex_row, 0))
    baked.texture.use(unit)
    set_uniform(program, "env_bake", unit)


def bind_baked_object(program, baked, scene, obj) -> None:
    """Set lighting.glsl's per-object rectangles (env_bake_rect, its rectangle_rows, and env_bake_rect_count) and
    env_bake_vertex_first (-1: none)."""
    rows, count, vertex = baked.object_uniforms(scene, obj)
    write_uniform_array(program, "env_bake_rect", rows)
    set_uniform(program, "env_bake_rect_count", count)
    set_uniform(program, "env_bake_vertex_first", vertex)


def bind_split_sum(program, table, prefiltered, levels: int) -> None:
    """Bind common/microfacet.glsl's brdf_table and the prefiltered environment (``levels`` bands) to their
    units (passes/shading/prefiltered.py makes both)."""
    table.use(first_unit("brdf_table"))
    set_uniform(program, "brdf_table", first_unit("brdf_table"))
    prefiltered.use(first_unit("prefiltered_environment"))
    set_uniform(program, "prefiltered_environment", first_unit("prefiltered_environment"))
    set_uniform(program, "prefiltered_levels", int(levels))


def bind_reflection_probe(program, probe) -> None:
    """Bind a glossy receiver's reflection probe (passes/shading/reflection_probes.py) in place of the
    prefiltered environment, and set common/reflection_probe.glsl's centre and proxy box."""
    probe.atlas.use(first_unit("prefiltered_environment"))
    set_uniform(program, "prefiltered_environment", first_unit("prefiltered_environment"))
    set_uniform(program, "probe_centre", probe.centre.astype("f4"))
    set_uniform(program, "probe_box_min", probe.box[0].astype("f4"))
    set_uniform(program, "probe_box_max", probe.box[1].astype("f4"))


def bind_material_maps(program, gpu, material, names) -> None:
    """Bind ``material``'s maps ``names`` (of MATERIAL_MAPS) to their units, each to the sampler of its name."""
    for unit, name in zip(TEXTURE_UNITS["material_maps"], MATERIAL_MAPS):
        if name in names:
            gpu.albedo_texture(getattr(material, name)).use(unit)
            set_uniform(program, name, unit)


def bind_impostors(program, impostors, reflector: int | None, params) -> None:
    """Set impostors.glsl's uniforms for one reflector (world index; ``impostors``: an ImpostorSet or None)
    and bind its atlas."""
    group = [] if impostors is None or reflector is None else impostors.by_reflector.get(reflector, [])
    set_uniform(program, "impostor_count", len(group))
    set_uniform(program, "impostor_base", 0 if not group else int(impostors.base[reflector]))
    set_uniform(program, "impostor_tolerance", float(params.impostor_tolerance))
    set_uniform(program, "impostor_hit_tolerance", float(params.hit_tolerance))
    if not group:
        return
    n = MAX_IMPOSTORS
    clips = np.tile(np.eye(4, dtype="f4"), (n, 1, 1))
    vec = {name: np.zeros((n, 3), "f4") for name in ("origin", "axis", "center")}
    slab, radius = np.zeros((n, 2), "f4"), np.ones(n, "f4")
    cells, flat = np.zeros((n, 2), "i4"), np.zeros(n, "i4")
    for k, imp in enumerate(group):
        clips[k] = imp.camera.clip_from_world().T
        vec["origin"][k], vec["axis"][k], vec["center"][k] = imp.origin, imp.axis, imp.center
        slab[k], radius[k], cells[k], flat[k] = imp.slab, imp.radius, imp.cell, imp.flat
    group[0].texture.use(first_unit("impostor_atlas"))
    set_uniform(program, "impostor_atlas", first_unit("impostor_atlas"))
    set_uniform(program, "impostor_size", int(group[0].camera.size[0]))
    write_uniform_array(program, "impostor_cell", cells)
    write_uniform_array(program, "impostor_clip_from_world", clips)
    for name, values in vec.items():
        write_uniform_array(program, f"impostor_{name}", values)
    write_uniform_array(program, "impostor_slab", slab)
    write_uniform_array(program, "impostor_radius", radius)
    write_uniform_array(program, "impostor_flat", flat)


def bind_planes(program, planes: list, gpu) -> None:
    """Set impostors.glsl's plane uniforms (``planes``: the NearbyPlanes) and bind their textures."""
    set_uniform(program, "plane_count", len(planes))
    if not planes:
        return
    for name in ("center", "normal", "half_u", "half_v", "color"):
        values = np.zeros((MAX_PLANES, 3), "f4")
        values[: len(planes)] = [getattr(p, name) for p in planes]
        write_uniform_array(program, f"plane_{name.removeprefix('half_')}", values)
    textured = [k for k, p in enumerate(planes) if p.texture is not None]
    if not textured or "plane_texture" not in program:
        return
    index, origins, axes = np.full(MAX_PLANES, -1, "i4"), np.zeros((MAX_PLANES, 2), "f4"), np.zeros((MAX_PLANES, 4), "f4")
    for j, k in enumerate(textured):
        index[k], origins[k], axes[k] = j, planes[k].uv_origin, planes[k].uv_axes.reshape(-1)
    write_uniform_array(program, "plane_texture_index", index)
    write_uniform_array(program, "plane_uv_origin", origins)
    write_uniform_array(program, "plane_uv_axes", axes)
    units = list(TEXTURE_UNITS["plane_textures"][:len(textured)])
    for unit, k in zip(units, textured):
        gpu.albedo_texture(planes[k].texture).use(unit)
    program["plane_texture"].write(np.array(units, "i4").tobytes())
