// Nearby geometry for reflected and refracted rays: what a ray (origin o, direction d) sees,
// instead of the environment alone.
//   NEARBY_IMPOSTORS (Hu and Qin, TVCG 2007, 2.2): each nearby object is a rectangle with a
//     texture (radiance rgb, depth along the projection axis in a; 0: empty) rendered from the
//     reflector's centre towards the object's centre; the ray meets the rectangle at Prect, the
//     initial-point rule of 2.2.2 picks a seed among points along the ray, the iterative lookup
//     of fig. 15-16 moves the point along the ray to the depth its texel holds; the nearest
//     rectangle hit wins; rays that hit none see the environment. A reflector's textures are
//     squares of one atlas, so a rectangle is a run-time index: uncorrected (fig. 18c), only
//     the rectangles whose Prect lies on their texture fetch a texel.
//   NEARBY_PLANES (Wyman, "intersecting T2 with other geometry"): a few diffuse rectangles
//     intersected exactly and shaded like every diffuse receiver (lights, shadows, SH ambient).
//   NEARBY_SEARCH_* (Wyman [Wyman05b, Policarpo05, Szirmay-Kalos05]): image-space search along
//     the ray against a camera-view texture of the scene without refractors (radiance, eye
//     distance): linear steps; linear steps then binary refinement; linear steps then secant.
// Include after common/surface_inputs.glsl (environment, lighting, camera uniforms).
// Host defines: NEARBY (0 none, 1 impostors, 2 planes, 3 search-linear, 4 search-binary,
//   5 search-secant; 0), MAX_IMPOSTORS (8: the most rectangles any reflector of the frame has),
//   IMPOSTOR_ITERATIONS (4: fig. 16 steps, 0 uncorrected), IMPOSTOR_SAMPLES (8: 2.2.2 seeds, 0 Prect
//   only), IMPOSTORS_CURVED (1; 0: every rectangle is a flat patch, passes/nearby/impostors.impostor_defines), IMPOSTOR_REFLECTIONS (1; 0: reflected rays, mirrors' and refractors' entry, see the environment) -- constants, so that loops unroll and uniform indices are constant (a CPU rasterizer runs
//   every iteration a uniform bound allows), MAX_PLANES (8), PLANE_TEXTURES (0: the textured planes,
//   at most passes/nearby/impostors.py MAX_PLANE_TEXTURES), PHOTON_BUFFER (0): 1 makes a hit
//   return radiance 1 (a throughput) and a miss 0, for the photon buffer of TVCG 3.1;
//   NEARBY_OUTPUT (0): what a refractor or mirror writes to location 1 (nearby_output): 0 its exit
//   direction, 1 the nearby hit point (xyz, w = 1 hit), 2 the photon record (u, v, k + 1, w = 1 hit).
#ifndef NEARBY
#define NEARBY 0
#endif
#ifndef MAX_IMPOSTORS
#define MAX_IMPOSTORS 8
#endif
#ifndef IMPOSTOR_ITERATIONS
#define IMPOSTOR_ITERATIONS 4
#endif
#ifndef IMPOSTOR_SAMPLES
#define IMPOSTOR_SAMPLES 8
#endif
#ifndef IMPOSTORS_CURVED
#define IMPOSTORS_CURVED 1  // 0: every rectangle of the frame is a flat patch (no seeds, no steps compiled)
#endif
#ifndef IMPOSTOR_REFLECTIONS
#define IMPOSTOR_REFLECTIONS 1  // 0: reflected rays (mirrors, refractors' entry) see the environment only
#endif
#ifndef MAX_PLANES
#define MAX_PLANES 8
#endif
#ifndef PHOTON_BUFFER
#define PHOTON_BUFFER 0
#endif
#ifndef NEARBY_OUTPUT
#define NEARBY_OUTPUT 0
#endif
#define NEARBY_NONE 0
#define NEARBY_IMPOSTORS 1
#define NEARBY_PLANES 2
#define NEARBY_SEARCH_LINEAR 3
#define NEARBY_SEARCH_BINARY 4
#define NEARBY_SEARCH_SECANT 5
// Whether mirrors look up nearby geometry (the shading shaders then redirect their environment
// lookup to nearby_mirror_radiance): with any nearby option, except impostors without reflections.
#define NEARBY_MIRRORS (NEARBY != NEARBY_NONE && !(NEARBY == NEARBY_IMPOSTORS && !IMPOSTOR_REFLECTIONS))

