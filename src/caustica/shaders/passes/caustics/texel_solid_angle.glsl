// The solid angle of a light-space texel (Shah et al. III-E: a photon carries the light's intensity times
// the solid angle of its texel). A texel of a perspective view or cube face whose ray leaves the light at
// alpha off the view axis subtends A cos^3 alpha, with A its area on the image plane at unit distance and
// c = cos alpha. Used by caustic_light_space.glsl (texel_measure) and impostor_caustic_splat.comp.

// Flux of `intensity` (W/sr) through that texel, multiplied left to right: `precise` keeps the order
// (without it Mesa reorders the product inside a function, which moves images by an ulp).
vec3 texel_flux(vec3 intensity, float unit_area, float c) {
    precise vec3 flux = intensity * unit_area * c * c * c;
    return flux;
}

float texel_solid_angle(float unit_area, float c) {
    return texel_flux(vec3(1.0), unit_area, c).x;
}
