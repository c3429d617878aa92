// per-vertex (Kakimoto et al., 3.4, 4.2, 4.5): the reflection map warped by per-vertex texture
// coordinates. Mirror: weight * map. Lens: Fresnel reflection of the environment at the front
// surface plus (1 - F1) * weight * map, one texture coordinate and IOR per channel (the
// chromatic aberration of fig. 15 shares one map). Fragments whose vertices hit the zooming
// region read the reversed map. Host defines (one variant each, since CPU rasterizers pay for
// every side of a branch): LENS (0/1), ZOOM (0/1: a reversed map is bound), DISPERSION (0/1:
// one texture coordinate per channel). Uniforms: environment, reflection_map, zoom_map
// (samplers), ior_rgb, camera_position, intensity_scale.
#version 430 core
#include "common/optics.glsl"
#include "common/environment.glsl"

uniform sampler2D environment;
uniform sampler2D reflection_map;
uniform sampler2D zoom_map;
uniform vec3 ior_rgb;
uniform vec3 camera_position;
uniform float intensity_scale;

in vec3 world_position;
in vec3 world_normal;
in vec2 uv_r;
in vec2 uv_g;
in vec2 uv_b;
in float zoom;
in vec3 weight;
layout(location = 0) out vec4 color;
layout(location = 1) out vec4 exit_direction;

vec3 map_at(vec2 uv) {
#if ZOOM
    if (zoom > 0.5) return texture(zoom_map, uv).rgb;
#endif
    return texture(reflection_map, uv).rgb;
}

void main() {
#if DISPERSION
    vec3 through = vec3(map_at(uv_r).r, map_at(uv_g).g, map_at(uv_b).b) * weight;
#else
    vec3 through = map_at(uv_g) * weight;
#endif
    exit_direction = vec4(0.0);
#if !LENS
    color = vec4(through, 1.0);
#else
    vec3 v = normalize(world_position - camera_position);
    vec3 n = normalize(world_normal);
    if (dot(n, v) > 0.0) n = -n;
    vec3 reflected = intensity_scale * environment_radiance(environment, reflect_direction(v, n));
    vec3 result;
    for (int c = 0; c < 3; ++c) {
        float f = fresnel_dielectric(dot(-v, n), 1.0, ior_rgb[c]);
        result[c] = f * reflected[c] + (1.0 - f) * through[c];
    }
    color = vec4(result, 1.0);
#endif
}
