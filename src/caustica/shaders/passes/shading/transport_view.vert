// transport-table-view: the shared mesh vertex stage plus the per-vertex table lookup of the view ray
// (Iwasaki et al. 5.3): world exit direction and transmittance after the entry (per channel), set by
// the host per frame as vertex attributes; zero on meshes without them (opaque objects). Host defines:
// ALBEDO_TEXTURE (common/albedo_vertex.glsl), ENVIRONMENT_BAKE_VERTICES (common/baked_vertex.glsl).
#version 430 core
#include "common/albedo_vertex.glsl"
#include "common/baked_vertex.glsl"
uniform mat4 world_from_object;
uniform mat3 world_normal_from_object;
uniform mat4 clip_from_world;

in vec3 in_position;
in vec3 in_normal;
in vec3 in_exit_dir;
in vec3 in_exit_t;
out vec3 world_position;
out vec3 world_normal;
out vec3 exit_dir_world;
out vec3 exit_t;

void main() {
    vec4 p = world_from_object * vec4(in_position, 1.0);
    world_position = p.xyz;
    world_normal = world_normal_from_object * in_normal;
    exit_dir_world = in_exit_dir;
    exit_t = in_exit_t;
    pass_surface_uv();
    pass_surface_tangent(mat3(world_from_object));
    pass_baked_irradiance();
    gl_Position = clip_from_world * p;
}
