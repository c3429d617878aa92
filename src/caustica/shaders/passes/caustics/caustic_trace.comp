// Caustic mapping photon pass (Shah et al. III-C, figs. 3-4): one photon per texel of the casters'
// light-space grid (view 0). The photon carries the light's flux through its texel (intensity times
// solid angle, or irradiance times area), refracts at the front surface (exact Fresnel per channel),
// leaves through the back surface found from the back buffer (Wyman's d_V, the back faces' distance
// from the light less the front's, grown until past the back faces and refined by exit_iterations
// regula falsi steps (Illinois) against the back-face texture; N2 from the back buffer), or reflects
// off a mirror, and lands where the intersection estimate against the receivers' position texture
// (view 1) puts it.
// The first guess of the estimate is the distance to the receiver behind the origin (Shah et al. use
// d = 1), or, in a second pass, to where the first pass landed the photon.
// ADAPTIVE 1 (Wyman and Nichols 2009, adaptive caustic maps; techniques/caustic_mapping.py, AdaptivePhotons):
// one photon per cell of refinement level `level`, a cell covering block x block caster texels; the photon
// starts at the block's centre texel and carries the flux of every texel of the block that sees the same
// caster (so four children carry their parent's flux). Cells are traced where their parent (binding 2,
// level - 1) was refined, or where a 4-neighbour's was (helpers: landing points for the footprints and the
// refinement test, not splatted); a second landing of a level (has_initial) copies the first's states.
// flux.w holds the cell's state: STATE_LIVE (splatted), STATE_HELPER,
// STATE_REFINED (children traced next level) or STATE_UNTRACED; a cell on a caster's rim (some texels of
// its block see no caster or another) or whose photon was lost is refined below last_level.
// Host defines: VIEW_COUNT (2), MAX_CASTERS (32), ADAPTIVE (0), CASTER_NONE, _MIRROR, _SOLID, _SURFACE
// (scene/codes.py, in every program).
#version 430 core
#ifndef MAX_CASTERS
#define MAX_CASTERS 32
#endif
#ifndef ADAPTIVE
#define ADAPTIVE 0
#endif
#include "common/optics.glsl"
#include "common/glass_contact.glsl"
#include "passes/caustics/caustic_light_space.glsl"
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
uniform int exit_reflections[MAX_CASTERS];  // total internal reflections a photon may take inside the caster
uniform vec4 contact_plane[MAX_CASTERS];  // the receiver the caster stands on: unit normal n (0: none), n . x = w on it
uniform float contact_tolerance[MAX_CASTERS];  // how far off that plane an exit still lies on it (passes/shading/glass_contact.py)
uniform int second_layer;  // 1: photons leaving through the nearest back faces may enter the glass again
uniform sampler2D second_position;  // view 0: the glass's front faces behind its nearest back faces
uniform sampler2D second_normal;
uniform sampler2D far_position;  // view 0: the glass's farthest back faces
uniform sampler2D far_normal;
uniform int estimator;
uniform float fallback_distance;  // initial guess where no receiver lies behind the photon's origin
#if ADAPTIVE
#include "passes/post/adaptive_states.glsl"
layout(std430, binding = 2) readonly buffer Parent { Photon parent[]; };  // level - 1 (unread at level 0)
uniform int level;       // 0: the coarsest
uniform int last_level;  // no refinement at the last
uniform int block;       // caster texels a side of one cell
#endif

// Land a photon leaving o along r on the receivers; returns the landing point (w = 0: lost).
vec4 land(vec3 o, vec3 r, int index) {
    float d0 = has_initial != 0 && initial[index].position.w > 0.0 ? max(dot(initial[index].position.xyz - o, r), 1e-4 * length_unit)
                                                                    : 0.0;
    return land_photon(receiver_position, 1, o, r, d0, fallback_distance, iterations, estimator);
}

// Signed distance of p past the back faces `tex` along the light (a miss, outside the silhouette, counts as past).
float past_back(sampler2D tex, vec3 p, out bool miss) {
    vec4 s = surface_through(tex, 0, p);
    miss = s.a <= 0.0;
    return miss ? 1.0 : light_distance(p) - s.a;
}