// The last hit of nearby_radiance: world point (w = 1; 0: none) and, for impostors, (u, v, global index + 1).
vec4 nearby_hit = vec4(0.0);
vec3 nearby_uvk = vec3(0.0);

// What a ray that meets no nearby geometry sees; clears the last hit. nearby_radiance looks it up
// before its search, for every ray: the environment's footprint takes screen derivatives, which are
// undefined outside uniform control flow.
vec3 nearby_miss(vec3 d) {
    nearby_hit = vec4(0.0);
    nearby_uvk = vec3(0.0);
#if PHOTON_BUFFER
    return vec3(0.0);
#else
    return environment_radiance(environment, d);
#endif
}

#if NEARBY == NEARBY_IMPOSTORS
uniform int impostor_count;                               // rectangles of the reflector being shaded
uniform int impostor_base;                                // global index of its first rectangle
uniform mat4 impostor_clip_from_world[MAX_IMPOSTORS];     // the (near-parallel) projection of the texture
uniform vec3 impostor_origin[MAX_IMPOSTORS];              // projection centre O, far behind the rectangle
uniform vec3 impostor_axis[MAX_IMPOSTORS];                // w: reflector centre -> object (plane normal for planes)
uniform vec3 impostor_center[MAX_IMPOSTORS];              // rectangle centre (its plane is perpendicular to w)
uniform vec2 impostor_slab[MAX_IMPOSTORS];                // object's depth range from O along w
uniform float impostor_radius[MAX_IMPOSTORS];             // object's bounding radius
uniform int impostor_flat[MAX_IMPOSTORS];                 // 1: a flat patch on its rectangle, exact at Prect (2.2.1)
uniform sampler2D impostor_atlas;                         // rgb radiance, a depth from O along w (0: empty)
uniform ivec2 impostor_cell[MAX_IMPOSTORS];               // texel offset of each rectangle's square in the atlas
uniform int impostor_size;                                // texels a side of each square
uniform float impostor_tolerance;                         // stop once t moves less than this (bounding radii)
uniform float impostor_hit_tolerance;                     // final |depth - texel depth| < this * radius

float impostor_depth(int k, vec3 p) { return dot(p - impostor_origin[k], impostor_axis[k]); }

// Continuous texel position of p in impostor k; false outside the texture or behind O.
bool impostor_pixel(int k, vec3 p, out vec2 pixel) {
    vec4 clip = impostor_clip_from_world[k] * vec4(p, 1.0);
    if (clip.w <= 1e-8) return false;
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    pixel = uv * float(impostor_size);
    return all(greaterThanEqual(uv, vec2(0.0))) && all(lessThan(uv, vec2(1.0)));
}

// The texel (nearest) under p, radiance and depth (vec4(0) where empty or outside), and p's
// continuous texel position: one projection per point.
vec4 impostor_texel(int k, vec3 p, out vec2 pixel) {
    if (!impostor_pixel(k, p, pixel)) return vec4(0.0);
    return texelFetch(impostor_atlas, impostor_cell[k] + ivec2(pixel), 0);
}

