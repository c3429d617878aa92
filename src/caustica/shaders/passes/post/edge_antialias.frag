// Post-process edge anti-aliasing: each pixel on a luminance edge is blended with the neighbour across
// the edge by the fraction of the pixel the far side would cover, estimated from how far the pixel lies
// from the ends of the edge's run of pixels (the end-search idea of Lottes' FXAA; docs/antialiasing.md).
// Detection works on a compressed luma (HDR-safe); the blend is linear, as a box filter would average.
// Host defines: MAX_STEPS (the end search's steps each way).
#version 430 core
uniform sampler2D source;
in vec2 ndc;
out vec4 resolved;

const float EDGE_THRESHOLD = 0.125;     // local contrast, relative to the brightest neighbour
const float EDGE_THRESHOLD_MIN = 0.03;  // and absolute (compressed luma), below which nothing is done
const float SUBPIXEL_WEIGHT = 0.75;     // how far a lone bright or dark pixel is pulled to its neighbours

ivec2 last_texel;

vec4 fetch(ivec2 p) { return texelFetch(source, clamp(p, ivec2(0), last_texel), 0); }

float luma_of(vec4 c) {
    float y = max(dot(c.rgb, vec3(0.2126, 0.7152, 0.0722)), 0.0);
    return sqrt(y / (1.0 + y));  // monotone, in [0, 1): a bright caustic does not mask the edges around it
}

float luma(ivec2 p) { return luma_of(fetch(p)); }

// Step lengths along the edge, in pixels: whole pixels, so the mean of the two rows is exact.
int step_length(int i) { return i < 5 ? 1 : (i < 9 ? 2 : (i < 11 ? 4 : 8)); }

void main() {
    last_texel = textureSize(source, 0) - 1;
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 center = fetch(p);
    float m = luma_of(center);
    float n = luma(p + ivec2(0, 1)), s = luma(p + ivec2(0, -1));
    float e = luma(p + ivec2(1, 0)), w = luma(p + ivec2(-1, 0));
    float hi = max(m, max(max(n, s), max(e, w)));
    float lo = min(m, min(min(n, s), min(e, w)));
    float range = hi - lo;
    if (range < max(EDGE_THRESHOLD_MIN, hi * EDGE_THRESHOLD)) {
        resolved = center;
        return;
    }
    float nw = luma(p + ivec2(-1, 1)), ne = luma(p + ivec2(1, 1));
    float sw = luma(p + ivec2(-1, -1)), se = luma(p + ivec2(1, -1));

    // Second differences across each axis: an edge running along x varies most along y.
    float along_x = 2.0 * abs(n - 2.0 * m + s) + abs(nw - 2.0 * w + sw) + abs(ne - 2.0 * e + se);
    float along_y = 2.0 * abs(w - 2.0 * m + e) + abs(nw - 2.0 * n + ne) + abs(sw - 2.0 * s + se);
    bool runs_along_x = along_x >= along_y;
    ivec2 along = runs_along_x ? ivec2(1, 0) : ivec2(0, 1);
    ivec2 across = runs_along_x ? ivec2(0, 1) : ivec2(1, 0);
    float before = runs_along_x ? s : w, after = runs_along_x ? n : e;
    // The edge lies between this pixel and the neighbour it differs from most.
    if (abs(before - m) >= abs(after - m)) across = -across;
    float other = (abs(before - m) >= abs(after - m)) ? before : after;
    float edge_luma = 0.5 * (m + other);
    float threshold = 0.25 * abs(other - m);

    // Walk both ways along the edge line (the mean of this row and the other's) until it ends.
    float end_luma[2];
    int distance[2];
    for (int side = 0; side < 2; ++side) {
        ivec2 dir = side == 0 ? -along : along;
        int d = 0;
        float delta = 0.0;
        for (int i = 0; i < MAX_STEPS; ++i) {
            d += step_length(i);
            ivec2 q = p + dir * d;
            delta = 0.5 * (luma(q) + luma(q + across)) - edge_luma;
            if (abs(delta) >= threshold) break;
        }
        end_luma[side] = delta;
        distance[side] = d;
    }
    int nearer = distance[0] < distance[1] ? 0 : 1;
    // The run's ends lie half a pixel before the first pixels past it.
    float run = float(distance[0] + distance[1] - 1);
    // A pixel near the end where the edge steps towards it is covered by the far side in proportion.
    bool steps_here = (end_luma[nearer] < 0.0) != (m < edge_luma);
    float edge_weight = steps_here ? 0.5 - (float(distance[nearer]) - 0.5) / run : 0.0;

    // A pixel unlike most of its neighbours (a lone sparkle, a thin line's end) is pulled towards the one
    // across; a pixel on a straight edge (a third to half of the range from their mean) is left alone.
    float neighbours = (2.0 * (n + s + e + w) + nw + ne + sw + se) / 12.0;
    float lone = clamp(2.0 * abs(neighbours - m) / range - 1.0, 0.0, 1.0);
    lone = lone * lone * (3.0 - 2.0 * lone);
    float weight = max(edge_weight, lone * lone * SUBPIXEL_WEIGHT);
    resolved = mix(center, fetch(p + across), weight);
}
