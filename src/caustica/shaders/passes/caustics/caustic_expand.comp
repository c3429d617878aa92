// Adaptive caustic maps (techniques/caustic_mapping.py, ExpandPhotons): the live photons of one refinement
// level spread over the finest grid. A photon of a cell block x block finest cells wide is split into its
// block^2 finest cells, each with 1 / block^2 of its flux, landing where the first-order model of its
// landing puts that cell's centre: x0 + du X_u + dv X_v, X_u and X_v the landing's derivatives per cell
// from the level's neighbours (a ray differential; the central difference, the one side where only one
// landed or where the two disagree in length by more than EXPAND_JUMP, none where neither did). Every
// photon then lies on the finest grid, so the footprint splats (caustic_footprint.comp) sum flat across
// the levels, as on a regular grid, where Gaussians of two sizes meeting at a level's edge would not.
// Host defines: none.
#version 430 core
#include "passes/post/adaptive_states.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
#define EXPAND_JUMP 2.0

struct Photon { vec4 position; vec4 flux; };
layout(std430, binding = 0) readonly buffer Level { Photon level[]; };
layout(std430, binding = 1) buffer Finest { Photon finest[]; };
uniform ivec2 grid;   // this level's cells (a cube atlas: 6 faces of grid.y side by side)
uniform int block;    // finest cells a side of one
uniform int channels;

// Landing point of cell t, channel c, on grid face `face` (w = 0: none).
vec4 landing(ivec2 t, int c, int face) {
    if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, grid)) || t.x / grid.y != face) return vec4(0.0);
    vec4 p = level[(t.y * grid.x + t.x) * channels + c].position;
    return p.w > 0.0 ? p : vec4(0.0);
}

// Derivative of the landing per cell along e.
vec3 derivative(ivec2 t, int c, ivec2 e, int face, vec3 x0) {
    vec4 f = landing(t + e, c, face), b = landing(t - e, c, face);
    vec3 df = f.xyz - x0, db = x0 - b.xyz;
    if (f.w <= 0.0 || b.w <= 0.0) return f.w > 0.0 ? df : b.w > 0.0 ? db : vec3(0.0);
    float lf = length(df), lb = length(db);
    if (max(lf, lb) > EXPAND_JUMP * min(lf, lb)) return lf <= lb ? df : db;
    return 0.5 * (df + db);
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (t.x >= grid.x || t.y >= grid.y) return;
    int face = t.x / grid.y;
    int width = grid.x * block;
    for (int c = 0; c < channels; ++c) {
        Photon ph = level[(t.y * grid.x + t.x) * channels + c];
        if (ph.position.w <= 0.0 || ph.flux.w != STATE_LIVE || all(equal(ph.flux.rgb, vec3(0.0)))) continue;
        vec3 xu = derivative(t, c, ivec2(1, 0), face, ph.position.xyz);
        vec3 xv = derivative(t, c, ivec2(0, 1), face, ph.position.xyz);
        vec4 flux = vec4(ph.flux.rgb / float(block * block), STATE_LIVE);
        for (int j = 0; j < block; ++j) {
            for (int i = 0; i < block; ++i) {
                vec2 d = (vec2(i, j) + 0.5) / float(block) - 0.5;
                ivec2 f = t * block + ivec2(i, j);
                finest[(f.y * width + f.x) * channels + c] = Photon(vec4(ph.position.xyz + d.x * xu + d.y * xv, 1.0), flux);
            }
        }
    }
}
