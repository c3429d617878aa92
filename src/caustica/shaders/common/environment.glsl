// Equirectangular environment lookup with Mitsuba 3's mapping and bilinear sampling:
// u = atan2(d.x, -d.z) / 2pi mod 1, v = acos(d.y) / pi, row 0 at +Y (the texture is
// uploaded top row first, so row 0 sits at t = 0). Columns are sampled at u * W - 0.5
// (wrapping), rows at v * (H - 1): the texture coordinate below places them there.
const float PI = 3.14159265358979;

vec3 environment_radiance(sampler2D environment, vec3 d) {
    d = normalize(d);
    vec2 size = vec2(textureSize(environment, 0));
    float u = fract(atan(d.x, -d.z) / (2.0 * PI));
    float v = acos(clamp(d.y, -1.0, 1.0)) / PI;
    float t = (v * (size.y - 1.0) + 0.5) / size.y;
    return texture(environment, vec2(u, t)).rgb;
}
