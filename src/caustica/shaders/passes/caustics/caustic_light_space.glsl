// Light-space views shared by the caustic passes (caustica/passes/caustics/light_views.py, LightView.bind).
// A view is a projective map (perspective or orthographic) or a six-face cube atlas (6N x N, faces in
// the order of CUBE_FORWARD / CUBE_UP). View v has view_kind[v] (0 projective, 1 cube), view_ortho[v],
// view_clip[6 v + face] (clip_from_world), view_forward[6 v + face], view_unit_area[v] (texel area on the
// image plane at unit distance; the absolute texel area for orthographic views) and view_size[v] (N).
// The light: ls_light_type (LIGHT_POINT, _DIRECTIONAL or _SPOT), position, direction, intensity, cone cosines.
// Host defines: VIEW_COUNT (1); LIGHT_POINT, _DIRECTIONAL, _SPOT (scene/codes.py; the shader library sets
// them in every program).
#ifndef VIEW_COUNT
#define VIEW_COUNT 1
#endif
#define VIEW_PROJECTIVE 0
#define VIEW_CUBE 1
#include "passes/caustics/texel_solid_angle.glsl"

uniform int view_kind[VIEW_COUNT];
uniform int view_ortho[VIEW_COUNT];
uniform mat4 view_clip[6 * VIEW_COUNT];
uniform vec3 view_forward[6 * VIEW_COUNT];
uniform float view_unit_area[VIEW_COUNT];
uniform int view_size[VIEW_COUNT];

uniform int ls_light_type;
uniform vec3 ls_light_position;
uniform vec3 ls_light_direction;
uniform vec3 ls_light_intensity;
uniform vec2 ls_light_cone;
// The casters' bounding radius (passes/caustics/casters.py, length_unit): the photon passes' offsets and
// tolerances scale with it, so a scene in millimetres or kilometres makes the same caustics.
uniform float length_unit;

// Direction light travels from the light to p.
vec3 light_ray(vec3 p) {
    return ls_light_type == LIGHT_DIRECTIONAL ? ls_light_direction : normalize(p - ls_light_position);
}

// Distance of p from the light as every map stores it (along the direction for directional lights).
float light_distance(vec3 p) {
    return ls_light_type == LIGHT_DIRECTIONAL ? dot(p - ls_light_position, ls_light_direction)
                                              : length(p - ls_light_position);
}

