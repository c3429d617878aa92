// Photon splats, first pass (Wyman, "Rendering From the Light"): the scene rendered from the light with
// the image-space refraction routine; instead of a colour each refractor texel stores the photon that
// leaves it: exit point P2, exit direction T2 and flux. Per RGB channel (one IOR each, for dispersion):
// T1 = refract(L, N1); d~ = (theta_t / theta_i) d_V + (1 - theta_t / theta_i) d_N (eq. 6.3.1), d_V from
// the light's front and back distances, d_N interpolated per vertex; P2 = P1 + d~ T1; N2 from the
// back-face normals at P2's projection, eq. 6.3.2 (perpendicular to L) where that texel is empty;
// T2 = refract(T1, -N2, n_glass). Flux: the light's intensity times the texel's solid angle (or
// irradiance times its area), times (1 - F1)(1 - F2) (exact Fresnel) and exp(-sigma_a d~).
// Open meshes (water) refract once (Beer-Lambert to the receiver is left to the landing pass);
// mirrors reflect once; diffuse objects occlude (no photon). Ours: a photon reaching a face that lies on the
// receiver the glass stands on lands where T1 meets it, with no exit Fresnel (exit point w = 2: landed).
// Host defines: CHANNELS (1: one RGB photon; 3: one photon per channel), USE_DN (1), GLASS_CONTACT (0/1),
// TIR_MODE (1: TIR_KEEP_T1 0, TIR_CLAMP 1, TIR_REFLECT 2, TIR_DROP 3), VIEW_COUNT (1: the photon buffer's view),
// CASTER_NONE, _MIRROR, _SOLID, _SURFACE (scene/codes.py, in every program: object_kind's codes).
#version 430 core
#ifndef CHANNELS
#define CHANNELS 1
#endif
#ifndef USE_DN
#define USE_DN 1
#endif
#define TIR_KEEP_T1 0
#define TIR_CLAMP 1
#define TIR_REFLECT 2
#define TIR_DROP 3
#ifndef TIR_MODE
#define TIR_MODE TIR_CLAMP
#endif
#ifndef GLASS_CONTACT
#define GLASS_CONTACT 0
#endif
#include "common/optics.glsl"
#include "common/glass_contact.glsl"
#include "passes/caustics/caustic_light_space.glsl"

uniform sampler2D back_position;  // view 0: farthest back faces of the glass, world xyz + light distance (0: none)
uniform sampler2D back_normal;    // view 0: their outward normals
uniform int object_kind;          // CASTER_* of the object being drawn
uniform int object_index;         // its index among the casters (single surfaces: the landing pass absorbs)
uniform vec3 object_ior;          // per channel
uniform vec3 object_sigma;        // Beer-Lambert absorption coefficient
uniform vec3 object_color;        // mirror reflectance
#if GLASS_CONTACT
uniform vec4 contact_plane;       // the receiver the object stands on: unit normal n (0: none), n . x = w on it
uniform float contact_tolerance;  // how far off that plane an exit still lies on it (passes/shading/glass_contact.py)
#endif

in vec3 world_position;
in vec3 world_normal;
in float world_dn;
layout(location = 0) out vec4 out_flux;  // rgb: W (dispersion: channel c's photon carries component c); a: index + 1 to absorb to the receiver
layout(location = 1) out vec4 out_origin0;  // exit point, w = 1 where the photon exists
layout(location = 2) out vec4 out_direction0;
#if CHANNELS == 3
layout(location = 3) out vec4 out_origin1;
layout(location = 4) out vec4 out_direction1;
layout(location = 5) out vec4 out_origin2;
layout(location = 6) out vec4 out_direction2;
#endif

// N2 at P2 from the back-face buffer; eq. 6.3.2 where P2 projects off the refractor.
vec3 exit_normal(vec3 p2, vec3 t1, vec3 l) {
    int face;
    bool inside;
    vec2 x = view_pixel(0, p2, face, inside);
    if (inside) {
        vec4 n2 = fetch_surface(back_normal, 0, face, x);
        if (dot(n2.xyz, n2.xyz) > 1e-12) return normalize(n2.xyz);
    }
    vec3 n2 = t1 - dot(l, t1) * l;
    return dot(n2, n2) > 1e-12 ? normalize(n2) : t1;
}

#if GLASS_CONTACT
// The back face seen from the light at p2's texel (p2 itself off the refractor).
vec3 back_surface(vec3 p2) {
    int face;
    bool inside;
    vec2 x = view_pixel(0, p2, face, inside);
    vec4 back = inside ? fetch_surface(back_position, 0, face, x) : vec4(0.0);
    return back.w > 0.0 ? back.xyz : p2;
}
#endif

