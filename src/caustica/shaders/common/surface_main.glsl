// main() of surface shading: diffuse (direct light with shadow maps + SH ambient + caustics),
// mirror (colour * environment in the reflected direction), glass (the technique's
// shade_refractor). Include after defining shade_refractor.
// Host defines: SURFACE_KIND (MATERIAL_DIFFUSE, _MIRROR or _GLASS): ShadeSurfaces compiles one
// variant per material kind, since CPU rasterizers (llvmpipe) run every side of a branch;
// -1 (the default) selects at run time by the material_kind uniform.
#ifndef SURFACE_KIND
#define SURFACE_KIND -1
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
        vec3 e = direct_irradiance(world_position, n) + ambient_irradiance(world_position, n)
                 + caustic_irradiance(world_position, n);
        radiance = surface_albedo() / PI * e;
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
