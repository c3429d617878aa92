// depth-search: two-interface refraction without preprocessing (Hu and Qin, TVCG 2007, 2.1 and 4).
// Per glass fragment: T1 at P1; decide whether the exit P2 lies on a front- or back-facing
// surface (binary search along the projected T1 for the silhouette point pe, 2.1.2, or the
// section-4 shortcut: assume back-facing and switch when P2 leaves the silhouette); correct
// dT iteratively against that face's depth buffer (2.1.3); N2 from that face's normal
// texture (2.1.4); T2 = refract(T1, N2) per RGB channel; environment lookup.
// Geometry (P2, N2) follows the green channel's IOR; each channel refracts with its own IOR
// at both interfaces (dispersion). TIR at the exit reflects once (at the entry: reflect only).
//
// Nearby geometry (``nearby``, and the ``impostors`` technique): T2 and the reflections go to
// nearby_radiance of common/impostors.glsl instead of the environment.
// Host defines: ShadeSurfaces' own (MAX_LIGHTS, CAUSTICS); NEARBY, NEARBY_OUTPUT, PHOTON_BUFFER,
// MAX_IMPOSTORS, MAX_PLANES (common/impostors.glsl; NEARBY 0 keeps the environment). Uniforms set by the technique:
//   search_steps (int), search_start (float, fraction of the buffer size), iterations (int),
//   tolerance (float, scene units), assume_back_first (int 0/1), internal_reflection (int 0/1),
//   world_from_clip (mat4).
#version 430 core
#include "common/surface_inputs.glsl"
#include "common/impostors.glsl"