// Wyman's exit distance d_V, refined against the back faces `tex`: f(d) = past_back(P1 + d T1) is negative
// inside; grow d from d_V until f >= 0, then exit_iterations regula falsi steps (Illinois) on the
// bracket, bisection where an end misses the silhouette.
float exit_distance(sampler2D tex, vec3 p1, vec3 t1, float f0, float dv) {
    float lo = 0.0, flo = min(f0, -1e-7), hi = max(dv, 1e-3 * (length_unit + length(p1 - ls_light_position)));
    bool miss_hi;
    float fhi = past_back(tex, p1 + hi * t1, miss_hi);
    for (int i = 0; i < 16 && fhi < 0.0; ++i) {
        lo = hi;
        flo = fhi;
        hi *= 2.0;
        fhi = past_back(tex, p1 + hi * t1, miss_hi);
    }
    if (fhi < 0.0) return dv;
    int side = 0;
    for (int k = 0; k < exit_iterations; ++k) {
        float m = miss_hi ? 0.5 * (lo + hi) : lo - flo * (hi - lo) / (fhi - flo);
        bool miss_m;
        float fm = past_back(tex, p1 + m * t1, miss_m);
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

// Where a photon leaving the glass at p2 along t2 meets its second layer again (the front faces behind
// the nearest back faces): the distance along t2, or -1 where it does not (it leaves the far back faces'
// depth, or the view, first). March SECOND_STEPS steps up to the far back faces' depth at p2, then bisect.
#define SECOND_STEPS 16
float second_entry(vec3 p2, vec3 t2) {
    vec4 far = surface_through(far_position, 0, p2);
    float reach = far.a - light_distance(p2);
    if (far.a <= 0.0 || reach <= 0.0) return -1.0;
    float span = 2.0 * reach, lo = 0.0;
    for (int k = 1; k <= SECOND_STEPS; ++k) {
        float d = span * float(k) / float(SECOND_STEPS);
        vec3 q = p2 + d * t2;
        vec4 s = surface_through(second_position, 0, q);
        if (s.a > 0.0 && light_distance(q) >= s.a) {
            float hi = d;
            for (int i = 0; i < 10; ++i) {  // bisection on the crossing
                float m = 0.5 * (lo + hi);
                vec3 x = p2 + m * t2;
                vec4 sm = surface_through(second_position, 0, x);
                if (sm.a > 0.0 && light_distance(x) >= sm.a) hi = m; else lo = m;
            }
            return hi;
        }
        lo = d;
    }
    return -1.0;
}

// The outward normal of the surface `tex` holds where p projects (that of texel s where p falls outside).
vec3 surface_normal(sampler2D tex, vec3 p, ivec2 s) {
    int f;
    bool in_view;
    vec2 x = view_pixel(0, p, f, in_view);
    vec3 n = in_view ? fetch_surface(tex, 0, f, x).xyz : vec3(0.0);
    if (dot(n, n) < 1e-12) n = texelFetch(tex, s, 0).xyz;
    return normalize(n);
}

// How far p (inside the glass) lies outside it along the light: positive nearer the light than the front
// faces or past the back faces (or off the glass's silhouette), negative between them; `back_side` tells
// which layer is the nearer to crossing.
float outside_glass(vec3 p, out bool back_side) {
    vec4 front = surface_through(front_position, 0, p);
    vec4 back = surface_through(back_position, 0, p);
    if (front.a <= 0.0 || back.a <= 0.0) {
        back_side = true;
        return length_unit;
    }
    float ld = light_distance(p), before = front.a - ld, past = ld - back.a;
    back_side = past >= before;
    return max(before, past);
}

// Where a photon inside the glass at p along r leaves it after an internal reflection (our extension, as
// depth-search's internal bounces from the eye): the distance along r to the crossing of the front or back
// faces seen from the light, found by INTERNAL_STEPS steps over the casters' diameter and a bisection, with
// n the outward normal there; -1 where it does not leave within that reach.
#define INTERNAL_STEPS 32
float internal_exit(vec3 p, vec3 r, ivec2 s, out vec3 n) {
    float span = 2.0 * length_unit, lo = 0.0;
    bool back_side, side;
    for (int k = 1; k <= INTERNAL_STEPS; ++k) {
        float d = span * float(k) / float(INTERNAL_STEPS);
        if (outside_glass(p + d * r, back_side) < 0.0) {
            lo = d;
            continue;
        }
        float hi = d;  // outside: back_side is the layer crossed before hi
        for (int i = 0; i < 12; ++i) {  // bisection on the crossing
            float m = 0.5 * (lo + hi);
            if (outside_glass(p + m * r, side) < 0.0) {
                lo = m;
            } else {
                hi = m;
                back_side = side;
            }
        }
        n = back_side ? surface_normal(back_normal, p + hi * r, s) : surface_normal(front_normal, p + hi * r, s);
        if (dot(n, r) < 0.0) n = -n;  // outward, along the leaving ray
        return hi;
    }
    return -1.0;
}

// Whether caster id's exit p2 through the face of outward normal n2 lies on the receiver it stands on
// (common/glass_contact.glsl), and `landing`, where all the light reaching that face lands.
bool on_contact(int id, vec3 p2, vec3 n2, out vec3 landing) {
    return on_contact_plane(contact_plane[id], contact_tolerance[id], p2, n2, landing);
}

// Whether the 3 x 3 texels around s see caster id: s lies inside its silhouette from the light, not on
// the rim (where the front- and back-face rasterizations may differ by a texel).
bool inside_silhouette(ivec2 s, int id) {
    ivec2 size = textureSize(front_normal, 0);
    for (int j = -1; j <= 1; ++j) {
        for (int i = -1; i <= 1; ++i) {
            ivec2 q = s + ivec2(i, j);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) return false;
            if (int(texelFetch(front_normal, q, 0).w + 0.5) - 1 != id) return false;
        }
    }
    return true;
}

// Trace the photons of caster texel s (its caster id, front point p1, normal fn) carrying `flux` into
// photons[first ..]; true where one landed.
bool trace_texel(ivec2 s, int id, vec4 front, vec3 fn, vec3 flux, int first) {
    vec3 p1 = front.xyz;
    vec3 l = light_ray(p1);
    vec3 n1 = normalize(fn);
    if (dot(n1, l) > 0.0) n1 = -n1;  // face the light (open meshes seen from below)

    // Mirror: a single specular bounce.
    if (caster_type[id] == CASTER_MIRROR) {
        vec4 hit = land(p1 + 1e-4 * length_unit * n1, reflect(l, n1), first);
        if (hit.w > 0.0) photons[first] = Photon(hit, vec4(flux * caster_color[id], 0.0));
        return hit.w > 0.0;
    }

    // Glass: one photon per channel (dispersion) or one for all three.
    bool landed = false;
    for (int c = 0; c < channel_count; ++c) {
        vec3 mask = channel_count == 1 ? vec3(1.0) : vec3(c == 0, c == 1, c == 2);
        float eta = caster_ior[id][c];
        vec3 t1 = refract(l, n1, 1.0 / eta);
        if (dot(t1, t1) == 0.0) continue;  // total reflection at entry (IOR < 1)
        vec3 transmit = vec3(1.0 - fresnel_dielectric(dot(-l, n1), 1.0, eta));
        vec3 o = p1, r = t1;
        float inside = 0.0;
        // A solid's opening (a scanned mesh's hole): inside the silhouette, no back face behind the front
        // face along the light. The light leaves through it as through a single surface.
        vec4 back = texelFetch(back_position, s, 0);
        bool opening = caster_type[id] == CASTER_SOLID && back.a <= 0.0;
        if (opening && !inside_silhouette(s, id)) continue;  // the rim: a back face the rasterizer missed
        if (caster_type[id] == CASTER_SOLID && !opening) {
            // Exit point: P2 = P1 + d T1, d from d_V refined against the back faces; N2 from the back buffer.
            float dv = max(back.a - front.a, 0.0);
            float d = exit_iterations > 0 ? exit_distance(back_position, p1, t1, front.a - back.a, dv) : dv;
            vec3 p2 = p1 + d * t1;
            int f2;
            bool in2;
            vec2 x2 = view_pixel(0, p2, f2, in2);
            vec3 n2 = in2 ? fetch_surface(back_normal, 0, f2, x2).xyz : vec3(0.0);
            if (dot(n2, n2) < 1e-12) n2 = texelFetch(back_normal, s, 0).xyz;
            n2 = normalize(n2);
            if (dot(n2, t1) < 0.0) n2 = -n2;  // outward, along the leaving ray
            vec3 t2 = refract(t1, -n2, eta);
            inside = d;
            // A face on the receiver the glass stands on passes all the light to it: it lands at the exit.
            vec3 landing;
            bool contact = on_contact(id, p2, n2, landing);
            // Total internal reflection at the exit: reflect inside and leave further on, up to
            // exit_reflections times (0: the photon is dropped).
            for (int b = 0; b < exit_reflections[id] && !contact && dot(t2, t2) == 0.0; ++b) {
                t1 = reflect(t1, n2);
                float run = internal_exit(p2 - 1e-4 * length_unit * n2, t1, s, n2);
                if (run < 0.0) break;
                p2 += run * t1;
                inside += run;
                t2 = refract(t1, -n2, eta);
                contact = on_contact(id, p2, n2, landing);
            }
            if (contact) {
                photons[first + c] = Photon(vec4(landing, 1.0),
                                            vec4(flux * transmit * exp(-caster_sigma[id] * inside) * mask, 0.0));
                landed = true;
                continue;
            }
            if (dot(t2, t2) == 0.0) continue;  // total internal reflection at the exit: dropped
            transmit *= 1.0 - fresnel_dielectric(dot(t1, n2), eta, 1.0);
            o = p2 + 1e-4 * length_unit * n2;
            r = t2;
            // The second layer: in through its front faces, out through the farthest back faces.
            float gap = second_layer != 0 ? second_entry(o, t2) : -1.0;
            if (gap > 0.0) {
                vec3 p3 = o + gap * t2;
                vec3 n3 = surface_normal(second_normal, p3, s);
                if (dot(n3, t2) > 0.0) n3 = -n3;  // against the arriving ray
                vec3 t3 = refract(t2, n3, 1.0 / eta);
                if (dot(t3, t3) == 0.0) continue;
                transmit *= 1.0 - fresnel_dielectric(dot(-t2, n3), 1.0, eta);
                vec4 far3 = surface_through(far_position, 0, p3);
                float dv3 = max(far3.a - light_distance(p3), 0.0);
                float d3 = exit_distance(far_position, p3, t3, -max(dv3, 1e-7), dv3);
                vec3 p4 = p3 + d3 * t3;
                vec3 n4 = surface_normal(far_normal, p4, s);
                if (dot(n4, t3) < 0.0) n4 = -n4;  // outward, along the leaving ray
                vec3 t4 = refract(t3, -n4, eta);
                if (dot(t4, t4) == 0.0) continue;  // total internal reflection: dropped
                transmit *= 1.0 - fresnel_dielectric(dot(t3, n4), eta, 1.0);
                inside += d3;
                o = p4 + 1e-4 * length_unit * n4;
                r = t4;
            }
        } else {
            o = p1 - 1e-4 * length_unit * n1;
        }
        vec4 hit = land(o, r, first + c);
        if (hit.w <= 0.0) continue;
        // Beer-Lambert: through the solid, or from a single surface (water, an opening) down to the receiver.
        if (caster_type[id] == CASTER_SURFACE || opening) inside = length(hit.xyz - o);
        vec3 absorbed = exp(-caster_sigma[id] * inside);
        photons[first + c] = Photon(hit, vec4(flux * transmit * absorbed * mask, 0.0));
        landed = true;
    }
    return landed;
}

// The caster index texel s sees (-1: none).
int caster_at(ivec2 s, out vec4 front, out vec4 fn) {
    front = texelFetch(front_position, s, 0);
    fn = texelFetch(front_normal, s, 0);
    int id = int(fn.w + 0.5) - 1;
    return front.a <= 0.0 || id < 0 || id >= MAX_CASTERS || caster_type[id] == CASTER_NONE ? -1 : id;
}

#if ADAPTIVE
// Whether the parent (level - 1) of cell t, on grid face `face` of `cells` a side, was refined.
bool parent_refined(ivec2 t, int face, int cells) {
    if (t.y < 0 || t.y >= cells || t.x < face * cells || t.x >= face * cells + cells) return false;
    int faces = view_kind[0] == VIEW_CUBE ? 6 : 1;
    ivec2 p = t / 2;
    return parent[(p.y * faces * (cells / 2) + p.x) * channel_count].flux.w == STATE_REFINED;
}

// The flux through the texels of the block from t0 (block x block) that see caster id, on `face`;
// `whole`: every texel sees it; `covered`: some texel sees a caster.
vec3 block_flux(ivec2 t0, int face, int id, out bool whole, out bool covered) {
    float measure = 0.0;
    whole = true;
    covered = false;
    for (int j = 0; j < block; ++j) {
        for (int i = 0; i < block; ++i) {
            vec4 front, fn;
            int k = caster_at(t0 + ivec2(i, j), front, fn);
            covered = covered || k >= 0;
            if (k < 0 || k != id) {
                whole = false;
                continue;
            }
            measure += texel_measure(0, face, front.xyz) * light_falloff(light_ray(front.xyz));
        }
    }
    return ls_light_intensity * measure;
}
#endif

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    int faces = view_kind[0] == VIEW_CUBE ? 6 : 1;
#if ADAPTIVE
    // Cell t of this level: traced where its parent or a 4-neighbour's parent was refined.
    int n = view_size[0] / block;
    if (t.x >= faces * n || t.y >= n) return;
    int face = t.x / n;
    float state = STATE_LIVE;
    if (level > 0 && !parent_refined(t, face, n)) {
        bool ring = parent_refined(t + ivec2(1, 0), face, n) || parent_refined(t - ivec2(1, 0), face, n) ||
                    parent_refined(t + ivec2(0, 1), face, n) || parent_refined(t - ivec2(0, 1), face, n);
        state = ring ? STATE_HELPER : STATE_UNTRACED;
    }
    ivec2 s = t * block + max(block / 2 - 1, 0);  // the first of the block's four central texels
#else
    int n = view_size[0];
    if (t.x >= faces * n || t.y >= n) return;
    int face = t.x / n;
    ivec2 s = t;
#endif
    int first = (t.y * faces * n + t.x) * channel_count;
#if ADAPTIVE
    // A second landing of the level keeps the states the first landing's refinement gave.
    if (has_initial != 0) state = initial[first].flux.w;
#endif
    for (int c = 0; c < channel_count; ++c) photons[first + c] = Photon(vec4(0.0), vec4(0.0));

    // The caster surface this texel sees, and the flux through the texel (the block's caster texels).
    vec4 front, fn;
    int id = caster_at(s, front, fn);
#if ADAPTIVE
    // The photon leaves the block's centre (a texel corner from two texels a side): the mean of the four
    // central texels' surface points and normals where they see one caster.
    if (block > 1 && id >= 0) {
        vec4 sum = front, nsum = vec4(fn.xyz, 0.0);
        bool same = true;
        for (int k = 1; k < 4; ++k) {
            vec4 f, n;
            same = same && caster_at(s + ivec2(k & 1, k >> 1), f, n) == id;
            sum += f;
            nsum.xyz += n.xyz;
        }
        if (same) {
            front = 0.25 * sum;
            fn.xyz = nsum.xyz;
        }
    }
    bool refinable = state == STATE_LIVE && level < last_level && has_initial == 0;
    bool whole = false, covered = false;
    vec3 flux = vec3(0.0);
    if (state != STATE_UNTRACED) flux = block_flux(t * block, face, id, whole, covered);
    bool landed = state != STATE_UNTRACED && id >= 0 && trace_texel(s, id, front, fn.xyz, flux, first);
    // A rim cell, or one whose photon was lost, is refined.
    if (refinable && covered && (!whole || !landed)) state = STATE_REFINED;
    for (int c = 0; c < channel_count; ++c) photons[first + c].flux.w = state;
#else
    if (id < 0) return;
    vec3 flux = ls_light_intensity * texel_measure(0, face, front.xyz) * light_falloff(light_ray(front.xyz));
    trace_texel(s, id, front, fn.xyz, flux, first);
#endif
}
