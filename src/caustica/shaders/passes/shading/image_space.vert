// Mesh vertex stage of image-space refraction: the shared one (object -> world -> clip,
// world position and normal) plus Wyman's d_N, the per-vertex distance along -N to the far
// side, precomputed in object space and carried into world units here.
#version 430 core
uniform mat4 world_from_object;
uniform mat3 world_normal_from_object;
uniform mat4 clip_from_world;

in vec3 in_position;
in vec3 in_normal;
in float in_dn;
out vec3 world_position;
out vec3 world_normal;
out float world_dn;

void main() {
    vec4 p = world_from_object * vec4(in_position, 1.0);
    world_position = p.xyz;
    world_normal = world_normal_from_object * in_normal;
    // The segment of length d_N along -N scales by |M N|: exact for uniform scale.
    world_dn = in_dn * length(mat3(world_from_object) * normalize(in_normal));
    gl_Position = clip_from_world * p;
}
