// main() of surface shading: diffuse (direct light with shadow maps + SH ambient + caustics),
// mirror (colour * environment in the reflected direction), glass (the technique's
// shade_refractor). Include after defining shade_refractor.
void main() {
    vec3 v = normalize(world_position - camera_position);
    vec3 n = normalize(world_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 radiance;
    exit_direction = vec4(0.0);
    if (material_kind == MATERIAL_DIFFUSE) {
        vec3 e = direct_irradiance(world_position, n) + ambient_irradiance(n) + caustic_irradiance(world_position);
        radiance = material_color / PI * e;
    } else if (material_kind == MATERIAL_MIRROR) {
        radiance = material_color * environment_radiance(environment, reflect_direction(v, n));
    } else {
        radiance = shade_refractor(v, n, exit_direction);
    }
    color = vec4(intensity_scale * radiance, 1.0);
}