// Spot cone falloff of the light travelling along `ray` (1 for other lights), as lighting.glsl.
float light_falloff(vec3 ray) {
    if (ls_light_type != LIGHT_SPOT) return 1.0;
    float c = dot(ray, ls_light_direction);
    float t = clamp((c - ls_light_cone.y) / max(ls_light_cone.x - ls_light_cone.y, 1e-9), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

int view_face(int v, vec3 p) {
    if (view_kind[v] != VIEW_CUBE) return 0;
    vec3 d = p - ls_light_position, a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0 : 1;
    if (a.y >= a.z) return d.y > 0.0 ? 2 : 3;
    return d.z > 0.0 ? 4 : 5;
}

// Continuous atlas pixel coordinates of p in view v (texel i covers [i, i + 1]), its face, and
// whether p projects inside the face.
vec2 view_pixel(int v, vec3 p, out int face, out bool inside) {
    face = view_face(v, p);
    vec4 clip = view_clip[6 * v + face] * vec4(p, 1.0);
    vec2 ndc = clip.xy / max(clip.w, 1e-30);
    inside = clip.w > 0.0 && all(lessThanEqual(abs(ndc), vec2(1.0)));
    float n = float(view_size[v]);
    return vec2((float(face) + ndc.x * 0.5 + 0.5) * n, (ndc.y * 0.5 + 0.5) * n);
}

// Measure of the light-space texel that sees p: its solid angle (perspective and cube views,
// texel_solid_angle) or its area perpendicular to the light (orthographic views).
float texel_measure(int v, int face, vec3 p) {
    if (view_ortho[v] != 0) return view_unit_area[v];
    float c = max(dot(light_ray(p), view_forward[6 * v + face]), 1e-6);
    return texel_solid_angle(view_unit_area[v], c);
}

// A surface texture of view v at continuous pixel x in `face` (rgba: world xyz, light distance; a = 0
// empty): bilinear where the four texels hold one smooth surface (distances within 2 percent),
// the nearest texel otherwise.
vec4 fetch_surface(sampler2D tex, int v, int face, vec2 x) {
    int n = view_size[v];
    ivec2 lo = ivec2(face * n, 0), hi = ivec2(face * n + n - 1, n - 1);
    vec2 y = x - 0.5, base = floor(y), f = y - base;
    ivec2 b = ivec2(base);
    vec4 s00 = texelFetch(tex, clamp(b, lo, hi), 0);
    vec4 s10 = texelFetch(tex, clamp(b + ivec2(1, 0), lo, hi), 0);
    vec4 s01 = texelFetch(tex, clamp(b + ivec2(0, 1), lo, hi), 0);
    vec4 s11 = texelFetch(tex, clamp(b + ivec2(1, 1), lo, hi), 0);
    float dmin = min(min(s00.a, s10.a), min(s01.a, s11.a)), dmax = max(max(s00.a, s10.a), max(s01.a, s11.a));
    if (dmin > 0.0 && dmax - dmin < 0.02 * dmax)
        return mix(mix(s00, s10, f.x), mix(s01, s11, f.x), f.y);
    return texelFetch(tex, clamp(ivec2(floor(x)), lo, hi), 0);
}

// The surface of view v seen through p (a = 0: none, or p outside the view).
vec4 surface_through(sampler2D tex, int v, vec3 p) {
    int face;
    bool inside;
    vec2 x = view_pixel(v, p, face, inside);
    return inside ? fetch_surface(tex, v, face, x) : vec4(0.0);
}

// Shah et al. III-C/D: distance d along the ray o + d r to the surface that view v's position
// texture holds. estimator 0 ("iterate", the paper's approximate Newton-Raphson): d <- |S(o + d r) - o|.
// estimator 1 ("newton", the appendix): Newton-Raphson on f(d) = light_distance(x) - S(x).a with a
// finite-difference derivative; a bracket [lo, hi] of the root is kept, and a step that leaves it or
// oscillates (returns to the estimate before last), or misses the texture, is replaced by bisection.
// Returns -1 when the iterate estimator looks up an empty texel.
float estimate_distance(sampler2D tex, int v, vec3 o, vec3 r, float d, int iterations, int estimator) {
    float lo = 0.0, hi = 1e30, before = -1.0;
    for (int k = 0; k < iterations; ++k) {
        vec3 x = o + d * r;
        vec4 s = surface_through(tex, v, x);
        if (s.a <= 0.0 && estimator == 0) return -1.0;
        if (s.a <= 0.0) {  // off the texture: treat as past the root and bisect towards the origin
            hi = min(hi, d);
            before = d;
            d = 0.5 * (lo + hi);
            continue;
        }
        float next;
        if (estimator == 0) {
            next = length(s.xyz - o);
        } else {
            float f = light_distance(x) - s.a;
            if (f < 0.0) lo = max(lo, d); else hi = min(hi, d);
            float h = 1e-3 * (length_unit + d);
            vec4 s2 = surface_through(tex, v, x + h * r);
            float slope = s2.a > 0.0 ? (light_distance(x + h * r) - s2.a - f) / h : 0.0;
            next = abs(slope) > 1e-6 ? d - f / slope : length(s.xyz - o);
            if (abs(next - d) < 1e-6 * (length_unit + d)) break;  // converged
            bool outside = next < lo || next > hi;
            bool oscillating = before >= 0.0 && abs(next - before) < 1e-4 * (length_unit + d) && abs(next - d) > 1e-4 * (length_unit + d);
            if ((outside || oscillating) && hi < 1e30) next = 0.5 * (lo + hi);
            else if (outside) next = length(s.xyz - o);
        }
        before = d;
        d = max(next, 0.0);
    }
    return d;
}

// Where a photon leaving o along r lands on the surface of view v's position texture `tex` (w = 1; w = 0:
// lost): estimate_distance from the first guess d0, or where d0 <= 0 from the distance to the surface seen
// through o (`fallback` where none); the hit must lie ahead of o.
vec4 land_photon(sampler2D tex, int v, vec3 o, vec3 r, float d0, float fallback, int iterations, int estimator) {
    if (d0 <= 0.0) {
        vec4 s = surface_through(tex, v, o);
        d0 = s.a > 0.0 ? max(length(s.xyz - o), 1e-4 * length_unit) : fallback;
    }
    float d = estimate_distance(tex, v, o, r, d0, iterations, estimator);
    if (d < 0.0) return vec4(0.0);
    vec4 hit = surface_through(tex, v, o + d * r);
    if (hit.a <= 0.0 || dot(hit.xyz - o, r) <= 0.0) return vec4(0.0);
    return vec4(hit.xyz, 1.0);
}

// Gaussian splat kernel over texel centres within `radius` texels of the photon at pixel c
// (sigma = radius / 2), normalised so one photon deposits exactly its flux.
float splat_kernel(vec2 c, vec2 texel_centre, float radius) {
    vec2 d = texel_centre - c;
    float r2 = dot(d, d);
    return r2 < radius * radius ? exp(-2.0 * r2 / (radius * radius)) : 0.0;
}

float splat_normaliser(vec2 c, float radius) {
    int k = int(ceil(radius)) + 1;
    vec2 centre = floor(c) + 0.5;
    float sum = 0.0;
    for (int j = -k; j <= k; ++j)
        for (int i = -k; i <= k; ++i) sum += splat_kernel(c, centre + vec2(i, j), radius);
    return sum > 0.0 ? 1.0 / sum : 0.0;
}
