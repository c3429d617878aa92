// env-map baseline: single-interface reflection/refraction of the distant environment.
// Glass: F env(reflect) + (1 - F) env(T1) exp(-sigma_a * thickness), per RGB channel
// (one IOR each, for dispersion); thickness = farthest back-face distance - front distance.
// The exit direction this baseline assumes is T1 itself. Host defines: MAX_LIGHTS, CAUSTICS,
// SURFACE_KIND, DISPERSION (ShadeSurfaces; 0: one IOR for all channels).
#version 430 core
#include "common/surface_inputs.glsl"

uniform sampler2D back_surface;  // farthest back face: normal xyz, eye distance w

vec3 shade_refractor(vec3 v, vec3 n, out vec4 exit_dir) {
    vec3 reflected = environment_radiance(environment, reflect_direction(v, n));
    float front = length(world_position - camera_position);
    float back = texelFetch(back_surface, ivec2(gl_FragCoord.xy), 0).w;
    vec3 transmittance = exp(-absorption_coefficient * max(back - front, 0.0));
    vec3 result;
#if DISPERSION
    for (int c = 0; c < 3; ++c) {
        float f = fresnel_dielectric(dot(-v, n), 1.0, ior_rgb[c]);
        vec3 t = refract_direction(v, n, 1.0 / ior_rgb[c]);
        float refracted = dot(t, t) > 0.0 ? environment_radiance(environment, t)[c] : 0.0;
        result[c] = f * reflected[c] + (1.0 - f) * refracted * transmittance[c];
    }
#else
    // One IOR for all channels: one refraction, one lookup.
    float f = fresnel_dielectric(dot(-v, n), 1.0, ior_rgb[1]);
    vec3 t = refract_direction(v, n, 1.0 / ior_rgb[1]);
    vec3 refracted = dot(t, t) > 0.0 ? environment_radiance(environment, t) : vec3(0.0);
    result = f * reflected + (1.0 - f) * refracted * transmittance;
#endif
    vec3 t1 = refract_direction(v, n, 1.0 / ior_rgb[1]);
    exit_dir = dot(t1, t1) > 0.0 ? vec4(t1, 1.0) : vec4(0.0);
    return result;
}

#include "common/surface_main.glsl"