// Radiance at a continuous texel position: bilinear over the neighbours that hold the object; where
// none does, the texel under the position, which is one of the four (four fetches, not five).
vec3 impostor_radiance(int k, vec2 pixel) {
    ivec2 size = ivec2(impostor_size);
    vec2 x = pixel - 0.5;
    vec2 base = floor(x), f = x - base;
    ivec2 under = ivec2(pixel) - ivec2(base);  // the texel under pixel, as (i, j) of the four (clamped alike)
    vec3 sum = vec3(0.0), nearest = vec3(0.0);
    float weight = 0.0;
    for (int j = 0; j <= 1; ++j)
        for (int i = 0; i <= 1; ++i) {
            vec4 s = texelFetch(impostor_atlas, impostor_cell[k] + clamp(ivec2(base) + ivec2(i, j), ivec2(0), size - 1), 0);
            float w = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y);
            if (s.a > 0.0) { sum += w * s.rgb; weight += w; }
            if (ivec2(i, j) == under) nearest = s.rgb;
        }
    return weight > 0.0 ? sum / weight : nearest;
}

// Prect: where the ray meets rectangle k (t along it, pixel on its texture); false when it
// misses the texture, and so (the paper's assumption) the object. A ray starting on the rectangle's
// plane (glass standing on a floor leaves it there) meets it at t = 0, within ON_RECTANGLE radii.
const float ON_RECTANGLE = 1e-4;
bool impostor_prect(int k, vec3 o, vec3 d, out float t, out vec2 pixel) {
    float dw = dot(d, impostor_axis[k]);
    t = abs(dw) < 1e-6 ? -1.0 : (impostor_depth(k, impostor_center[k]) - impostor_depth(k, o)) / dw;
    if (t <= 0.0 && t * abs(dw) > -ON_RECTANGLE * impostor_radius[k]) t = 0.0;
    return t >= 0.0 && impostor_pixel(k, o + t * d, pixel);
}

// One rectangle, corrected (IMPOSTOR_ITERATIONS > 0; uncorrected lookups stop at Prect in
// nearby_radiance): Prect, the initial-point rule (2.2.2), the iterative lookup (fig. 16).
// (t, pixel, s) is always the current point along the ray, its texel position and its texel.
// A flat patch lies on its rectangle, so Prect is its hit (2.2.1: a plane's texture is exact):
// neither seeds nor steps (their loops end at once for every pixel).
bool impostor_intersect(int k, vec3 o, vec3 d, out float t_hit, out vec2 uv_hit) {
    float t;
    vec2 pixel;
    if (!impostor_prect(k, o, d, t, pixel)) return false;
    float dw = dot(d, impostor_axis[k]);
    float o_depth = impostor_depth(k, o);
    bool curved = IMPOSTORS_CURVED != 0 && impostor_flat[k] == 0;
    vec4 s = texelFetch(impostor_atlas, impostor_cell[k] + ivec2(pixel), 0);
    // Seed: the first point along the ray whose depth is beyond its selected point's (the
    // paper's priority), otherwise the point whose depth is closest to its selected point's.
#if IMPOSTOR_SAMPLES > 0
    {
        float t0 = (impostor_slab[k].x - o_depth) / dw, t1 = (impostor_slab[k].y - o_depth) / dw;
        float lo = max(min(t0, t1), 0.0), hi = max(t0, t1);
        float best_gap = s.a > 0.0 ? abs(o_depth + t * dw - s.a) : 1e30;
        for (int j = 0; j < IMPOSTOR_SAMPLES && hi > lo && curved; ++j) {
            float tj = mix(lo, hi, (float(j) + 0.5) / float(IMPOSTOR_SAMPLES));
            vec2 pj;
            vec4 sj = impostor_texel(k, o + tj * d, pj);
            if (sj.a <= 0.0) continue;
            float gap = o_depth + tj * dw - sj.a;
            if (gap > 0.0) { t = tj; pixel = pj; s = sj; break; }
            if (-gap < best_gap) { best_gap = -gap; t = tj; pixel = pj; s = sj; }
        }
    }
#endif
    // Iterate: move along the ray to the depth the texel under the point holds; a point that
    // lands off the object goes back to the last one on it.
    float last = -1.0;
    vec2 last_pixel = pixel;
    vec4 last_s = s;
    for (int i = 0; i < IMPOSTOR_ITERATIONS && curved; ++i) {
        if (s.a <= 0.0) break;
        last = t; last_pixel = pixel; last_s = s;
        float next = (s.a - o_depth) / dw;
        if (!(next > 0.0)) break;
        bool done = abs(next - t) < impostor_tolerance * impostor_radius[k];
        t = next;
        s = impostor_texel(k, o + t * d, pixel);
        if (done) break;
    }
    if (s.a <= 0.0 && last > 0.0) { t = last; pixel = last_pixel; s = last_s; }
    if (s.a <= 0.0) return false;
    if (abs(o_depth + t * dw - s.a) > impostor_hit_tolerance * impostor_radius[k]) return false;
    t_hit = t;
    uv_hit = pixel;
    return true;
}

