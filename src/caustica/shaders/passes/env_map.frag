// env-map baseline: single-interface reflection/refraction of the distant environment.
// Diffuse: direct light with shadow maps + SH ambient. Mirror: colour * env(reflect).
// Glass: F env(reflect) + (1 - F) env(refract) exp(-sigma_a * thickness), per RGB channel
// (one IOR each, for dispersion); thickness = back-face distance - front distance.
// The single interface's T1 is the exit direction this baseline assumes (second output).
// Host defines: MAX_LIGHTS (12).
#version 430 core
#include "common/optics.glsl"
#include "common/environment.glsl"
#include "common/lighting.glsl"

#define MATERIAL_DIFFUSE 0
#define MATERIAL_MIRROR 1
#define MATERIAL_GLASS 2

uniform sampler2D environment;
uniform sampler2D back_surface;  // farthest back face: normal xyz, eye distance w
uniform vec3 camera_position;
uniform int material_kind;
uniform vec3 material_color;
uniform vec3 ior_rgb;
uniform vec3 absorption_coefficient;
uniform float intensity_scale;

in vec3 world_position;
in vec3 world_normal;
layout(location = 0) out vec4 color;
layout(location = 1) out vec4 exit_direction;  // debug: world direction leaving the refractor (green IOR), w = 1 where defined

vec3 shade_glass(vec3 v, vec3 n) {
    vec3 reflected = environment_radiance(environment, reflect_direction(v, n));
    float front = length(world_position - camera_position);
    float back = texelFetch(back_surface, ivec2(gl_FragCoord.xy), 0).w;
    float thickness = max(back - front, 0.0);
    vec3 transmittance = exp(-absorption_coefficient * thickness);
    vec3 result;
    for (int c = 0; c < 3; ++c) {
        float f = fresnel_dielectric(dot(-v, n), 1.0, ior_rgb[c]);
        vec3 t = refract_direction(v, n, 1.0 / ior_rgb[c]);
        float refracted = dot(t, t) > 0.0 ? environment_radiance(environment, t)[c] : 0.0;
        result[c] = f * reflected[c] + (1.0 - f) * refracted * transmittance[c];
    }
    return result;
}

void main() {
    vec3 v = normalize(world_position - camera_position);
    vec3 n = normalize(world_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 radiance;
    exit_direction = vec4(0.0);
    if (material_kind == MATERIAL_DIFFUSE) {
        vec3 e = direct_irradiance(world_position, n) + ambient_irradiance(n);
        radiance = material_color / PI * e;
    } else if (material_kind == MATERIAL_MIRROR) {
        radiance = material_color * environment_radiance(environment, reflect_direction(v, n));
    } else {
        radiance = shade_glass(v, n);
        vec3 t = refract_direction(v, n, 1.0 / ior_rgb[1]);
        exit_direction = dot(t, t) > 0.0 ? vec4(t, 1.0) : vec4(0.0);
    }
    color = vec4(intensity_scale * radiance, 1.0);
}
