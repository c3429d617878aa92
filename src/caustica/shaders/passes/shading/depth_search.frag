// depth-search: two-interface refraction without preprocessing (Hu and Qin, TVCG 2007, 2.1 and 4).
// Per glass fragment: T1 at P1; decide whether the exit P2 lies on a front- or back-facing
// surface (binary search along the projected T1 for the silhouette point pe, 2.1.2, or the
// section-4 shortcut: assume back-facing and switch when P2 leaves the silhouette); correct
// dT iteratively against that face's depth buffer (2.1.3); N2 from that face's normal
// texture (2.1.4); T2 = refract(T1, N2) per RGB channel; environment lookup.
// Geometry (P2, N2) follows the green channel's IOR; each channel refracts with its own IOR
// at every interface (dispersion). TIR at the last exit reflects once (at the entry: reflect only).
// Ours, SHARED_BOUNCES: red and blue look up only their first exit, where the channels part most,
// and reuse green's lookups at the bounced exits (weighted by their own Fresnel terms).
// Our extension, not in the paper: INTERNAL_BOUNCES > 0 follows the light reflected inside at
// each exit (weight F) to the next exit, found against the nearer of the two buffers.
// Ours too: CONVEX_EXITS computes every exit exactly where the glass is an analytic sphere or a mesh
// bounded by few planes, balls and cylinders, a lens's (common/convex_exits.glsl; 1: every glass object,
// 2: per object).
//
// Nearby geometry (``nearby``, and the ``impostors`` technique): T2 and the reflections go to
// nearby_radiance of common/impostors.glsl instead of the environment.
// Host defines: ShadeSurfaces' own (MAX_LIGHTS, CAUSTICS, SURFACE_KIND, DISPERSION);
// INTERNAL_BOUNCES (0: the paper's two interfaces), SHARED_BOUNCES (0/1), BACK_SECANT (0/1), BACK_SPHERE_START (0/1),
// CONVEX_EXITS (0/1/2), GLASS_CONTACT (0/1: contact_plane, contact_tolerance), ASSUME_BACK_FIRST (0/1; compile-time, since
// llvmpipe would run both sides of a uniform branch); NEARBY, NEARBY_OUTPUT, PHOTON_BUFFER,
// MAX_IMPOSTORS, MAX_PLANES (common/impostors.glsl; NEARBY 0 keeps the environment). Uniforms set by the technique:
//   search_steps (int), search_start (float, fraction of the buffer size), iterations (int),
//   bounce_iterations (int: the dT corrections at each bounced exit), tolerance (float, scene units: the
//   technique's fraction of the object's size),
//   world_from_clip (mat4).
#version 430 core
#ifndef INTERNAL_BOUNCES
#define INTERNAL_BOUNCES 0  // our extension: internal reflections followed to further exits (0: the paper)
#endif
#ifndef BACK_SECANT
#define BACK_SECANT 1  // ours: back-face dT starts at d_V and takes secant steps (0: 2.1.3's small start, depth steps)
#endif
#ifndef BACK_SPHERE_START
#define BACK_SPHERE_START 1  // ours, with BACK_SECANT: start at the chord along T1 of the sphere fitting d_V (0: at d_V)
#endif
#ifndef CONVEX_EXITS
#define CONVEX_EXITS 0  // ours: exact exits from solids of planes, balls and cylinders (1: every glass object, 2: some; passes/shading/convex_exits.py)
#endif
#ifndef ASSUME_BACK_FIRST
#define ASSUME_BACK_FIRST 1  // section 4: iterate on the back faces first (0: search first, 2.1.2)
#endif
#ifndef SHARED_BOUNCES
#define SHARED_BOUNCES 1  // ours, with DISPERSION: red and blue reuse green's lookups at the bounced exits (0: their own)
#endif
#ifndef GLASS_CONTACT
#define GLASS_CONTACT 0  // ours: exits through a face lying on the receiver the glass stands on land on it (passes/shading/glass_contact.py)
#endif
#include "common/surface_inputs.glsl"
#include "common/impostors.glsl"
#if CONVEX_EXITS
#include "common/convex_exits.glsl"
#endif
#if GLASS_CONTACT && NEARBY != NEARBY_NONE  // departure()'s contact test: searched exits need it as exact ones do
#include "common/glass_contact.glsl"
#endif

