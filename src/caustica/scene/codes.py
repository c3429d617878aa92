"""Integer codes of material kinds, light types and caustic casters, one table for Python and the shaders.

The ray tracer's material table (``raytrace.paths.Materials``), ``ShadeSurfaces``' ``material_kind``
uniform and ``SURFACE_KIND`` define hold :data:`MATERIAL_CODES`; light samples
(``passes.lights.LightSample.type``, the ``light_type`` and ``ls_light_type`` uniforms) hold the
``LIGHT_*`` codes; caustic-mapping's caster table and photon-splats' object kind hold the ``CASTER_*``
codes (``passes.casters``). The shader library defines :data:`CODE_DEFINES` in every program it builds
(``gpu.shaders.ShaderLibrary``), so no shader spells the numbers out. Pure data: no GL, no scene.
"""
from __future__ import annotations

MATERIAL_DIFFUSE, MATERIAL_MIRROR, MATERIAL_GLASS = 0, 1, 2
MATERIAL_CODES = {"diffuse": MATERIAL_DIFFUSE, "mirror": MATERIAL_MIRROR, "glass": MATERIAL_GLASS}  # by Material.kind
LIGHT_POINT, LIGHT_DIRECTIONAL, LIGHT_SPOT = 0, 1, 2  # a point of a line light is a LIGHT_POINT
CASTER_NONE = 0  # not a caster: occludes the light
CASTER_MIRROR = 1  # reflects once
CASTER_SOLID = 2  # closed glass: refracts in, and out through the back faces
CASTER_SURFACE = 3  # open glass mesh (water): one refracting surface
CODE_DEFINES = {"MATERIAL_DIFFUSE": MATERIAL_DIFFUSE, "MATERIAL_MIRROR": MATERIAL_MIRROR,
                "MATERIAL_GLASS": MATERIAL_GLASS, "LIGHT_POINT": LIGHT_POINT,
                "LIGHT_DIRECTIONAL": LIGHT_DIRECTIONAL, "LIGHT_SPOT": LIGHT_SPOT,
                "CASTER_NONE": CASTER_NONE, "CASTER_MIRROR": CASTER_MIRROR, "CASTER_SOLID": CASTER_SOLID,
                "CASTER_SURFACE": CASTER_SURFACE}