vec3 nearby_radiance(vec3 o, vec3 d) {
    d = normalize(d);
    vec3 missed = nearby_miss(d);  // first: see nearby_miss
    float best = 1e30;
    int hit = -1;
    vec2 hit_pixel = vec2(0.0);
    vec3 hit_texel = vec3(0.0);
#if IMPOSTOR_ITERATIONS == 0
    // Uncorrected (fig. 18c): Prect's texel. Every Prect first, then a fetch only for the
    // rectangles whose texture Prect lies on: a CPU rasterizer runs a branch's fetch for every
    // pixel, but a loop only as often as its busiest pixel needs.
    float prect_t[MAX_IMPOSTORS];
    vec2 prect_pixel[MAX_IMPOSTORS];
    int on_texture = 0;  // bit k: Prect lies on rectangle k's texture
    for (int k = 0; k < MAX_IMPOSTORS; ++k) {  // a constant bound: unrolled, constant uniform indices
        if (k >= impostor_count) break;
        if (impostor_prect(k, o, d, prect_t[k], prect_pixel[k])) on_texture |= 1 << k;
    }
    while (on_texture != 0) {
        int k = findLSB(on_texture);
        on_texture &= on_texture - 1;
        vec4 s = texelFetch(impostor_atlas, impostor_cell[k] + ivec2(prect_pixel[k]), 0);
        if (s.a > 0.0 && prect_t[k] < best) {
            best = prect_t[k]; hit = k; hit_pixel = prect_pixel[k]; hit_texel = s.rgb;
        }
    }
#else
    for (int k = 0; k < MAX_IMPOSTORS; ++k) {  // a constant bound: unrolled, constant uniform indices
        if (k >= impostor_count) break;
        float t;
        vec2 pixel;
        if (impostor_intersect(k, o, d, t, pixel) && t < best) {
            best = t; hit = k; hit_pixel = pixel;
        }
    }
#endif
    if (hit < 0) return missed;
    vec2 uv = hit_pixel / float(impostor_size);
#if IMPOSTOR_ITERATIONS == 0
    vec3 radiance = hit_texel;
#else
    vec3 radiance = impostor_radiance(hit, hit_pixel);
#endif
    nearby_hit = vec4(o + best * d, 1.0);
    nearby_uvk = vec3(uv, float(impostor_base + hit + 1));
#if PHOTON_BUFFER
    return vec3(1.0);
#else
    return radiance;
#endif
}

#elif NEARBY == NEARBY_PLANES
uniform int plane_count;
uniform vec3 plane_center[MAX_PLANES];
uniform vec3 plane_normal[MAX_PLANES];
uniform vec3 plane_u[MAX_PLANES];       // half extents along the rectangle's sides
uniform vec3 plane_v[MAX_PLANES];
uniform vec3 plane_color[MAX_PLANES];   // diffuse albedo
#ifndef PLANE_TEXTURES
#define PLANE_TEXTURES 0
#endif
#if PLANE_TEXTURES
uniform sampler2D plane_texture[PLANE_TEXTURES];
uniform int plane_texture_index[MAX_PLANES];  // into plane_texture; -1: untextured
uniform vec2 plane_uv_origin[MAX_PLANES];     // uv at the centre
uniform vec4 plane_uv_axes[MAX_PLANES];       // d uv / d s (xy), d uv / d t (zw); s, t: -1..1 along u, v
#endif