uniform sampler2D front_surface;  // nearest front face: outward normal xyz, eye distance w (0: none)
uniform sampler2D back_surface;   // farthest back face: the same
uniform mat4 world_from_clip;
uniform int search_steps;
uniform float search_start;
uniform int iterations;
uniform int bounce_iterations;  // ours: the dT corrections at each bounced exit (INTERNAL_BOUNCES)
uniform float tolerance;
#if GLASS_CONTACT && NEARBY != NEARBY_NONE
uniform vec4 contact_plane;       // the receiver this glass stands on: unit normal n (0: none), n . x = w on it
uniform float contact_tolerance;  // how far off that plane an exit still lies on it (scene units)
#endif

// Buffer pixel (continuous, origin at the lower left) of a world point; false behind the eye.
bool buffer_pixel(vec3 p, out vec2 pixel) {
    vec4 clip = camera_clip_from_world * vec4(p, 1.0);
    if (clip.w <= 1e-8) return false;
    pixel = (clip.xy / clip.w * 0.5 + 0.5) * vec2(textureSize(back_surface, 0));
    return true;
}

// The buffer texel holding a continuous pixel position: its surface, or vec4(0) off-screen.
vec4 surface_at(sampler2D surfaces, vec2 pixel) {
    ivec2 size = textureSize(surfaces, 0);
    ivec2 texel = ivec2(floor(pixel));
    if (any(lessThan(texel, ivec2(0))) || any(greaterThanEqual(texel, size))) return vec4(0.0);
    return texelFetch(surfaces, texel, 0);
}

