// main() of surface shading: diffuse (direct light with shadow maps + SH ambient + caustics; an opaque PBR
// receiver's shade_principled in its variants, common/surface_inputs.glsl),
// mirror (colour * environment in the reflected direction), glass (the technique's
// shade_refractor). Include after defining shade_refractor.
// Host defines: SURFACE_KIND (MATERIAL_DIFFUSE, _MIRROR or _GLASS): ShadeSurfaces compiles one
// variant per material kind, since CPU rasterizers (llvmpipe) run every side of a branch;
// -1 (the default) selects at run time by the material_kind uniform.
#ifndef SURFACE_KIND
#define SURFACE_KIND -1
#endif

#ifndef REFLECTION_PROBE
#define REFLECTION_PROBE 0
#endif
#ifndef PROBE_PARALLAX
#define PROBE_PARALLAX 0
#endif
#if REFLECTION_PROBE
#include "common/reflection_probe.glsl"
#endif

#if PRINCIPLED
// An opaque glTF metallic-roughness receiver (glTF 2.0 Appendix B, its lobes weighted as
// scene/microfacet.py's layer_weights): per light, the diffuse s (1 - metallic) base / pi plus GGX's
// c F D G2 / (4 cos cos), F Schlick's at the mix of the dielectric's F0 and the base colour, c the
// multiple-scattering compensation and s = 1 - (compensated F0_d A + B) what the dielectric's lobe leaves,
// shadowed as a diffuse receiver (at ``n``, the surface's normal; the BRDF at the shading normal); the
// ambient irradiance (times the occlusion) and the caustics on the diffuse part, by s; the
// environment's specular share by the split sum, prefiltered radiance in the mirror direction times the
// compensated (F0 A + B) (common/microfacet.glsl), times the occlusion (with REFLECTION_PROBE, the object's
// local probe's, common/reflection_probe.glsl); the emission added.
vec3 shade_principled(vec3 v, vec3 n) {
    SurfaceMaterial m = surface_material(n);
    vec3 to_eye = -v;
    vec3 shading_n = m.normal;
    vec3 diffuse_albedo = (1.0 - m.metallic) * m.base;
#if GLOSSY
    float n_dot_v = max(dot(shading_n, to_eye), 1e-4);
    vec3 f0 = mix(material_dielectric_f0, m.base, m.metallic);
    float alpha = ggx_alpha(m.roughness);
    vec2 ab = split_sum(n_dot_v, m.roughness);
    vec3 diffuse_share = clamp(1.0 - compensated_specular_albedo(material_dielectric_f0, ab), 0.0, 1.0);
    vec3 compensation = energy_compensation(f0, ab);
#else
    vec3 diffuse_share = vec3(1.0);
#endif
    vec3 radiance = vec3(0.0);
    for (int i = 0; i < light_count; ++i) {
        vec3 to_light;
        vec3 incident = light_arrival(i, world_position, to_light);
        float n_dot_l = dot(shading_n, to_light);
        if (n_dot_l <= 0.0) continue;
        vec3 brdf = diffuse_albedo / PI;
#if GLOSSY
        vec3 h = normalize(to_light + to_eye);
        float v_dot_h = dot(to_eye, h);
        brdf = diffuse_share * brdf + compensation * schlick(f0, v_dot_h) * ggx_specular(n_dot_l, n_dot_v,
                                                                                      dot(shading_n, h), alpha);
#endif
        radiance += brdf * incident * n_dot_l * light_visibility(i, world_position, n);
    }
    vec3 e = m.occlusion * ambient_irradiance(world_position, n, shading_n) + caustic_irradiance(world_position, n);
    radiance += diffuse_share * diffuse_albedo / PI * e;
#if GLOSSY
    vec3 mirror = reflect(v, shading_n);
#if REFLECTION_PROBE
    mirror = probe_direction(world_position, mirror);  // the object's probe is bound as the prefiltered atlas
#endif
    radiance += m.occlusion * compensated_specular_albedo(f0, ab)
                * prefiltered_radiance(prefiltered_environment, prefiltered_levels, mirror, m.roughness);
#endif
    return radiance + m.emission;
}
#endif

void main() {
#if DEFERRED_SHADING == DEFER_RESOLVE
    vec4 surface = texelFetch(deferred_surface, ivec2(gl_FragCoord.xy), 0);
    vec3 ray_origin, ray_direction;
    deferred_pixel_ray(ray_origin, ray_direction);
    world_position = ray_origin + surface.w * ray_direction;
    world_normal = surface.xyz;  // facing the eye
    vec3 v = normalize(world_position - camera_position);
    vec3 n = normalize(world_normal);
#else
    vec3 v = normalize(world_position - camera_position);
    vec3 n = normalize(world_normal);
    if (!gl_FrontFacing) n = -n;
#endif
    vec3 radiance = vec3(0.0);
    exit_direction = vec4(0.0);
#if DEFERRED_SHADING == DEFER_SHADE_NOW
    deferred_surface_out = vec4(0.0);
#elif DEFERRED_SHADING == DEFER_GBUFFER
    vec3 ray_origin, ray_direction;
    deferred_pixel_ray(ray_origin, ray_direction);
    deferred_surface_out = vec4(n * deferred_id, length(world_position - ray_origin));
#if CAPTURE_FRONT_SURFACE
    front_surface_out = vec4(normalize(world_normal), length(world_position - camera_position));  // as surface_normal_distance.frag
#endif
    return;
#endif
    int kind = SURFACE_KIND < 0 ? material_kind : SURFACE_KIND;
#if SURFACE_KIND < 0 || SURFACE_KIND == MATERIAL_DIFFUSE
    if (kind == MATERIAL_DIFFUSE) {
#if PRINCIPLED
        radiance = shade_principled(v, n);
#else
        vec3 e = direct_irradiance(world_position, n) + ambient_irradiance(world_position, n)
                 + caustic_irradiance(world_position, n);
        radiance = surface_albedo() / PI * e;
#endif
    }
#endif
#if SURFACE_KIND < 0 || SURFACE_KIND == MATERIAL_MIRROR
    if (kind == MATERIAL_MIRROR) {
        radiance = material_color * environment_radiance(environment, reflect_direction(v, n));
    }
#endif
#if SURFACE_KIND < 0 || SURFACE_KIND == MATERIAL_GLASS
    if (kind == MATERIAL_GLASS) {
        radiance = shade_refractor(v, n, exit_direction);
    }
#endif
    color = vec4(intensity_scale * radiance, 1.0);
#if DEFERRED_SHADING == DEFER_RESOLVE && DEFER_STAGE == 1
    deferred_refine_out = deferred_refine ? deferred_key : 0.0;
#endif
}
