// per-vertex (Kakimoto et al., 3.4 and 4.5): a mirror or lens with per-vertex texture coordinates
// into its reflection map. The same object -> world -> clip products as common/mesh_vertex.glsl,
// so the surface lands on the depth ShadeSurfaces wrote. Host sets no defines.
#version 430 core
uniform mat4 world_from_object;
uniform mat3 world_normal_from_object;
uniform mat4 clip_from_world;

in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv_r;           // Q of the exact hit in the map, per colour channel (lens aberration)
in vec2 in_uv_g;
in vec2 in_uv_b;
in float in_zoom;          // 1: the hit lies in the zooming region (reversed map)
in vec3 in_weight;         // mirror: its colour; lens: exit Fresnel and Beer-Lambert per channel
out vec3 world_position;
out vec3 world_normal;
out vec2 uv_r;
out vec2 uv_g;
out vec2 uv_b;
out float zoom;
out vec3 weight;

void main() {
    vec4 p = world_from_object * vec4(in_position, 1.0);
    world_position = p.xyz;
    world_normal = world_normal_from_object * in_normal;
    uv_r = in_uv_r;
    uv_g = in_uv_g;
    uv_b = in_uv_b;
    zoom = in_zoom;
    weight = in_weight;
    gl_Position = clip_from_world * p;
}