// One channel's photon through a closed refractor: (exit point, w = 1 where it leaves, 2 where it landed), its direction
// (w: the Fresnel transmittance (1 - F1)(1 - F2)) and the distance d~ inside.
vec4 refract_twice(vec3 p1, vec3 l, vec3 n1, float eta, float d_v, float d_n, bool has_dn,
                   out vec4 direction, out float d) {
    direction = vec4(0.0);
    d = 0.0;
    vec3 t1 = refract_direction(l, n1, 1.0 / eta);
    if (dot(t1, t1) == 0.0) return vec4(0.0);  // total reflection at entry (eta < 1)
    float transmit = 1.0 - fresnel_dielectric(dot(-l, n1), 1.0, eta);
    // Estimate the distance to the second interface (eq. 6.3.1).
    d = d_v;
    if (has_dn) {
        float theta_i = acos(clamp(dot(-l, n1), -1.0, 1.0));
        float theta_t = acos(clamp(dot(t1, -n1), -1.0, 1.0));
        float w = theta_i > 1e-4 ? theta_t / theta_i : 1.0 / eta;  // small-angle Snell limit
        d = max(w * d_v + (1.0 - w) * d_n, 0.0);
    }
    // Find P2 and its normal, facing the ray.
    vec3 p2 = p1 + d * t1;
    vec3 n2 = exit_normal(p2, t1, l);
    vec3 facing = dot(t1, n2) > 0.0 ? -n2 : n2;
#if GLASS_CONTACT
    // A face on the receiver the glass stands on: the light passes into it where T1 meets its plane.
    vec3 landing;
    float along = dot(contact_plane.xyz, t1);
    if (on_contact_plane(contact_plane, contact_tolerance, back_surface(p2), -facing, landing) && along < 0.0) {
        d = max((contact_plane.w - dot(contact_plane.xyz, p1)) / along, 0.0);
        direction = vec4(t1, transmit);
        return vec4(p1 + d * t1, 2.0);
    }
#endif
    // Refract out of the glass, or a TIR fallback.
    vec3 t2 = refract_direction(t1, facing, eta);
    if (dot(t2, t2) > 0.0) {
        transmit *= 1.0 - fresnel_dielectric(dot(t1, -facing), eta, 1.0);
    } else {
#if TIR_MODE == TIR_KEEP_T1
        t2 = t1;
#elif TIR_MODE == TIR_CLAMP
        t2 = normalize(t1 - dot(t1, facing) * facing);
#elif TIR_MODE == TIR_REFLECT
        t2 = reflect_direction(t1, facing);
#else
        return vec4(0.0);
#endif
    }
    direction = vec4(normalize(t2), transmit);
    return vec4(p2 - 1e-4 * length_unit * facing, 1.0);
}

void main() {
    out_flux = vec4(0.0);
    out_origin0 = out_direction0 = vec4(0.0);
#if CHANNELS == 3
    out_origin1 = out_direction1 = out_origin2 = out_direction2 = vec4(0.0);
#endif
    if (object_kind == CASTER_NONE) return;
    // The photon this texel holds: the light's flux through the texel.
    vec3 p1 = world_position;
    vec3 l = light_ray(p1);
    int face = int(gl_FragCoord.x) / view_size[0];
    vec3 flux = ls_light_intensity * texel_measure(0, face, p1) * light_falloff(l);
    vec3 n1 = normalize(world_normal);
    if (dot(n1, l) > 0.0) n1 = -n1;  // face the light (open meshes seen from below)

    if (object_kind == CASTER_MIRROR) {
        out_origin0 = vec4(p1 + 1e-4 * length_unit * n1, 1.0);
        out_direction0 = vec4(reflect_direction(l, n1), 0.0);
        out_flux = vec4(flux * object_color, 0.0);
        return;
    }

    vec4 origins[3], directions[3];
    vec3 through = vec3(0.0);
    if (object_kind == CASTER_SURFACE) {
        // One interface: the photon goes on to the receiver inside the medium.
        for (int c = 0; c < CHANNELS; ++c) {
            vec3 t1 = refract_direction(l, n1, 1.0 / object_ior[c]);
            bool entered = dot(t1, t1) > 0.0;
            origins[c] = entered ? vec4(p1 - 1e-4 * length_unit * n1, 1.0) : vec4(0.0);
            directions[c] = vec4(t1, 0.0);
            float transmit = entered ? 1.0 - fresnel_dielectric(dot(-l, n1), 1.0, object_ior[c]) : 0.0;
            if (CHANNELS == 1) through = vec3(transmit); else through[c] = transmit;
        }
        out_flux.a = float(object_index + 1);
    } else {
        // Two interfaces: d_V from the back faces at this texel, d_N from the vertices.
        vec4 back = texelFetch(back_position, ivec2(gl_FragCoord.xy), 0);
        float d_v = back.a > 0.0 ? max(back.a - light_distance(p1), 0.0) : 0.0;
        bool has_dn = USE_DN != 0 && world_dn > 0.0;
        for (int c = 0; c < CHANNELS; ++c) {
            float d;
            origins[c] = refract_twice(p1, l, n1, object_ior[c], d_v, world_dn, has_dn, directions[c], d);
            vec3 absorbed = directions[c].w * exp(-object_sigma * d);  // Beer-Lambert over d~
            if (origins[c].w <= 0.0) continue;
            if (CHANNELS == 1) through = absorbed; else through[c] = absorbed[c];
        }
    }
    out_flux.rgb = flux * through;
    out_origin0 = origins[0];
    out_direction0 = vec4(directions[0].xyz, 0.0);
#if CHANNELS == 3
    out_origin1 = origins[1];
    out_direction1 = vec4(directions[1].xyz, 0.0);
    out_origin2 = origins[2];
    out_direction2 = vec4(directions[2].xyz, 0.0);
#endif
}