uniform sampler2D front_surface;  // nearest front face: outward normal xyz, eye distance w (0: none)
uniform sampler2D back_surface;   // farthest back face: the same
uniform mat4 world_from_clip;
uniform int search_steps;
uniform float search_start;
uniform int iterations;
uniform float tolerance;
uniform int assume_back_first;
uniform int internal_reflection;  // 1: follow the light reflected inside at P2 to a second exit (our extension)

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
// all hold a surface (the nearest texel otherwise): sub-texel P2 and N2.
vec4 surface_filtered(sampler2D surfaces, vec2 pixel) {
    vec4 nearest = surface_at(surfaces, pixel);
    if (nearest.w <= 0.0) return nearest;
    vec2 base = floor(pixel - 0.5);
    vec2 f = pixel - 0.5 - base;
    vec4 s00 = surface_at(surfaces, base + vec2(0.5, 0.5)), s10 = surface_at(surfaces, base + vec2(1.5, 0.5));
    vec4 s01 = surface_at(surfaces, base + vec2(0.5, 1.5)), s11 = surface_at(surfaces, base + vec2(1.5, 1.5));
    if (min(min(s00.w, s10.w), min(s01.w, s11.w)) <= 0.0) return nearest;
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

// 2.1.3: correct dT against one buffer. S (normal N_S) is the surface the buffer holds where
// P1 + dT T1 projects. Back faces: dT += (|S - E| - |P1 + dT T1 - E|) / (T1 . ray), the depth
// difference along the pixel ray turned into a step along T1 (|S - P1| where that rate is
// small). Front faces (steep near the silhouette, where front exits happen): dT = the
// distance along T1 to the tangent plane at S. A point that leaves the silhouette steps back
// halfway to the last point inside and sets `left`. Returns false if no point was inside.
bool correct_distance(sampler2D surfaces, bool tangent_plane, vec3 p1, vec3 t1, inout float dt,
                      out vec4 s2, out bool left) {
    left = false;
    s2 = vec4(0.0);
    float inside_dt = 0.0;
    bool done = false;
    for (int i = 0; ; ++i) {
        vec3 q = p1 + dt * t1;
        vec2 pixel;
        vec4 s = buffer_pixel(q, pixel) ? surface_filtered(surfaces, pixel) : vec4(0.0);
        if (s.w <= 0.0) {
            left = true;
            dt = 0.5 * (dt + inside_dt);
            if (i >= iterations) break;
            continue;
        }
        inside_dt = dt;
        s2 = s;
        if (i >= iterations || done) break;
        vec3 sp = surface_point(pixel, s.w);
        vec3 ray = normalize(q - camera_position);
        float rate = dot(t1, ray);
        vec3 n_s = normalize(s.xyz);
        float next;
        if (tangent_plane && abs(dot(t1, n_s)) > 1e-3) next = dot(sp - p1, n_s) / dot(t1, n_s);
        else if (!tangent_plane && abs(rate) > 0.05) next = dt + (s.w - length(q - camera_position)) / rate;
        else next = length(sp - p1);
        if (!(next > 0.0)) next = length(sp - p1);  // also catches NaN
        done = abs(next - dt) < tolerance;
        dt = next;
    }
    dt = inside_dt;
    return s2.w > 0.0;
}

// Our extension, not in the paper: the light reflected inside at P2 (weight F2) heads back
// towards the eye side and leaves through a front face. Start from the front surface the
// buffer holds at P2's pixel and correct against the tangent planes there (2.1.3's front
// rule). Rays heading away from the eye are not followed (false).
bool second_exit(vec3 p2, vec3 r2, float start, out float dt3, out vec4 s3) {
    dt3 = 0.0;
    s3 = vec4(0.0);
    if (dot(r2, normalize(p2 - camera_position)) >= 0.0) return false;
    vec2 pixel;
    if (!buffer_pixel(p2, pixel)) return false;
    vec4 front = surface_filtered(front_surface, pixel);
    if (front.w <= 0.0) return false;
    dt3 = max(length(surface_point(pixel, front.w) - p2), start);
    bool left;
    return correct_distance(front_surface, true, p2, r2, dt3, s3, left);
}

vec3 shade_refractor(vec3 v, vec3 n, out vec4 exit_dir) {
    vec3 reflected_dir = reflect_direction(v, n);
    vec3 reflected = nearby_reflection(world_position, reflected_dir);
    float ior = ior_rgb[1];
    vec3 t1 = refract_direction(v, n, 1.0 / ior);
    exit_dir = nearby_output(vec4(reflected_dir, 1.0));
    // Entry TIR (n_t < n_i at grazing incidence): the surface only reflects.
    if (dot(t1, t1) == 0.0) return reflected;
    vec3 p1 = world_position;
    vec2 pix1;
    buffer_pixel(p1, pix1);
    float start = 1e-3 * length(p1 - camera_position);  // the paper's small positive initial dT

    // Decide the exit face: with the section-4 shortcut, iterate on the back faces first and
    // search only where P2 left the silhouette; otherwise search first (2.1.2).
    bool front_exit = false;
    float dt = start;
    vec4 s2;
    bool left = true;
    bool found = assume_back_first != 0 && correct_distance(back_surface, false, p1, t1, dt, s2, left);
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
        // (dT = 0 would be a fixed point there). A back exit keeps the first iteration's
        // result when it ran.
        if (front_exit) {
            dt = max(length(chord), start);
            found = correct_distance(front_surface, true, p1, t1, dt, s2, left);
        } else if (assume_back_first == 0) {
            dt = start;
            found = correct_distance(back_surface, false, p1, t1, dt, s2, left);
        }
    }
    // P2 outside every buffer: N2 = T1, so T2 = T1 (env-map's single refraction).
    vec3 n2 = found ? normalize(s2.xyz) : t1;
    // Optionally one internal reflection at P2, leaving at P3 through N3 (extension).
    float dt3 = 0.0;
    vec4 s3;
    bool bounce = internal_reflection != 0 && found
        && second_exit(p1 + dt * t1, reflect_direction(t1, -n2), start, dt3, s3);
    vec3 n3 = bounce ? normalize(s3.xyz) : n2;
    // Exit through the outward normal N2 (2.1.4); per-channel Snell and Fresnel at every interface.
    vec3 transmittance = exp(-absorption_coefficient * dt);
    vec3 transmittance3 = exp(-absorption_coefficient * (dt + dt3));
    vec3 result;
    for (int c = 0; c < 3; ++c) {
        float f1 = fresnel_dielectric(dot(-v, n), 1.0, ior_rgb[c]);
        vec3 t1c = refract_direction(v, n, 1.0 / ior_rgb[c]);
        if (dot(t1c, t1c) == 0.0) { result[c] = reflected[c]; continue; }
        vec3 t2 = refract_direction(t1c, -n2, ior_rgb[c]);
        float f2 = fresnel_dielectric(dot(t1c, n2), ior_rgb[c], 1.0);
        vec3 r2 = reflect_direction(t1c, -n2);
        float inside;
        if (bounce) {
            // Transmitted at P2, plus reflected at P2 and transmitted at P3 (TIR at P3: dropped).
            vec3 t3 = refract_direction(r2, -n3, ior_rgb[c]);
            float f3 = fresnel_dielectric(dot(r2, n3), ior_rgb[c], 1.0);
            vec3 p2 = p1 + dt * t1;
            float second = dot(t3, t3) > 0.0 ? f2 * (1.0 - f3) * transmittance3[c] * nearby_cached(p2 + dt3 * reflect_direction(t1, -n2), t3)[c] : 0.0;
            float first = dot(t2, t2) > 0.0 ? (1.0 - f2) * transmittance[c] * nearby_cached(p2, t2)[c] : 0.0;
            inside = first + second;
        } else {
            // Exit TIR: one internal reflection, then out to the environment.
            vec3 out_dir = dot(t2, t2) > 0.0 ? t2 : r2;
            float through = dot(t2, t2) > 0.0 ? 1.0 - f2 : 1.0;
            inside = through * transmittance[c] * nearby_cached(p1 + dt * t1, out_dir)[c];
        }
        result[c] = f1 * reflected[c] + (1.0 - f1) * inside;
    }
    vec3 t2 = refract_direction(t1, -n2, ior);
    exit_dir = nearby_output(vec4(dot(t2, t2) > 0.0 ? t2 : reflect_direction(t1, -n2), 1.0));
    return result;
}

#if NEARBY
#define environment_radiance(env, dir) nearby_mirror_radiance(dir)  // mirrors see nearby geometry too
#endif

#include "common/surface_main.glsl"
