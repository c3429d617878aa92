// Optics shared by every technique: exact dielectric Fresnel, Snell refraction, reflection.
// Functions take explicit arguments; no uniforms here.

// Unpolarised Fresnel reflectance of a smooth dielectric interface (average of s and p).
// cos_i: cosine between the incident direction (reversed) and the normal, >= 0.
// eta_i, eta_t: refractive indices on the incident and transmitted sides. Returns 1 on TIR.
float fresnel_dielectric(float cos_i, float eta_i, float eta_t) {
    cos_i = clamp(cos_i, 0.0, 1.0);
    float sin_t = eta_i / eta_t * sqrt(max(0.0, 1.0 - cos_i * cos_i));
    if (sin_t >= 1.0) return 1.0;
    float cos_t = sqrt(max(0.0, 1.0 - sin_t * sin_t));
    float rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    float rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

// Snell refraction of direction d at a surface with normal n facing against d; eta = n_i / n_t.
// Returns the zero vector on total internal reflection.
vec3 refract_direction(vec3 d, vec3 n, float eta) {
    return refract(normalize(d), normalize(n), eta);
}

vec3 reflect_direction(vec3 d, vec3 n) {
    return reflect(normalize(d), normalize(n));
}
