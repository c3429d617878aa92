// transport-table-view (Iwasaki et al. 5.3): glass shaded with the view ray's exit through the light
// transport table, looked up per vertex on the CPU and interpolated over the triangles:
// F env(reflect) + (1 - F) T env(exit direction), F the exact front-surface Fresnel per fragment,
// T the table's transmittance after the entry (later interfaces, Beer-Lambert) per channel.
// Host defines: MAX_LIGHTS, CAUSTICS (ShadeSurfaces).
#version 430 core
#include "common/surface_inputs.glsl"

in vec3 exit_dir_world;  // interpolated world exit direction of the view ray
in vec3 exit_t;          // interpolated transmittance after the front interface

vec3 shade_refractor(vec3 v, vec3 n, out vec4 exit_dir) {
    vec3 reflected = environment_radiance(environment, reflect_direction(v, n));
    float f = fresnel_dielectric(dot(-v, n), 1.0, ior_rgb[1]);
    float len = length(exit_dir_world);
    vec3 result = f * reflected;
    exit_dir = vec4(0.0);
    if (len > 1e-6) {
        vec3 d = exit_dir_world / len;
        result += (1.0 - f) * clamp(exit_t, 0.0, 1.0) * environment_radiance(environment, d);
        exit_dir = vec4(d, 1.0);
    }
    return result;
}

#include "common/surface_main.glsl"
