// image-space refraction (Wyman, "Approximate, Image-Space Refraction"): two interfaces.
// Per RGB channel (one IOR each, for dispersion): T1 at the front surface; the distance to
// the exit d~ = (theta_t / theta_i) d_V + (1 - theta_t / theta_i) d_N (eq. 6.3.1);
// P2 = P1 + d~ T1; N2 from the back-face buffer at P2's projection, or eq. 6.3.2 where that
// texel is empty; T2 = refract(T1, -N2, n_glass / 1); the environment in direction T2.
// Colour: F1 env(reflect) + (1 - F1) (1 - F2) exp(-sigma_a d~) env(T2).
// Exit direction (location 1): T2 of the green channel; w = 1, or 2 where the exit refraction
// was totally internally reflected and TIR_MODE chose T2.
// Host defines: MAX_LIGHTS, CAUSTICS, DISPERSION (ShadeSurfaces; 0: one IOR, one path for all channels); USE_DN (1: interpolate with d_N; 0: d~ = d_V);
// TIR_MODE (1: TIR_KEEP_T1 0, TIR_CLAMP 1, TIR_REFLECT 2); NEARBY, MAX_PLANES (common/impostors.glsl:
// T2 from P2 and the reflections meet nearby planes or an image-space search instead of the environment).
#version 430 core
#ifndef USE_DN
#define USE_DN 1
#endif
#define TIR_KEEP_T1 0
#define TIR_CLAMP 1
#define TIR_REFLECT 2
#ifndef TIR_MODE
#define TIR_MODE TIR_CLAMP
#endif
#include "common/surface_inputs.glsl"
#include "common/impostors.glsl"

uniform sampler2D back_surface;  // second interface: outward normal xyz, eye distance w (0: empty)
#if USE_DN
uniform sampler2D front_dn;      // nearest front face: d_N in world units (x), eye distance (y; 0: none)
#endif

// The ray leaving the refractor in one channel.
struct Exit {
    vec3 direction;      // T2 (or the reflection at the front surface when T1 does not exist)
    float transmittance; // (1 - F2), 1 where the TIR fallback chose the direction
    float distance;      // d~, the estimated path inside
    vec3 origin;         // P2, where the ray leaves
    bool entered;        // false: TIR at the front surface (n < 1), only the reflection remains
    bool tir;            // the exit refraction was totally internally reflected
};

// N2: the back-face buffer at P2's projection; where empty, eq. 6.3.2 (perpendicular to V).
vec3 exit_normal(vec3 p2, vec3 t1, vec3 v) {
    vec4 clip = camera_clip_from_world * vec4(p2, 1.0);
    if (clip.w > 0.0) {
        ivec2 size = textureSize(back_surface, 0);
        ivec2 texel = ivec2(floor((clip.xy / clip.w * 0.5 + 0.5) * vec2(size)));
        if (all(greaterThanEqual(texel, ivec2(0))) && all(lessThan(texel, size))) {
            vec4 surface = texelFetch(back_surface, texel, 0);
            if (surface.w > 0.0) return normalize(surface.xyz);
        }
    }
    vec3 n2 = t1 - dot(v, t1) * v;
    return dot(n2, n2) > 1e-12 ? normalize(n2) : t1;
}

Exit refract_twice(vec3 v, vec3 n, float ior, float d_v, float d_n, bool has_dn) {
    Exit e;
    e.transmittance = 1.0;
    e.distance = 0.0;
    e.origin = world_position;
    e.tir = false;
    // Refract into the glass: T1.
    vec3 t1 = refract_direction(v, n, 1.0 / ior);
    e.entered = dot(t1, t1) > 0.0;
    if (!e.entered) {
        e.direction = reflect_direction(v, n);
        return e;
    }
    // Estimate the distance to the second interface (eq. 6.3.1).
    float d = d_v;
    if (has_dn) {
        float theta_i = acos(clamp(dot(-v, n), -1.0, 1.0));
        float theta_t = acos(clamp(dot(t1, -n), -1.0, 1.0));
        float w = theta_i > 1e-4 ? theta_t / theta_i : 1.0 / ior;  // small-angle Snell limit
        d = max(w * d_v + (1.0 - w) * d_n, 0.0);
    }
    e.distance = d;
    // Find P2 and its normal.
    vec3 p2 = world_position + d * t1;
    e.origin = p2;
    vec3 n2 = exit_normal(p2, t1, v);
    vec3 facing = dot(t1, n2) > 0.0 ? -n2 : n2;  // -N2, the normal facing the ray
    // Refract out of the glass: T2, or a TIR fallback.
    vec3 t2 = refract_direction(t1, facing, ior);
    if (dot(t2, t2) > 0.0) {
        e.direction = t2;
        e.transmittance = 1.0 - fresnel_dielectric(dot(t1, -facing), ior, 1.0);
        return e;
    }
    e.tir = true;
#if TIR_MODE == TIR_KEEP_T1
    e.direction = t1;
#elif TIR_MODE == TIR_CLAMP
    e.direction = normalize(t1 - dot(t1, facing) * facing);  // grazing: the critical angle's limit
#else
    e.direction = reflect_direction(t1, facing);
#endif
    return e;
}

vec3 shade_refractor(vec3 v, vec3 n, out vec4 exit_dir) {
    // Distances along the view ray (d_V) and along -N (d_N) at this pixel.
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float front = length(world_position - camera_position);
    float back = texelFetch(back_surface, pixel, 0).w;
    float d_v = back > 0.0 ? max(back - front, 0.0) : 0.0;
    float d_n = 0.0;
    bool has_dn = false;
#if USE_DN
    vec2 dn = texelFetch(front_dn, pixel, 0).xy;
    has_dn = dn.y > 0.0 && abs(dn.y - front) <= 1e-3 * front;  // the same front surface
    d_n = dn.x;
#endif
    vec3 reflected = nearby_reflection(world_position, reflect_direction(v, n));
    vec3 result;
#if DISPERSION
    // Follow each channel's path and look up the environment.
    for (int c = 0; c < 3; ++c) {
        Exit e = refract_twice(v, n, ior_rgb[c], d_v, d_n, has_dn);
        float f1 = fresnel_dielectric(dot(-v, n), 1.0, ior_rgb[c]);
        float through = 0.0;
        if (e.entered)
            through = e.transmittance * exp(-absorption_coefficient[c] * e.distance)
                    * nearby_cached(e.origin, e.direction)[c];
        result[c] = f1 * reflected[c] + (1.0 - f1) * through;
        if (c == 1) exit_dir = vec4(e.direction, e.tir ? 2.0 : 1.0);
    }
#else
    // One IOR for all channels: one path, one lookup (the three channels' paths would be equal).
    Exit e = refract_twice(v, n, ior_rgb[1], d_v, d_n, has_dn);
    float f1 = fresnel_dielectric(dot(-v, n), 1.0, ior_rgb[1]);
    vec3 through = e.entered ? e.transmittance * exp(-absorption_coefficient * e.distance)
                             * nearby_cached(e.origin, e.direction) : vec3(0.0);
    result = f1 * reflected + (1.0 - f1) * through;
    exit_dir = vec4(e.direction, e.tir ? 2.0 : 1.0);
#endif
    return result;
}

#if NEARBY_MIRRORS
#define environment_radiance(env, dir) nearby_mirror_radiance(dir)  // mirrors see nearby geometry too
#endif
#include "common/surface_main.glsl"
