// Caustic mapping photon pass (Shah et al. III-C, figs. 3-4): one photon per texel of the casters'
// light-space grid (view 0). The photon carries the light's flux through its texel (intensity times
// solid angle, or irradiance times area), refracts at the front surface (exact Fresnel per channel),
// leaves through the back surface found from the back buffer (Wyman: d_V, refined by the same
// estimator against the back-face texture; N2 from the back buffer), or reflects off a mirror, and
// lands where the intersection estimate against the receivers' position texture (view 1) puts it.
// The first guess of the estimate is the distance to the receiver behind the origin (Shah et al. use
// d = 1), or, in a second pass, to where the first pass landed the photon.
// Host defines: VIEW_COUNT (2), MAX_CASTERS (32), CASTER_NONE, _MIRROR, _SOLID, _SURFACE (scene/codes.py, in every program).
#version 430 core
#ifndef MAX_CASTERS
#define MAX_CASTERS 32
#endif
#include "common/optics.glsl"
#include "passes/caustic_light_space.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

struct Photon { vec4 position; vec4 flux; };  // position.w = 1 where the photon landed
layout(std430, binding = 0) writeonly buffer Photons { Photon photons[]; };
// Landing points of a first pass against coarser receivers (same layout): the first guess here.
layout(std430, binding = 1) readonly buffer Initial { Photon initial[]; };
uniform int has_initial;

uniform sampler2D front_position;  // view 0, nearest front faces of every object
uniform sampler2D front_normal;    // w: caster index + 1 (0: not a caster)
uniform sampler2D back_position;   // view 0, farthest back faces of the refractors
uniform sampler2D back_normal;
uniform sampler2D receiver_position;  // view 1, diffuse receivers
uniform int caster_type[MAX_CASTERS];
uniform vec3 caster_ior[MAX_CASTERS];
uniform vec3 caster_sigma[MAX_CASTERS];  // Beer-Lambert absorption coefficient
uniform vec3 caster_color[MAX_CASTERS];  // mirror reflectance
uniform int channel_count;  // 3: one photon per RGB channel (dispersion), 1: one RGB photon
uniform int iterations;
uniform int exit_iterations;
uniform int estimator;
uniform float fallback_distance;  // initial guess where no receiver lies behind the photon's origin

// Land a photon leaving o along r on the receivers; returns the landing point (w = 0: lost).
vec4 land(vec3 o, vec3 r, int index) {
    float d0 = has_initial != 0 && initial[index].position.w > 0.0 ? max(dot(initial[index].position.xyz - o, r), 1e-4 * length_unit)
                                                                    : 0.0;
    return land_photon(receiver_position, 1, o, r, d0, fallback_distance, iterations, estimator);
}

// Signed distance of p past the back faces along the light (a miss, outside the silhouette, counts as past).
float past_back(vec3 p, out bool miss) {
    vec4 s = surface_through(back_position, 0, p);
    miss = s.a <= 0.0;
    return miss ? 1.0 : light_distance(p) - s.a;
}