// The surface at a continuous pixel position, bilinear between the four nearest texels when
// all hold a surface (the nearest texel otherwise): sub-texel P2 and N2. Four fetches at
// clamped texels; texels off the buffer count as empty.
vec4 surface_filtered(sampler2D surfaces, vec2 pixel) {
    ivec2 size = textureSize(surfaces, 0);
    vec2 base = floor(pixel - 0.5);
    vec2 f = pixel - 0.5 - base;
    ivec2 lo = ivec2(base), hi = lo + 1;
    ivec2 clo = clamp(lo, ivec2(0), size - 1), chi = clamp(hi, ivec2(0), size - 1);
    vec4 s00 = texelFetch(surfaces, clo, 0), s10 = texelFetch(surfaces, ivec2(chi.x, clo.y), 0);
    vec4 s01 = texelFetch(surfaces, ivec2(clo.x, chi.y), 0), s11 = texelFetch(surfaces, chi, 0);
    bvec2 lo_in = equal(lo, clo), hi_in = equal(hi, chi);
    s00.w = lo_in.x && lo_in.y ? s00.w : 0.0;
    s10.w = hi_in.x && lo_in.y ? s10.w : 0.0;
    s01.w = lo_in.x && hi_in.y ? s01.w : 0.0;
    s11.w = hi_in.x && hi_in.y ? s11.w : 0.0;
    if (min(min(s00.w, s10.w), min(s01.w, s11.w)) <= 0.0) {
        // Not all four hold a surface: the one with the largest bilinear weight that does, so a
        // point less than a texel off the silhouette still finds the edge (ours; fewer P2 that
        // seem to leave the silhouette). None: empty.
        vec4 weight = vec4((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
        weight = mix(vec4(-1.0), weight, greaterThan(vec4(s00.w, s10.w, s01.w, s11.w), vec4(0.0)));
        float best = max(max(weight.x, weight.y), max(weight.z, weight.w));
        vec4 covered = best == weight.x ? s00 : best == weight.y ? s10 : best == weight.z ? s01 : s11;
        return best >= 0.0 ? covered : vec4(0.0);
    }
    return mix(mix(s00, s10, f.x), mix(s01, s11, f.x), f.y);
}

// World point of a buffer surface: the eye plus eye distance along the pixel's ray.
vec3 surface_point(vec2 pixel, float distance) {
    vec2 ndc = pixel / vec2(textureSize(back_surface, 0)) * 2.0 - 1.0;
    vec4 far = world_from_clip * vec4(ndc, 1.0, 1.0);
    return camera_position + distance * normalize(far.xyz / far.w - camera_position);
}

// 2.1.2: binary search along t1 for the silhouette pixel pe; returns the world point Pe.
// The first test point lies search_start * buffer size away (outside the silhouette), then
// each step halves the stride, moving out from inside points and in from outside points.
bool silhouette_point(vec2 p1, vec2 t1, out vec3 pe) {
    float stride = search_start * float(max(textureSize(front_surface, 0).x, textureSize(front_surface, 0).y));
    float along = stride;
    float inside_along = 0.0;
    vec4 inside_surface = surface_at(front_surface, p1);
    for (int i = 0; i < search_steps; ++i) {
        vec4 s = surface_at(front_surface, p1 + along * t1);
        stride *= 0.5;
        if (s.w > 0.0) {
            if (along > inside_along) { inside_along = along; inside_surface = s; }
            along += stride;
        } else {
            along -= stride;
        }
    }
    if (inside_surface.w <= 0.0) return false;
    pe = surface_point(floor(p1 + inside_along * t1) + 0.5, inside_surface.w);
    return true;
}

// Which buffer correct_distance reads (a constant at each call, so the compiler keeps one side).
const int BACK_LAYER = 0;   // the farthest back faces
const int FRONT_LAYER = 1;  // the nearest front faces
const int NEAREST_LAYER = 2;  // our extension: whichever of the two lies nearer the point's eye distance

// The surface a buffer (or the nearer of the two) holds at a continuous pixel position.
vec4 layer_surface(int layer, vec2 pixel, float depth) {
    if (layer == BACK_LAYER) return surface_filtered(back_surface, pixel);
    vec4 f = surface_filtered(front_surface, pixel);
    if (layer == FRONT_LAYER) return f;
    vec4 b = surface_filtered(back_surface, pixel);
    return f.w > 0.0 && (b.w <= 0.0 || abs(depth - f.w) < abs(depth - b.w)) ? f : b;
}

// 2.1.3: correct dT against a buffer. S (normal N_S) is the surface the buffer holds where
// P1 + dT T1 projects. Back faces: the gap |S - E| - |P1 + dT T1 - E| along the pixel ray is
// driven to 0 by dT += gap / slope, the slope T1 . ray (as if the back face were flat; with
// BACK_SECANT, ours, only the first step, then the secant through the last two steps, which also
// follows the face's tilt); |S - P1| where the slope is small. Front faces (steep near the silhouette, where front exits happen), and the nearer
// layer: dT = the distance along T1 to the tangent plane at S. A point that leaves the
// silhouette steps back halfway to the last point inside and sets `left`. A step shorter than
// `tolerance` ends it (its dT kept, N_S the surface just read), as does the `steps`-th correction.
// Returns false if no point was inside.
bool correct_distance(int layer, int steps, vec3 p1, vec3 t1, inout float dt, out vec4 s2, out bool left) {
    bool tangent_plane = layer != BACK_LAYER;
    left = false;
    s2 = vec4(0.0);
    float inside_dt = 0.0;
    float last_dt = 0.0, last_gap = 0.0;  // the previous back-face step (secant)
    for (int i = 0; ; ++i) {
        vec3 q = p1 + dt * t1;
        vec2 pixel;
        vec4 s = buffer_pixel(q, pixel) ? layer_surface(layer, pixel, length(q - camera_position)) : vec4(0.0);
        if (s.w <= 0.0) {
            left = true;
            // The first of two resolve stages hands a pixel that left on to the second, which
            // iterates again: no need to go on here.
            if (DEFER_STAGE == 1 && layer == BACK_LAYER) break;
            dt = 0.5 * (dt + inside_dt);
            if (i >= steps) break;
            continue;
        }
        inside_dt = dt;
        s2 = s;
        if (i >= steps) break;
        vec3 ray = normalize(q - camera_position);  // the ray of the pixel q projects to
        vec3 sp = camera_position + s.w * ray;        // surface_point(pixel, s.w), without the matrix
        float rate = dot(t1, ray);
        vec3 n_s = normalize(s.xyz);
        float next;
        float gap = s.w - length(q - camera_position);  // back faces: depth gap along the pixel ray
        // Its rate of change along T1: first the ray's alone (a flat back face), then the secant
        // through the last two steps, which also follows the surface's slope.
        float slope = BACK_SECANT != 0 && i > 0 && abs(dt - last_dt) > 1e-9 ? (last_gap - gap) / (dt - last_dt) : rate;
        if (!(abs(slope) > 0.05)) slope = rate;
        slope = max(slope, 0.5 * rate);  // steps at most twice the flat-face step: no overshoot off the rim
        last_dt = dt;
        last_gap = gap;
        if (tangent_plane && abs(dot(t1, n_s)) > 1e-3) next = dot(sp - p1, n_s) / dot(t1, n_s);
        else if (!tangent_plane && abs(slope) > 0.05) next = dt + gap / slope;
        else next = length(sp - p1);
        if (!(next > 0.0)) next = length(sp - p1);  // also catches NaN
        dt = next;
        // Converged: keep the step, with this lookup's surface for N2 (within tolerance of it),
        // rather than pay one more lookup to confirm it.
        if (abs(next - inside_dt) < tolerance) { inside_dt = dt; break; }
    }
    dt = inside_dt;
    return s2.w > 0.0;
}

// One exit of the green channel's path: where it leaves, the outward normal there and the path
// length inside up to it. The geometry of every channel's path is green's (dispersion refracts each
// channel with its own IOR at the same points).
struct Exit {
    vec3 point;
    vec3 normal;
    float travelled;
};
const int MAX_EXITS = INTERNAL_BOUNCES + 1;  // the first exit and one per internal bounce

// The first exit of the path entering at P1 along T1 (v, n: the view direction and the normal at P1),
// found in screen space: 2.1.2-2.1.4. False where no buffer holds it (N2 = T1 there, so T2 = T1:
// env-map's single refraction).
bool searched_first_exit(vec3 v, vec3 n, vec3 p1, vec3 t1, out Exit exit) {
    vec2 pix1;
    buffer_pixel(p1, pix1);
    float start = 1e-3 * length(p1 - camera_position);  // the paper's small positive initial dT
#if BACK_SECANT
    // Ours: the refractor's thickness along the view ray at P1 (Wyman's d_V, from the back buffer).
    float first_back = max(surface_at(back_surface, pix1).w - length(p1 - camera_position), start);
#if BACK_SPHERE_START
    // Ours: the sphere that touches the surface at P1 and cuts the chord d_V = 2 R cos(theta_i)
    // from the view ray cuts 2 R cos(theta_t) from T1, so start at d_V cos(theta_t) / cos(theta_i):
    // exact on a sphere, where the iteration then only confirms it.
    first_back = max(first_back * dot(n, t1) / min(dot(n, v), -1e-3), start);
#endif
#else
    float first_back = start;
#endif

    // Decide the exit face: with the section-4 shortcut, iterate on the back faces first and
    // search only where P2 left the silhouette; otherwise search first (2.1.2).
    bool front_exit = false;
    float dt = first_back;
    vec4 s2;
    bool left = true;
    bool found = false;
#if ASSUME_BACK_FIRST
    found = correct_distance(BACK_LAYER, iterations, p1, t1, dt, s2, left);
#if DEFER_STAGE == 1
    // The first of two resolve stages (ShadeSurfaces' ``staged``): the pixels whose P2 left the
    // silhouette are shaded again, with the search, by the second stage, which runs on them alone
    // (llvmpipe would run the search below for every vector, even where no pixel takes it).
    deferred_refine = left;
    left = false;
#endif
#endif
    if (left) {
        // 2.1.2: silhouette point Pe along the projected T1; front exit when T1 turns further
        // from V than the chord P1 -> Pe does.
        vec2 ahead;
        buffer_pixel(p1 + start * t1, ahead);
        vec2 t1_screen = ahead - pix1;
        vec3 pe;
        bool searched = dot(t1_screen, t1_screen) > 1e-12 && silhouette_point(pix1, normalize(t1_screen), pe);
        vec3 chord = searched ? pe - p1 : t1;
        if (searched) {
            float theta1 = acos(clamp(dot(v, t1), -1.0, 1.0));
            float theta2 = acos(clamp(dot(v, normalize(chord)), -1.0, 1.0));
            front_exit = theta1 > theta2;
        }
        // A front exit lies on the front arc between P1 and Pe: start from the chord length
        // (dT = 0 would be a fixed point there), or with BACK_SPHERE_START from the sphere's
        // chord along T1, which ends on a front face just as well. A back exit keeps the first
        // iteration's result when it ran.
        if (front_exit) {
#if BACK_SECANT && BACK_SPHERE_START
            dt = first_back;  // ours
#else
            dt = max(length(chord), start);
#endif
            found = correct_distance(FRONT_LAYER, iterations, p1, t1, dt, s2, left);
        } else if (ASSUME_BACK_FIRST == 0) {
            dt = first_back;
            found = correct_distance(BACK_LAYER, iterations, p1, t1, dt, s2, left);
        }
    }
    // P2 with N2 from the buffer (2.1.4).
    exit = Exit(p1 + dt * t1, found ? normalize(s2.xyz) : t1, dt);
    return found;
}

// Our extension, not in the paper: the next exit of the light reflected inside at `exit` along r.
// First guess: the previous chord (exact on a sphere, whose successive chords are equal); then
// 2.1.3's tangent-plane correction against whichever buffer lies nearer the point, since the next
// exit may be front- or back-facing. False where no buffer holds it.
bool searched_next_exit(inout Exit exit, vec3 r, inout float chord) {
    vec4 s;
    bool left;
    bool found = correct_distance(NEAREST_LAYER, bounce_iterations, exit.point, r, chord, s, left);
    exit = Exit(exit.point + chord * r, found ? normalize(s.xyz) : r, exit.travelled + chord);
    return found;
}

// Ours (passes/shading/convex_exits.py): the exit exact, where the glass is an analytic sphere or a convex
// mesh of few planes, from p along d (green's IOR). The shading normal there, unless the light it
// reflects would leave through the face or the light it refracts stay inside: then the face's own
// (passes/shading/convex_exits.py says where exact differs).
#if CONVEX_EXITS
Exit convex_next_exit(vec3 p, vec3 d, float travelled, float ior) {
    vec3 normal, face;
    float t = convex_exit(p, d, normal, face);
    vec3 leaving = refract_direction(d, -normal, ior);
    if (dot(reflect_direction(d, -normal), face) >= 0.0 || dot(leaving, face) < 0.0) normal = face;
    return Exit(p + t * d, normal, travelled + t);
}
#endif

#if CONVEX_EXITS
#define EXACT_EXITS (CONVEX_EXITS == 1 || convex_kind != 0)  // 1: every glass object; 2: the one being shaded
#endif

// The first exit along T1 from P1: exact where the glass has a known convex shape, else searched.
bool first_exit(vec3 v, vec3 n, vec3 p1, vec3 t1, float ior, out Exit exit) {
#if CONVEX_EXITS
    if (EXACT_EXITS) {
        exit = convex_next_exit(p1, t1, 0.0, ior);
        return true;
    }
#endif
    return searched_first_exit(v, n, p1, t1, exit);
}

// The exit after `exit` along the reflected direction r; chord: the searched bounces' first guess.
bool next_exit(inout Exit exit, vec3 r, float ior, inout float chord) {
#if CONVEX_EXITS
    if (EXACT_EXITS) {
        exit = convex_next_exit(exit.point, r, exit.travelled, ior);
        return true;
    }
#endif
    return searched_next_exit(exit, r, chord);
}

// One refractive index's light inside the glass: its direction, the share of the light entering
// that still goes on inside, and the radiance that has left so far.
struct InsideLight {
    vec3 direction;
    float ior;
    float weight;
    vec3 radiance;
};

// How the light of one IOR meets an exit (2.1.4): the ray it leaves along (T, or R on TIR), and
// the Fresnel reflectance F there (1 on TIR).
struct Departure {
    vec3 from;
    vec3 along;
    float reflectance;
    bool tir;
};

Departure departure(InsideLight light, Exit exit) {
    vec3 t = refract_direction(light.direction, -exit.normal, light.ior);
    bool tir = dot(t, t) == 0.0;
    Departure leaving = Departure(exit.point, tir ? reflect_direction(light.direction, -exit.normal) : t,
                                  fresnel_dielectric(dot(light.direction, exit.normal), light.ior, 1.0), tir);
#if GLASS_CONTACT && NEARBY != NEARBY_NONE
    // Ours: a face lying on the receiver the glass stands on passes all the light to it, reflecting none.
    vec3 landing;
    if (on_contact_plane(contact_plane, contact_tolerance, exit.point, exit.normal, landing)) {
#if NEARBY == NEARBY_PLANES
        // Wyman's planes count hits beyond a small t only: the lookup starts contact_tolerance before the
        // receiver's plane, so that it meets the plane it lands on.
        landing -= contact_tolerance * exit.normal;
#endif
        leaving = Departure(landing, exit.normal, 0.0, false);
    }
#endif
    return leaving;
}

// The light of one IOR leaving at an exit, where a lookup along the departure saw `seen`: the
// transmitted share 1 - F leaves, and the reflected share F goes on inside along R (our extension;
// the paper stops at the first exit). TIR leaves along R, and only at the last exit.
void leave(inout InsideLight light, Exit exit, Departure leaving, vec3 seen, bool last) {
    float share = leaving.tir ? (last ? 1.0 : 0.0) : 1.0 - leaving.reflectance;
    light.radiance += light.weight * share * exp(-absorption_coefficient * exit.travelled) * seen;
    light.weight *= leaving.reflectance;
    light.direction = reflect_direction(light.direction, -exit.normal);
}

// Every IOR's light at the k-th exit of green's path: the lookups along its departures (red's and blue's
// own at the first exit), the transmitted shares leaving, the reflected going on inside; `last`: no exit
// follows (its TIR leaves here). The bounced exits (k > 0) look up the environment in one tap as wide as
// the footprint's longer side (over-filtered, never aliased): their light is the small share the exits
// reflect, or a TIR path whose neighbours take other paths.
void exit_lookups(int k, Exit exit, bool last, inout InsideLight green
#if DISPERSION
                  , inout InsideLight red, inout InsideLight blue, vec3 red_seen, vec3 blue_seen
#endif
                  ) {
    environment_taps_limit = k == 0 ? ENVIRONMENT_TAPS : 1;
    Departure leaving = departure(green, exit);
    vec3 seen = nearby_radiance(leaving.from, leaving.along);
    leave(green, exit, leaving, seen, last);
#if DISPERSION
#if SHARED_BOUNCES
    leave(red, exit, departure(red, exit), k == 0 ? red_seen : seen, last);
    leave(blue, exit, departure(blue, exit), k == 0 ? blue_seen : seen, last);
#else
    leaving = departure(red, exit);
    leave(red, exit, leaving, nearby_radiance(leaving.from, leaving.along), last);
    leaving = departure(blue, exit);
    leave(blue, exit, leaving, nearby_radiance(leaving.from, leaving.along), last);
#endif
#endif
    environment_taps_limit = ENVIRONMENT_TAPS;
}

// The light of one IOR entering at the front face: Fresnel at the entry, then what left the glass.
float entered_radiance(vec3 v, vec3 n, vec3 reflected, InsideLight light, int c) {
    float f1 = fresnel_dielectric(dot(-v, n), 1.0, light.ior);
    vec3 t1 = refract_direction(v, n, 1.0 / light.ior);
    return dot(t1, t1) == 0.0 ? reflected[c] : f1 * reflected[c] + (1.0 - f1) * light.radiance[c];
}

vec3 shade_refractor(vec3 v, vec3 n, out vec4 exit_dir) {
    vec3 reflected_dir = reflect_direction(v, n);
    vec3 reflected = nearby_reflection(world_position, reflected_dir);
    float ior = ior_rgb[1];
    vec3 t1 = refract_direction(v, n, 1.0 / ior);
    exit_dir = nearby_output(vec4(reflected_dir, 1.0));
    // Entry TIR (n_t < n_i at grazing incidence): the surface only reflects.
    if (dot(t1, t1) == 0.0) return reflected;
    Exit exit;
    bool more = first_exit(v, n, world_position, t1, ior, exit);
    vec3 t2 = refract_direction(t1, -exit.normal, ior);
    vec4 first_exit_direction = vec4(dot(t2, t2) > 0.0 ? t2 : reflect_direction(t1, -exit.normal), 1.0);

    InsideLight green = InsideLight(t1, ior, 1.0, vec3(0.0));
#if DISPERSION
    InsideLight red = InsideLight(refract_direction(v, n, 1.0 / ior_rgb[0]), ior_rgb[0], 1.0, vec3(0.0));
    InsideLight blue = InsideLight(refract_direction(v, n, 1.0 / ior_rgb[2]), ior_rgb[2], 1.0, vec3(0.0));
#if SHARED_BOUNCES
    // Ours: red and blue look up their own directions at the first exit, where the channels part
    // most, and take green's lookups at the bounced exits (with their own Fresnel weights).
    Departure red_first = departure(red, exit), blue_first = departure(blue, exit);
    vec3 red_seen = nearby_radiance(red_first.from, red_first.along);
    vec3 blue_seen = nearby_radiance(blue_first.from, blue_first.along);
#else
    vec3 red_seen = vec3(0.0), blue_seen = vec3(0.0);  // each exit looks up its own (exit_lookups)
#endif
#endif
    // Each IOR's light follows the green path's exits one at a time, nothing kept in arrays (which
    // llvmpipe keeps in memory). Whether an exit is the last, which decides where its TIR goes, is
    // known once the next one has been searched for. One loop, so that the search is compiled once;
    // every pixel runs all of it (no break), so the lookups' screen derivatives stay in uniform control
    // flow; past its last exit a path's weights are 0. The last exit is taken after the loop: inside
    // it, llvmpipe would run a search after it too, for no pixel.
    float chord = exit.travelled;
    for (int k = 0; k < MAX_EXITS - 1; ++k) {
        Exit next = exit;
        more = more && next_exit(next, reflect_direction(green.direction, -exit.normal), ior, chord);
#if DISPERSION
        exit_lookups(k, exit, !more, green, red, blue, red_seen, blue_seen);
#else
        exit_lookups(k, exit, !more, green);
#endif
        float going_on = more ? 1.0 : 0.0;
        green.weight *= going_on;
#if DISPERSION
        red.weight *= going_on;
        blue.weight *= going_on;
#endif
        exit = next;
    }
#if DISPERSION
    exit_lookups(MAX_EXITS - 1, exit, true, green, red, blue, red_seen, blue_seen);
#else
    exit_lookups(MAX_EXITS - 1, exit, true, green);
#endif
    exit_dir = nearby_output(first_exit_direction);  // after the lookups: it may name the last one's hit
#if DISPERSION
    return vec3(entered_radiance(v, n, reflected, red, 0), entered_radiance(v, n, reflected, green, 1),
                entered_radiance(v, n, reflected, blue, 2));
#else
    float f1 = fresnel_dielectric(dot(-v, n), 1.0, ior);
    return f1 * reflected + (1.0 - f1) * green.radiance;
#endif
}

#if NEARBY_MIRRORS
#define environment_radiance(env, dir) nearby_mirror_radiance(dir)  // mirrors see nearby geometry too
#endif

#include "common/surface_main.glsl"
