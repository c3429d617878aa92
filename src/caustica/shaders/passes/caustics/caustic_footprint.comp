// Footprint of each photon on the caustic map (passes/caustics/light_space.py, SplatPhotons): the photons lie on
// the light-space grid they were made on (entry (row * grid.x + column) * channels + channel), so the
// landing points of a photon's grid neighbours (same channel) give the Jacobian J of grid -> caustic-map
// texels, a ray differential. Each photon's grid cell lands on the parallelogram J spans; its Gaussian
// gets the covariance Sigma = sigma0^2 I + s^2 J J^T (sigma0 = splat_radius / 2, s = footprint_scale),
// so neighbouring splats overlap wherever the photons spread apart (a regular grid under a 3-sigma
// Gaussian of s = 0.7 cell sizes sums flat to a few 1e-3) and keep splat_radius where they converge.
// A derivative is the central difference, or, where the forward and backward ones disagree, the
// shorter: across a discontinuity (a silhouette, a crease, another surface) one side jumps far. Each goes to the nearest neighbour that landed within FOOTPRINT_SEARCH
// texels (the rim of a refractor, where the exit estimate loses photons, keeps a few isolated ones:
// with splat_radius's kernel alone they sparkle).
// Degenerate footprints (grazing photons spread over a long streak): Sigma's axes are clamped to
// footprint_cap texels and the photon's flux scaled by the kept fraction of its footprint's area,
// sqrt(det Sigma_clamped / det Sigma): its irradiance near where it lands stays, the rest, which one
// splat cannot place, goes.
// Writes per photon vec4(A_xx, A_xy, A_yy, flux scale) with A = Sigma^-1 (caustic_footprint.glsl) and
// the flux scale = weight / (the kernel's sum over texel centres): a splat deposits weight x its flux.
// Photons of an adaptive level (flux.w not STATE_LIVE) other than live ones get no splat (footprint 0).
// Host defines: VIEW_COUNT (1: view 0 is the caustic map's view).
#version 430 core
#include "passes/caustics/caustic_light_space.glsl"
#include "passes/caustics/caustic_footprint.glsl"
#include "passes/post/adaptive_states.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
#define FOOTPRINT_SEARCH 4
#define FOOTPRINT_JUMP 2.0

struct Photon { vec4 position; vec4 flux; };
layout(std430, binding = 0) readonly buffer Photons { Photon photons[]; };
layout(std430, binding = 1) writeonly buffer Footprints { vec4 footprints[]; };
uniform ivec2 grid;            // the photon grid's texels (a cube atlas: 6 faces of grid.y side by side)
uniform int channels;          // photons per grid texel
uniform float splat_radius;    // texels: sigma0 = splat_radius / 2
uniform float footprint_scale; // s: the footprint's sigma per landed grid cell
uniform float footprint_cap;   // texels: the largest sigma along either axis

// Caustic-map pixel of the photon at grid texel t, channel c; false unless it landed in `face` and its
// grid texel lies on the grid face `grid_face`.
bool landed_pixel(ivec2 t, int c, int grid_face, int face, out vec2 x) {
    x = vec2(0.0);
    if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, grid)) || t.x / grid.y != grid_face) return false;
    Photon ph = photons[(t.y * grid.x + t.x) * channels + c];
    if (ph.position.w <= 0.0) return false;
    int f;
    bool inside;
    x = view_pixel(0, ph.position.xyz, f, inside);
    return inside && f == face;
}

// The nearest landed neighbour along `step` within FOOTPRINT_SEARCH texels: its landing displacement per
// grid texel (true), or false where none landed (the sparse rim of a refractor: photons lost at the exit).
bool neighbour_derivative(ivec2 t, int c, ivec2 step, int grid_face, int face, vec2 x0, out vec2 d) {
    d = vec2(0.0);
    for (int k = 1; k <= FOOTPRINT_SEARCH; ++k) {
        vec2 x;
        if (landed_pixel(t + k * step, c, grid_face, face, x)) {
            d = (x - x0) / float(k);
            return true;
        }
    }
    return false;
}

