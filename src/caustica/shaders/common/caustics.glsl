// Caustic irradiance on diffuse receivers from light-space caustic maps (one per light sample).
// A map texel holds the irradiance (W/m^2, RGB) that focused light delivers to the receiver
// surface the texel sees, and in alpha that surface's distance to the light (0: empty), so a
// receiver only takes light meant for it. Projective maps (spot, directional, or a point light
// aimed at its refractors) use caustic_clip_from_world; cube maps use the six-face atlas layout
// of the shadow maps (cube_atlas_uv in lighting.glsl). Or, with CAUSTIC_TILES, caustic textures
// on rectangles (Hu and Qin 3.3, fig. 21-23): the fragment of receiver OBJk finds its place in
// each of its rectangles' textures by the rectangle's parallel projection.
// Host defines: CAUSTICS (0/1), CAUSTIC_TILES (0/1), MAX_LIGHTS, MAX_CAUSTIC_TILES.
#ifndef CAUSTICS
#define CAUSTICS 0
#endif
#ifndef CAUSTIC_TILES
#define CAUSTIC_TILES 0
#endif
#define CAUSTIC_NONE 0
#define CAUSTIC_PROJECTIVE 1
#define CAUSTIC_CUBE 2

#if CAUSTICS
uniform int caustic_kind[MAX_LIGHTS];
uniform mat4 caustic_clip_from_world[MAX_LIGHTS];
uniform sampler2D caustic_map[MAX_LIGHTS];
uniform float caustic_distance_tolerance;  // relative: |a - d| < tolerance * d, the same at any scale of the scene

// Bilinear over the four texels around uv (clamped to [lo, hi]) that belong to the receiver at distance d.
vec3 caustic_lookup(sampler2D map, vec2 uv, vec2 lo, vec2 hi, float d) {
    vec2 size = vec2(textureSize(map, 0));
    vec2 x = uv * size - 0.5;
    vec2 base = floor(x), f = x - base;
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (int j = 0; j <= 1; ++j)
        for (int i = 0; i <= 1; ++i) {
            ivec2 texel = ivec2(clamp(base + vec2(i, j), lo * size, hi * size - 1.0));
            vec4 value = texelFetch(map, texel, 0);
            float w = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y);
            if (value.a > 0.0 && abs(value.a - d) < caustic_distance_tolerance * d) {
                sum += w * value.rgb;
                weight += w;
            }
        }
    return weight > 0.0 ? sum / weight : vec3(0.0);
}

vec3 caustic_irradiance(vec3 p, vec3 n) {
    vec3 e = vec3(0.0);
    for (int i = 0; i < light_count; ++i) {
        if (caustic_kind[i] == CAUSTIC_PROJECTIVE) {
            vec4 clip = caustic_clip_from_world[i] * vec4(p, 1.0);
            vec3 ndc = clip.xyz / clip.w;
            if (clip.w <= 0.0 || any(greaterThan(abs(ndc.xy), vec2(1.0)))) continue;
            float d = light_type[i] == LIGHT_DIRECTIONAL ? dot(p - light_position[i], light_direction[i])
                                                         : length(p - light_position[i]);
            e += caustic_lookup(caustic_map[i], ndc.xy * 0.5 + 0.5, vec2(0.0), vec2(1.0), d);
        } else if (caustic_kind[i] == CAUSTIC_CUBE) {
            vec3 v = p - light_position[i];
            int face;
            vec2 uv = cube_atlas_uv(v, face);
            vec2 lo = vec2(float(face) / 6.0, 0.0), hi = vec2(float(face + 1) / 6.0, 1.0);
            e += caustic_lookup(caustic_map[i], vec2((float(face) + uv.x) / 6.0, uv.y), lo, hi, length(v));
        }
    }
    return e;
}
#elif CAUSTIC_TILES
uniform sampler2D caustic_tiles;   // the tiles side by side: irradiance across each rectangle's axis
uniform int caustic_tile_size;
uniform mat4 caustic_tile_clip_from_world[MAX_CAUSTIC_TILES];
uniform vec3 caustic_tile_axis[MAX_CAUSTIC_TILES];  // from the caster towards the receiver
uniform int receiver_tile[MAX_CAUSTIC_TILES];       // the tiles on the object being drawn
uniform int receiver_tile_count;

// Bilinear inside tile k.
vec3 caustic_tile_lookup(int k, vec2 uv) {
    vec2 x = uv * float(caustic_tile_size) - 0.5;
    vec2 base = floor(x), f = x - base;
    vec3 sum = vec3(0.0);
    for (int j = 0; j <= 1; ++j)
        for (int i = 0; i <= 1; ++i) {
            ivec2 q = clamp(ivec2(base) + ivec2(i, j), ivec2(0), ivec2(caustic_tile_size - 1));
            float w = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y);
            sum += w * texelFetch(caustic_tiles, q + ivec2(k * caustic_tile_size, 0), 0).rgb;
        }
    return sum;
}

// Irradiance across the axis turned into irradiance on the surface (|N . axis|), on the side
// facing the caster only.
vec3 caustic_irradiance(vec3 p, vec3 n) {
    vec3 e = vec3(0.0);
    for (int r = 0; r < receiver_tile_count; ++r) {
        int k = receiver_tile[r];
        vec4 clip = caustic_tile_clip_from_world[k] * vec4(p, 1.0);
        vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
        if (clip.w <= 0.0 || any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) continue;
        e += caustic_tile_lookup(k, uv) * max(-dot(n, caustic_tile_axis[k]), 0.0);
    }
    return e;
}
#else
vec3 caustic_irradiance(vec3 p, vec3 n) { return vec3(0.0); }
#endif
