// TVCG 3.3, fig. 21-23: caustics onto receivers by projection. For each receiver texel of a light
// view (position + distance to the light, normal + receiver code), every caustic tile whose object
// is that receiver is looked up by the rectangle's parallel projection (bilinear inside the tile) and
// turned from irradiance across the axis into irradiance on the surface (|N . w|). Planar receivers are
// their rectangles, so this is the paper's direct texture on a plane. Output: the caustic-map contract
// (rgb irradiance, a = the receiver's distance to the light; 0 where empty). Host defines: MAX_TILES (16),
// TILE_COUNT (the tiles in use: a constant, so the loop over them unrolls).
#version 430 core
#ifndef MAX_TILES
#define MAX_TILES 16
#endif
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D receiver_position;
uniform sampler2D receiver_normal;
uniform sampler2D caustic;        // tiles side by side
uniform int tile_size;
uniform mat4 tile_clip_from_world[MAX_TILES];
uniform vec3 tile_axis[MAX_TILES];
uniform float tile_code[MAX_TILES];  // receiver code (diffuse index + 1) of the tile's object
layout(rgba32f, binding = 0) writeonly uniform image2D caustic_map;

vec3 tile_lookup(int k, vec2 uv) {
    vec2 x = uv * float(tile_size) - 0.5;
    vec2 base = floor(x), f = x - base;
    vec3 sum = vec3(0.0);
    for (int j = 0; j <= 1; ++j)
        for (int i = 0; i <= 1; ++i) {
            ivec2 q = clamp(ivec2(base) + ivec2(i, j), ivec2(0), ivec2(tile_size - 1));
            float w = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y);
            sum += w * texelFetch(caustic, q + ivec2(k * tile_size, 0), 0).rgb;
        }
    return sum;
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(caustic_map);
    if (t.x >= size.x || t.y >= size.y) return;
    vec4 receiver = texelFetch(receiver_position, t, 0);
    vec4 normal = texelFetch(receiver_normal, t, 0);
    vec3 e = vec3(0.0);
    if (receiver.a > 0.0) {
        for (int k = 0; k < TILE_COUNT; ++k) {
            if (abs(normal.w - tile_code[k]) > 0.5) continue;
            vec4 clip = tile_clip_from_world[k] * vec4(receiver.xyz, 1.0);
            vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
            if (clip.w <= 0.0 || any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) continue;
            e += tile_lookup(k, uv) * abs(dot(normalize(normal.xyz), tile_axis[k]));
        }
    }
    imageStore(caustic_map, t, vec4(e, receiver.a > 0.0 ? receiver.a : 0.0));
}
