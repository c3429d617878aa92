// Direct light on diffuse receivers with shadow maps, plus unoccluded ambient from the
// environment's SH irradiance. Host defines: MAX_LIGHTS (passes/lights.py sets it; 8 here alone);
// LIGHT_POINT, _DIRECTIONAL, _SPOT (scene/codes.py: light_type's codes; the shader library sets them
// in every program).
#ifndef MAX_LIGHTS
#define MAX_LIGHTS 8
#endif

uniform int light_count;
uniform int light_type[MAX_LIGHTS];
uniform vec3 light_position[MAX_LIGHTS];
uniform vec3 light_direction[MAX_LIGHTS];      // travel direction (directional, spot axis)
uniform vec3 light_intensity[MAX_LIGHTS];      // W/sr (point, spot) or irradiance (directional)
uniform vec2 light_cone_cos[MAX_LIGHTS];       // spot: cos(inner), cos(outer)
uniform mat4 light_clip_from_world[MAX_LIGHTS]; // directional and spot shadow projection
uniform sampler2D shadow_map[MAX_LIGHTS];      // r32f: distance to the light (atlas of 6 faces for points)
uniform vec3 cube_forward[6];
uniform vec3 cube_up[6];
uniform float shadow_bias;
uniform vec3 irradiance_sh[9];

// Stored occluder distance at a texel, 3x3 percentage-closer filtered against `dist`.
float shadow_pcf(sampler2D map, vec2 uv, vec2 lo, vec2 hi, float dist) {
    vec2 texel = 1.0 / vec2(textureSize(map, 0));
    float lit = 0.0;
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) {
            vec2 p = clamp(uv + vec2(x, y) * texel, lo + 0.5 * texel, hi - 0.5 * texel);
            lit += (texture(map, p).r >= dist) ? 1.0 : 0.0;
        }
    return lit / 9.0;
}

// Which face of the point-light atlas a direction falls on, and its [0,1]^2 coordinates.
vec2 cube_atlas_uv(vec3 v, out int face) {
    vec3 a = abs(v);
    if (a.x >= a.y && a.x >= a.z) face = v.x > 0.0 ? 0 : 1;
    else if (a.y >= a.z) face = v.y > 0.0 ? 2 : 3;
    else face = v.z > 0.0 ? 4 : 5;
    vec3 f = cube_forward[face], up = cube_up[face], r = cross(f, up);
    float depth = dot(v, f);
    return vec2(dot(v, r), dot(v, up)) / depth * 0.5 + 0.5;
}

float light_visibility(int i, vec3 p, vec3 n) {
    if (light_type[i] == LIGHT_POINT) {
        vec3 v = p - light_position[i];
        float dist = length(v);
        int face;
        vec2 uv = cube_atlas_uv(v, face);
        vec2 lo = vec2(float(face) / 6.0, 0.0), hi = vec2(float(face + 1) / 6.0, 1.0);
        return shadow_pcf(shadow_map[i], vec2((float(face) + uv.x) / 6.0, uv.y), lo, hi, dist - shadow_bias * (1.0 + dist));
    }
    vec4 clip = light_clip_from_world[i] * vec4(p, 1.0);
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) return light_type[i] == LIGHT_DIRECTIONAL ? 1.0 : 0.0;
    float dist = light_type[i] == LIGHT_DIRECTIONAL ? dot(p - light_position[i], light_direction[i])
                                                    : length(p - light_position[i]);
    return shadow_pcf(shadow_map[i], ndc.xy * 0.5 + 0.5, vec2(0.0), vec2(1.0), dist - shadow_bias * (1.0 + abs(dist)));
}

// Irradiance at p with normal n from every light, shadowed.
vec3 direct_irradiance(vec3 p, vec3 n) {
    vec3 e = vec3(0.0);
    for (int i = 0; i < light_count; ++i) {
        vec3 to_light;
        vec3 incident;
        if (light_type[i] == LIGHT_DIRECTIONAL) {
            to_light = -light_direction[i];
            incident = light_intensity[i];
        } else {
            vec3 v = light_position[i] - p;
            float d2 = dot(v, v);
            to_light = v / sqrt(d2);
            incident = light_intensity[i] / d2;
            if (light_type[i] == LIGHT_SPOT) {
                float c = dot(-to_light, light_direction[i]);
                float t = clamp((c - light_cone_cos[i].y) / max(light_cone_cos[i].x - light_cone_cos[i].y, 1e-9), 0.0, 1.0);
                incident *= t * t * (3.0 - 2.0 * t);
            }
        }
        float cos_theta = dot(n, to_light);
        if (cos_theta <= 0.0) continue;
        e += incident * cos_theta * light_visibility(i, p, n);
    }
    return e;
}

// Cosine-convolved environment (Ramamoorthi and Hanrahan 2001) from 9 SH coefficients.
vec3 ambient_irradiance(vec3 n) {
    float x = n.x, y = n.y, z = n.z;
    vec3 e = irradiance_sh[0] * 0.282095
           + irradiance_sh[1] * 0.488603 * y + irradiance_sh[2] * 0.488603 * z + irradiance_sh[3] * 0.488603 * x
           + irradiance_sh[4] * 1.092548 * x * y + irradiance_sh[5] * 1.092548 * y * z
           + irradiance_sh[6] * 0.315392 * (3.0 * z * z - 1.0) + irradiance_sh[7] * 1.092548 * x * z
           + irradiance_sh[8] * 0.546274 * (x * x - y * y);
    return max(e, vec3(0.0));
}
