// GGX microfacet reflection as glTF 2.0's BRDF (Appendix B) defines it, mirroring scene/microfacet.py:
// alpha = roughness^2 (floored), the Trowbridge-Reitz distribution, height-correlated Smith masking-shadowing,
// Schlick's Fresnel; the split-sum table (Karis 2013) and Fdez-Aguera's (JCGT 2019) energy compensation
// for the environment. Cosines are clamped to [0, 1]. Needs PI (common/environment.glsl).
const float GGX_MIN_ALPHA = 1e-4;  // microfacet.py's MIN_ALPHA

float ggx_alpha(float roughness) { return max(roughness * roughness, GGX_MIN_ALPHA); }

// D(h): microfacet normals per projected area, integral of D cos(theta_h) over the hemisphere 1.
float ggx_distribution(float n_dot_h, float alpha) {
    float c = clamp(n_dot_h, 0.0, 1.0);
    float a2 = alpha * alpha;
    float d = c * c * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

float ggx_lambda(float n_dot_x, float alpha) {
    float cos2 = max(clamp(n_dot_x, 0.0, 1.0) * clamp(n_dot_x, 0.0, 1.0), 1e-12);
    return 0.5 * (sqrt(1.0 + alpha * alpha * (1.0 - cos2) / cos2) - 1.0);
}

// Smith's height-correlated G2 of the light and view directions.
float ggx_masking_shadowing(float n_dot_l, float n_dot_v, float alpha) {
    return 1.0 / (1.0 + ggx_lambda(n_dot_l, alpha) + ggx_lambda(n_dot_v, alpha));
}

vec3 schlick(vec3 f0, float cos_theta) {
    float m = 1.0 - clamp(cos_theta, 0.0, 1.0);
    float m2 = m * m;
    return f0 + (1.0 - f0) * (m2 * m2 * m);
}

// D G2 / (4 cos_l cos_v): the specular BRDF without its Fresnel factor.
float ggx_specular(float n_dot_l, float n_dot_v, float n_dot_h, float alpha) {
    float l = clamp(n_dot_l, 0.0, 1.0), v = clamp(n_dot_v, 0.0, 1.0);
    return ggx_distribution(n_dot_h, alpha) * ggx_masking_shadowing(l, v, alpha) / max(4.0 * l * v, 1e-12);
}

// The split-sum table (microfacet.brdf_table, rg32f, linear, clamped): (A, B) at (cos_v, roughness), with
// the integral of f_spec cos_l over the hemisphere = F0 A + B; its first and last texel centres sit at 0
// and 1 of each (microfacet.split_sum reads it the same way).
uniform sampler2D brdf_table;

vec2 split_sum(float n_dot_v, float roughness) {
    vec2 size = vec2(textureSize(brdf_table, 0));
    vec2 at = clamp(vec2(n_dot_v, roughness), 0.0, 1.0);
    return texture(brdf_table, (at * (size - 1.0) + 0.5) / size).rg;
}

// The environment's specular weight: single scattering F0 A + B, times 1 + F0 (1 / (A + B) - 1), so that a
// rough white metal reflects all it receives (microfacet.energy_compensation).
vec3 energy_compensation(vec3 f0, vec2 ab) {
    return 1.0 + f0 * (1.0 / max(ab.x + ab.y, 1e-6) - 1.0);
}

vec3 compensated_specular_albedo(vec3 f0, vec2 ab) {
    return (f0 * ab.x + ab.y) * energy_compensation(f0, ab);
}