// Plane k's albedo at q (from its centre): its colour, times its texture at the uvs, an affine map
// of the point on the rectangle (level 0: a ray's lookup has no screen derivatives).
vec3 plane_albedo(int k, vec3 q) {
    vec3 albedo = plane_color[k];
#if PLANE_TEXTURES
    vec2 st = vec2(dot(q, plane_u[k]) / dot(plane_u[k], plane_u[k]), dot(q, plane_v[k]) / dot(plane_v[k], plane_v[k]));
    vec2 uv = plane_uv_origin[k] + st.x * plane_uv_axes[k].xy + st.y * plane_uv_axes[k].zw;
    for (int j = 0; j < PLANE_TEXTURES; ++j)  // constant indices into the sampler array
        if (j == plane_texture_index[k]) albedo *= textureLod(plane_texture[j], uv, 0.0).rgb;
#endif
    return albedo;
}

vec3 nearby_radiance(vec3 o, vec3 d) {
    d = normalize(d);
    vec3 missed = nearby_miss(d);  // first: see nearby_miss
    float best = 1e30;
    int hit = -1;
    for (int k = 0; k < plane_count; ++k) {
        float dn = dot(d, plane_normal[k]);
        if (abs(dn) < 1e-8) continue;
        float t = dot(plane_center[k] - o, plane_normal[k]) / dn;
        vec3 q = o + t * d - plane_center[k];
        vec3 u = plane_u[k], v = plane_v[k];
        if (t > 1e-5 && t < best && abs(dot(q, u)) <= dot(u, u) && abs(dot(q, v)) <= dot(v, v)) { best = t; hit = k; }
    }
    if (hit < 0) return missed;
    vec3 p = o + best * d;
    vec3 n = dot(plane_normal[hit], d) < 0.0 ? plane_normal[hit] : -plane_normal[hit];
    nearby_hit = vec4(p, 1.0);
    vec3 e = direct_irradiance(p, n) + baked_or_sh_irradiance(p, n) + caustic_irradiance(p, n);
    return plane_albedo(hit, p - plane_center[hit]) / PI * e;
}

#elif NEARBY >= NEARBY_SEARCH_LINEAR
uniform sampler2D nearby_view;   // the scene without refractors from the camera: rgb radiance, a eye distance (0: none)
uniform int search_linear_steps; // uniform steps along the ray
uniform int search_refine_steps; // binary or secant steps inside the first crossing
uniform float search_distance;   // how far along the ray to search (scene units)

// Signed gap at t: ray point's eye distance minus the stored one (> 0: behind the surface); false off-screen/empty.
bool search_gap(vec3 o, vec3 d, float t, out float gap, out vec4 s) {
    vec3 q = o + t * d;
    vec4 clip = camera_clip_from_world * vec4(q, 1.0);
    s = vec4(0.0);
    gap = 0.0;
    if (clip.w <= 1e-8) return false;
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) return false;
    s = texelFetch(nearby_view, ivec2(uv * vec2(textureSize(nearby_view, 0))), 0);
    if (s.a <= 0.0) return false;
    gap = length(q - camera_position) - s.a;
    return true;
}

