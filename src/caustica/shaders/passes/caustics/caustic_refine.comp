// Adaptive caustic maps (Wyman and Nichols 2009; techniques/caustic_mapping.py, AdaptivePhotons): which live
// cells of a refinement level split into four children at the next. A photon's footprint splat
// (caustic_footprint.comp) models its landing as linear across its cell (a ray differential), which
// spreads the cell's flux evenly over the parallelogram its neighbours span; where the landing bends
// (the caustic's detail: a focus, an envelope, a fold) that model is off by the second difference of the
// landing points, |x(t + e) + x(t - e) - 2 x(t)| along either grid axis, in caustic-map texels. A cell
// whose second difference exceeds `threshold`, or one of whose four neighbours did not land on the same
// face (a silhouette, a rim, total internal reflection), is refined: its photons' flux.w becomes
// STATE_REFINED (adaptive_states.glsl). Landing points are read, never written, so cells run in any order.
// Host defines: VIEW_COUNT (1: view 0 is the caustic map's view).
#version 430 core
#include "passes/caustics/caustic_light_space.glsl"
#include "passes/post/adaptive_states.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

struct Photon { vec4 position; vec4 flux; };
layout(std430, binding = 0) buffer Photons { Photon photons[]; };
uniform ivec2 grid;       // cells of this level (a cube atlas: 6 faces of grid.y side by side)
uniform int channels;     // photons per cell
uniform float threshold;  // caustic-map texels

// Caustic-map pixel and face of the photon of cell t, channel c; false unless it landed inside the
// map and t lies on grid face `grid_face`.
bool landing(ivec2 t, int c, int grid_face, out vec2 x, out int face) {
    x = vec2(0.0);
    face = -1;
    if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, grid)) || t.x / grid.y != grid_face) return false;
    Photon ph = photons[(t.y * grid.x + t.x) * channels + c];
    if (ph.position.w <= 0.0) return false;
    bool inside;
    x = view_pixel(0, ph.position.xyz, face, inside);
    return inside;
}

// Whether the photon of cell t, channel c (landed at x0 on face f0) needs finer photons.
bool needs_refinement(ivec2 t, int c, int grid_face, vec2 x0, int f0) {
    for (int axis = 0; axis < 2; ++axis) {
        ivec2 e = axis == 0 ? ivec2(1, 0) : ivec2(0, 1);
        vec2 xp, xm;
        int fp, fm;
        if (!landing(t + e, c, grid_face, xp, fp) || !landing(t - e, c, grid_face, xm, fm) || fp != f0 || fm != f0)
            return true;
        if (length(xp + xm - 2.0 * x0) > threshold) return true;
    }
    return false;
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (t.x >= grid.x || t.y >= grid.y) return;
    int first = (t.y * grid.x + t.x) * channels;
    if (photons[first].flux.w != STATE_LIVE) return;
    int grid_face = t.x / grid.y;
    bool refine = false;
    for (int c = 0; c < channels && !refine; ++c) {
        Photon ph = photons[first + c];
        vec2 x0;
        int f0;
        if (ph.position.w <= 0.0 || all(equal(ph.flux.rgb, vec3(0.0)))) continue;
        refine = !landing(t, c, grid_face, x0, f0) || needs_refinement(t, c, grid_face, x0, f0);
    }
    if (!refine) return;
    for (int c = 0; c < channels; ++c) photons[first + c].flux.w = STATE_REFINED;
}
