// Shared vertex stage for meshes: object -> world -> clip. Writes world position and normal (and
// surface_uv and world_tangent: host defines ALBEDO_TEXTURE, SURFACE_UV, NORMAL_TEXTURE,
// common/albedo_vertex.glsl; baked_vertex_irradiance: host define ENVIRONMENT_BAKE_VERTICES,
// common/baked_vertex.glsl).
#version 430 core
#include "common/albedo_vertex.glsl"
#include "common/baked_vertex.glsl"
uniform mat4 world_from_object;
uniform mat3 world_normal_from_object;
uniform mat4 clip_from_world;

in vec3 in_position;
in vec3 in_normal;
out vec3 world_position;
out vec3 world_normal;

void main() {
    vec4 p = world_from_object * vec4(in_position, 1.0);
    world_position = p.xyz;
    world_normal = world_normal_from_object * in_normal;
    pass_surface_uv();
    pass_surface_tangent(mat3(world_from_object));
    pass_baked_irradiance();
    gl_Position = clip_from_world * p;
}