// Wyman's exit distance d_V, refined against the back faces: f(d) = past_back(P1 + d T1) is negative
// inside; grow d from d_V until f >= 0, then exit_iterations regula falsi steps (Illinois) on the
// bracket, bisection where an end misses the silhouette.
float exit_distance(vec3 p1, vec3 t1, float f0, float dv) {
    float lo = 0.0, flo = min(f0, -1e-7), hi = max(dv, 1e-3 * (length_unit + length(p1 - ls_light_position)));
    bool miss_hi;
    float fhi = past_back(p1 + hi * t1, miss_hi);
    for (int i = 0; i < 16 && fhi < 0.0; ++i) {
        lo = hi;
        flo = fhi;
        hi *= 2.0;
        fhi = past_back(p1 + hi * t1, miss_hi);
    }
    if (fhi < 0.0) return dv;
    int side = 0;
    for (int k = 0; k < exit_iterations; ++k) {
        float m = miss_hi ? 0.5 * (lo + hi) : lo - flo * (hi - lo) / (fhi - flo);
        bool miss_m;
        float fm = past_back(p1 + m * t1, miss_m);
        if (fm < 0.0) {
            lo = m;
            flo = fm;
            if (side == -1 && !miss_hi) fhi *= 0.5;
            side = -1;
        } else {
            hi = m;
            fhi = fm;
            miss_hi = miss_m;
            if (side == 1) flo *= 0.5;
            side = 1;
        }
    }
    return miss_hi ? lo : lo - flo * (hi - lo) / (fhi - flo);
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    int n = view_size[0];
    int faces = view_kind[0] == VIEW_CUBE ? 6 : 1;
    if (t.x >= faces * n || t.y >= n) return;
    int first = (t.y * faces * n + t.x) * channel_count;
    for (int c = 0; c < channel_count; ++c) photons[first + c] = Photon(vec4(0.0), vec4(0.0));

    // The caster surface this texel sees, and the flux through the texel.
    vec4 front = texelFetch(front_position, t, 0);
    vec4 fn = texelFetch(front_normal, t, 0);
    int id = int(fn.w + 0.5) - 1;
    if (front.a <= 0.0 || id < 0 || id >= MAX_CASTERS || caster_type[id] == CASTER_NONE) return;
    vec3 p1 = front.xyz;
    vec3 l = light_ray(p1);
    int face = t.x / n;
    vec3 flux = ls_light_intensity * texel_measure(0, face, p1) * light_falloff(l);
    vec3 n1 = normalize(fn.xyz);
    if (dot(n1, l) > 0.0) n1 = -n1;  // face the light (open meshes seen from below)

    // Mirror: a single specular bounce.
    if (caster_type[id] == CASTER_MIRROR) {
        vec4 hit = land(p1 + 1e-4 * length_unit * n1, reflect(l, n1), first);
        if (hit.w > 0.0) photons[first] = Photon(hit, vec4(flux * caster_color[id], 0.0));
        return;
    }

    // Glass: one photon per channel (dispersion) or one for all three.
    for (int c = 0; c < channel_count; ++c) {
        vec3 mask = channel_count == 1 ? vec3(1.0) : vec3(c == 0, c == 1, c == 2);
        float eta = caster_ior[id][c];
        vec3 t1 = refract(l, n1, 1.0 / eta);
        if (dot(t1, t1) == 0.0) continue;  // total reflection at entry (IOR < 1)
        vec3 transmit = vec3(1.0 - fresnel_dielectric(dot(-l, n1), 1.0, eta));
        vec3 o = p1, r = t1;
        float inside = 0.0;
        if (caster_type[id] == CASTER_SOLID) {
            // Exit point: P2 = P1 + d T1, d from d_V refined against the back faces; N2 from the back buffer.
            vec4 back = texelFetch(back_position, t, 0);
            if (back.a <= 0.0) continue;
            float dv = max(back.a - front.a, 0.0);
            float d = exit_iterations > 0 ? exit_distance(p1, t1, front.a - back.a, dv) : dv;
            vec3 p2 = p1 + d * t1;
            int f2;
            bool in2;
            vec2 x2 = view_pixel(0, p2, f2, in2);
            vec3 n2 = in2 ? fetch_surface(back_normal, 0, f2, x2).xyz : vec3(0.0);
            if (dot(n2, n2) < 1e-12) n2 = texelFetch(back_normal, t, 0).xyz;
            n2 = normalize(n2);
            if (dot(n2, t1) < 0.0) n2 = -n2;  // outward, along the leaving ray
            vec3 t2 = refract(t1, -n2, eta);
            if (dot(t2, t2) == 0.0) continue;  // total internal reflection at the exit: dropped
            transmit *= 1.0 - fresnel_dielectric(dot(t1, n2), eta, 1.0);
            inside = d;
            o = p2 + 1e-4 * length_unit * n2;
            r = t2;
        } else {
            o = p1 - 1e-4 * length_unit * n1;
        }
        vec4 hit = land(o, r, first + c);
        if (hit.w <= 0.0) continue;
        // Beer-Lambert: through the solid, or from a single surface (water) down to the receiver.
        if (caster_type[id] == CASTER_SURFACE) inside = length(hit.xyz - o);
        vec3 absorbed = exp(-caster_sigma[id] * inside);
        photons[first + c] = Photon(hit, vec4(flux * transmit * absorbed * mask, 0.0));
    }
}
