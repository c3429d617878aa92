// Equirectangular environment lookup with Mitsuba 3's mapping: u = atan2(d.x, -d.z) / 2pi mod 1,
// v = acos(d.y) / pi, row 0 at +Y (the texture is uploaded top row first, so row 0 sits at t = 0).
// Columns are sampled at u * W - 0.5 (wrapping), rows at v * (H - 1): the texture coordinate below
// places them there.
//
// Environment.filter "footprint" (a mipmapped texture, gpu/device.py): each lookup is the mean over the
// directions the pixel covers (docs/antialiasing.md, "Footprint-filtered environment"). The screen-space
// derivatives of the direction (ray differentials, Igehy 1999, taken from the quad's neighbours) map to
// (u, t) by the chain rule; the analytic gradient of u does not see the seam where u wraps, which
// implicit derivatives of (u, t) would blur. "bilinear" (one level): one bilinear sample, as Mitsuba
// takes per sample. Fragment stages only (derivatives).
#ifdef GL_ARB_derivative_control  // enabled by the shader library (gpu/shaders.py)
#define ENVIRONMENT_DFDX dFdxFine
#define ENVIRONMENT_DFDY dFdyFine
#else
#define ENVIRONMENT_DFDX dFdx
#define ENVIRONMENT_DFDY dFdy
#endif
const float PI = 3.14159265358979;
const int ENVIRONMENT_TAPS = 8;            // most lookups along a footprint's longer side
const float ENVIRONMENT_LOD_SCALE = 0.5;   // gradients as GL's level of detail takes them, against a box
const float ENVIRONMENT_MAGNIFICATION_MAX = 13.0;  // most radians between neighbours' directions per pixel angle
uniform float environment_pixel_angle;  // radians a pixel subtends at the image centre (0: no filtering)
int environment_taps_limit = ENVIRONMENT_TAPS;  // a shader lowers it for lookups whose light weighs little

// The mean of the texture over the parallelogram (u, t) + a gradient_x + b gradient_y, |a|, |b| <= 1/2:
// taps along its longer side, each a trilinear lookup as wide as the shorter side and its own share of
// the longer (anisotropic filtering, done here: llvmpipe's GL_EXT_texture_filter_anisotropic
// mis-filters textureGrad). A mip level's bilinear tent spans about twice the footprint GL's level of
// detail names, hence ENVIRONMENT_LOD_SCALE.
vec3 environment_footprint(sampler2D environment, vec2 uv, vec2 gradient_x, vec2 gradient_y) {
    vec2 size = vec2(textureSize(environment, 0));
    float length_x = length(gradient_x * size), length_y = length(gradient_y * size);
    vec2 major = length_x >= length_y ? gradient_x : gradient_y;
    vec2 minor = length_x >= length_y ? gradient_y : gradient_x;
    float ratio = max(length_x, length_y) / max(min(length_x, length_y), 1.0);
    int taps = int(clamp(ceil(ratio), 1.0, float(min(environment_taps_limit, ENVIRONMENT_TAPS))));
    vec3 sum = vec3(0.0);
    for (int i = 0; i < taps; ++i) {
        vec2 offset = ((float(i) + 0.5) / float(taps) - 0.5) * major;
        sum += textureGrad(environment, uv + offset, minor * ENVIRONMENT_LOD_SCALE,
                           major * (ENVIRONMENT_LOD_SCALE / float(taps))).rgb;
    }
    return sum / float(taps);
}

// A screen derivative of the looked-up direction, shortened to `cap` radians where it is longer (a NaN or
// infinite one: no footprint). A neighbour that far off is a discontinuity (another bounce, total internal
// reflection, a rim), or a curved surface that magnifies more than the cap (a small ball or a thin log far
// away): either way the pixel covers at least the cap's worth of directions, so that axis is filtered over
// it, not left to alias. A footprint kept within the cap spreads a bright sun at a ball's rim less
// (docs/antialiasing.md). A neighbour on another object within the cap is kept: at an outline the wider
// footprint stands in for the pixel's mix of the two.
vec3 capped_derivative(vec3 derivative, float cap) {
    float span = length(derivative);
    if (span <= cap) return derivative;
    return span < 1e30 ? derivative * (cap / span) : vec3(0.0);
}