// Landing displacement per grid texel along `step`: the central difference where the forward and
// backward ones agree (lengths within a factor FOOTPRINT_JUMP, directions within 60 degrees), else the
// shorter (across a discontinuity, a silhouette, a crease or another surface, one side jumps far; a
// photon landed off its neighbours, or a fold, has the two point opposite ways); zero where no
// neighbour landed on either side.
vec2 grid_derivative(ivec2 t, int c, ivec2 step, int grid_face, int face, vec2 x0) {
    vec2 df, db;
    bool f = neighbour_derivative(t, c, step, grid_face, face, x0, df);
    bool b = neighbour_derivative(t, c, -step, grid_face, face, x0, db);
    db = -db;  // per texel along +step
    if (!(f && b)) return f ? df : db;
    float lf = length(df), lb = length(db);
    bool agree = max(lf, lb) <= FOOTPRINT_JUMP * min(lf, lb) && dot(df, db) >= 0.5 * lf * lb;
    return agree ? 0.5 * (df + db) : (lf <= lb ? df : db);
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (t.x >= grid.x || t.y >= grid.y) return;
    int grid_face = t.x / grid.y;
    for (int c = 0; c < channels; ++c) {
        int i = (t.y * grid.x + t.x) * channels + c;
        footprints[i] = vec4(0.0);
        Photon ph = photons[i];
        // Adaptive cells not live (helpers, refined parents: adaptive_states.glsl) are only neighbours.
        if (ph.position.w <= 0.0 || ph.flux.w != STATE_LIVE || all(equal(ph.flux.rgb, vec3(0.0)))) continue;
        int face;
        bool inside;
        vec2 x0 = view_pixel(0, ph.position.xyz, face, inside);
        if (!inside) continue;
        vec2 du = grid_derivative(t, c, ivec2(1, 0), grid_face, face, x0);
        vec2 dv = grid_derivative(t, c, ivec2(0, 1), grid_face, face, x0);
        float s0 = 0.25 * splat_radius * splat_radius, k = footprint_scale * footprint_scale;
        float sxx = s0 + k * (du.x * du.x + dv.x * dv.x);
        float sxy = k * (du.x * du.y + dv.x * dv.y);
        float syy = s0 + k * (du.y * du.y + dv.y * dv.y);
        // Eigen-decomposition of Sigma; clamp its axes to the cap.
        float mean = 0.5 * (sxx + syy), half_gap = sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
        float l1 = mean + half_gap, l2 = max(mean - half_gap, s0);
        float cap = footprint_cap * footprint_cap;
        float weight = 1.0;
        if (l1 > cap) {
            float c1 = cap, c2 = min(l2, cap);
            weight = sqrt(c1 * c2 / (l1 * l2));
            vec2 e = abs(sxy) > 1e-9 * l1 ? normalize(vec2(sxy, l1 - sxx)) : (sxx >= syy ? vec2(1.0, 0.0) : vec2(0.0, 1.0));
            vec2 q = vec2(-e.y, e.x);
            sxx = c1 * e.x * e.x + c2 * q.x * q.x;
            sxy = c1 * e.x * e.y + c2 * q.x * q.y;
            syy = c1 * e.y * e.y + c2 * q.y * q.y;
        }
        float det = max(sxx * syy - sxy * sxy, 1e-30);
        vec3 a = vec3(syy, -sxy, sxx) / det;
        // The kernel's sum over the texel centres it reaches (those off the map too: a splat there loses
        // that part, as splat_normaliser's).
        ivec2 reach = footprint_reach(a);
        vec2 centre = floor(x0) + 0.5;
        float sum = 0.0;
        for (int j = -reach.y; j <= reach.y; ++j) {
            ivec2 row = footprint_row(x0, j, a, reach.x);
            for (int q = row.x; q <= row.y; ++q) sum += footprint_kernel(x0, centre + vec2(q, j), a);
        }
        footprints[i] = sum > 0.0 ? vec4(a, weight / sum) : vec4(0.0);
    }
}
