// The environment lobes' early out (passes/shading/environment.py EnvironmentLobeMaps; lighting.glsl lobe_light): per texel of
// the lobes' atlas, the nearest opaque (r) and glass (g) distance over the 3x3 taps around it, clamped to
// its tile as map_tap clamps them. A receiver no farther along the lobe than both is lit by every tap, and
// its lookup stops after this one fetch with the same result as the nine.
#version 430 core
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D opaque;   // r32f: the opaque objects' distance along the lobe
uniform sampler2D glass;    // rgba32f: a the glass's nearest distance (read where has_glass is 1)
uniform int has_glass;
uniform int tile_size;
layout(rg32f, binding = 0) writeonly uniform image2D nearest;

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(nearest);
    if (t.x >= size.x || t.y >= size.y) return;
    int x0 = (t.x / tile_size) * tile_size;
    vec2 m = vec2(3.0e38);
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) {
            ivec2 u = clamp(ivec2(t.x - x0, t.y) + ivec2(x, y), ivec2(0), ivec2(tile_size - 1));
            ivec2 a = ivec2(x0 + u.x, u.y);
            m.x = min(m.x, texelFetch(opaque, a, 0).r);
            if (has_glass == 1) m.y = min(m.y, texelFetch(glass, a, 0).a);
        }
    imageStore(nearest, t, vec4(m, 0.0, 0.0));
}