// The mapping's (u, v) of the unit direction d, and its inverse.
vec2 equirect_uv(vec3 d) {
    return vec2(fract(atan(d.x, -d.z) / (2.0 * PI)), acos(clamp(d.y, -1.0, 1.0)) / PI);
}

vec3 equirect_direction(vec2 uv) {
    float phi = 2.0 * PI * uv.x, theta = PI * uv.y;
    return vec3(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi));
}

// The texture coordinate of mapping coordinate v in an image of ``rows`` rows (rows at v * (rows - 1)).
float equirect_row_coordinate(float v, float rows) { return (v * (rows - 1.0) + 0.5) / rows; }

vec3 environment_radiance(sampler2D environment, vec3 d) {
    d = normalize(d);
    vec2 size = vec2(textureSize(environment, 0));
    vec2 uv = equirect_uv(d);
    float u = uv.x, v = uv.y;
    float t = equirect_row_coordinate(v, size.y);
    if (textureQueryLevels(environment) == 1) return textureLod(environment, vec2(u, t), 0.0).rgb;  // bilinear
    // d(atan2(x, -z)) = (x dz - z dx) / (x^2 + z^2); d(acos y) = -dy / sqrt(1 - y^2).
    float horizontal = max(d.x * d.x + d.z * d.z, 1e-8);
    vec2 per_xz = vec2(d.z, -d.x) * (-1.0 / (2.0 * PI * horizontal));   // du = dot(per_xz, (dx, dz))
    float per_y = -(size.y - 1.0) / (size.y * PI * sqrt(horizontal));   // dt = per_y * dy
    // Fine derivatives: each pixel's own row and column of its quad (coarse ones share one for the quad,
    // which makes a mirrored view filter differently from its mirror image).
    vec3 ddx = ENVIRONMENT_DFDX(d), ddy = ENVIRONMENT_DFDY(d);
    ddx = capped_derivative(ddx, ENVIRONMENT_MAGNIFICATION_MAX * environment_pixel_angle);
    ddy = capped_derivative(ddy, ENVIRONMENT_MAGNIFICATION_MAX * environment_pixel_angle);
    vec2 gradient_x = vec2(dot(per_xz, ddx.xz), per_y * ddx.y);
    vec2 gradient_y = vec2(dot(per_xz, ddy.xz), per_y * ddy.y);
    return environment_footprint(environment, vec2(u, t), gradient_x, gradient_y);
}

// The prefiltered environment (passes/shading/prefiltered.py): ``levels`` equirect images stacked top to
// bottom in one texture, level k the environment convolved with GGX's lobe about the mirror direction at
// roughness k / (levels - 1) (the split-sum's first factor, Karis 2013); a lookup blends the two levels
// about ``roughness``, each bilinear within its own rows.
vec3 prefiltered_level(sampler2D atlas, int levels, int level, vec2 uv) {
    vec2 size = vec2(textureSize(atlas, 0));
    float rows = size.y / float(levels);
    float t = (float(level) * rows + uv.y * (rows - 1.0) + 0.5) / size.y;
    return textureLod(atlas, vec2(uv.x, t), 0.0).rgb;
}

vec3 prefiltered_radiance(sampler2D atlas, int levels, vec3 d, float roughness) {
    vec2 uv = equirect_uv(normalize(d));
    float level = clamp(roughness, 0.0, 1.0) * float(levels - 1);
    int below = min(int(level), levels - 2);
    return mix(prefiltered_level(atlas, levels, below, uv), prefiltered_level(atlas, levels, below + 1, uv),
               level - float(below));
}