vec3 nearby_radiance(vec3 o, vec3 d) {
    d = normalize(d);
    vec3 missed = nearby_miss(d);  // first: see nearby_miss
    float step_length = search_distance / float(max(search_linear_steps, 1));
    float t_prev = 0.0, gap_prev = -1.0;
    float t_hit = -1.0, gap_hit = 0.0;
    vec4 s;
    for (int i = 1; i <= search_linear_steps; ++i) {
        float t = float(i) * step_length, gap;
        bool valid = search_gap(o, d, t, gap, s);
        // A crossing: in front at the previous step, behind now by less than a step (not a jump behind an edge).
        if (valid && gap >= 0.0 && gap_prev < 0.0 && gap < 2.0 * step_length) { t_hit = t; gap_hit = gap; break; }
        if (valid) gap_prev = gap; else gap_prev = -1.0;
        t_prev = t;
    }
    if (t_hit < 0.0) return missed;
#if NEARBY == NEARBY_SEARCH_BINARY
    float a = t_prev, b = t_hit;
    for (int i = 0; i < search_refine_steps; ++i) {
        float m = 0.5 * (a + b), gap;
        vec4 sm;
        if (search_gap(o, d, m, gap, sm) && gap >= 0.0) b = m; else a = m;
    }
    t_hit = b;
#elif NEARBY == NEARBY_SEARCH_SECANT
    float a = t_prev, b = t_hit, fa = gap_prev, fb = gap_hit;
    for (int i = 0; i < search_refine_steps; ++i) {
        if (abs(fb - fa) < 1e-12) break;
        float m = clamp(b - fb * (b - a) / (fb - fa), min(a, b), max(a, b)), gap;
        vec4 sm;
        if (!search_gap(o, d, m, gap, sm)) break;
        if (gap >= 0.0) { b = m; fb = gap; } else { a = m; fa = gap; }
    }
    t_hit = b;
#endif
    float gap;
    search_gap(o, d, t_hit, gap, s);
    nearby_hit = vec4(o + t_hit * d, 1.0);
    return s.rgb;
}

#else
vec3 nearby_radiance(vec3 o, vec3 d) { return nearby_miss(d); }
#endif

// nearby_radiance, reusing the previous answer for the same ray (RGB channels that share a path).
vec3 cached_origin = vec3(1e30), cached_direction = vec3(0.0), cached_radiance = vec3(0.0);
vec4 cached_hit = vec4(0.0);
vec3 cached_uvk = vec3(0.0);
vec3 nearby_cached(vec3 o, vec3 d) {
    if (o == cached_origin && d == cached_direction) {
        nearby_hit = cached_hit;
        nearby_uvk = cached_uvk;
        return cached_radiance;
    }
    cached_radiance = nearby_radiance(o, d);
    cached_origin = o;
    cached_direction = d;
    cached_hit = nearby_hit;
    cached_uvk = nearby_uvk;
    return cached_radiance;
}

// The reflection at the entry surface: nearby geometry, none in the photon buffer (refraction photons only).
vec3 nearby_reflection(vec3 o, vec3 d) {
#if PHOTON_BUFFER
    return vec3(0.0);
#elif NEARBY == NEARBY_IMPOSTORS && !IMPOSTOR_REFLECTIONS
    return environment_radiance(environment, d);  // the entry reflection sees the environment only
#else
    vec3 radiance = nearby_radiance(o, d);
    nearby_hit = vec4(0.0);
    nearby_uvk = vec3(0.0);
    return radiance;
#endif
}

// What location 1 holds for a pixel whose last nearby ray ended in nearby_hit (NEARBY_OUTPUT), or `exit`.
vec4 nearby_output(vec4 exit) {
#if NEARBY_OUTPUT == 1
    return nearby_hit;
#elif NEARBY_OUTPUT == 2
    return vec4(nearby_uvk, nearby_hit.w);
#else
    return exit;
#endif
}

// Mirrors (surface_main.glsl looks up the reflected ray): the same search from the surface point,
// its record written to location 1 directly (main has already cleared it).
vec3 nearby_mirror_radiance(vec3 d) {
    vec3 radiance = nearby_radiance(world_position, d);
    exit_direction = nearby_output(exit_direction);
    return radiance;
}
