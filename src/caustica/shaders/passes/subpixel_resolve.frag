// Subpixel reconstruction of the shaded image from multisampled geometry (passes/subpixel.py; Chajed,
// Lefohn and Luebke, "Subpixel Reconstruction Antialiasing for Deferred Shading", I3D 2011, section 3).
// The colour was shaded once per pixel, at its centre; the geometry (labels.frag: object id, view depth)
// was drawn twice, at the centres and at SAMPLES samples per pixel. Each sample takes the colour of the
// pixel centre in the 3 x 3 neighbourhood that saw the same surface: same object, nearest depth, this
// pixel's own centre first. The pixel is the mean of its samples. Where every sample sees this pixel's
// own surface (the interior of a surface) the colour is returned unchanged.
// Host defines: SAMPLES (samples per pixel of the multisampled geometry).
#version 430 core
uniform sampler2D color;            // shaded at pixel centres
uniform sampler2D centre_surface;   // labels.frag at the centres: w view depth (0: background)
uniform sampler2D centre_ids;       // x: object index + 1 (0: background)
uniform sampler2DMS sample_surface; // the same at SAMPLES samples per pixel
uniform sampler2DMS sample_ids;
uniform float depth_tolerance;      // a depth within this fraction of the best match is as good
in vec2 ndc;
out vec4 reconstructed;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    ivec2 last = textureSize(color, 0) - 1;
    // Read the centres' surfaces around this pixel (index 4: the pixel itself)
    float ids[9];
    float depths[9];
    ivec2 at[9];
    for (int n = 0; n < 9; ++n) {
        at[n] = clamp(pixel + ivec2(n % 3 - 1, n / 3 - 1), ivec2(0), last);
        ids[n] = texelFetch(centre_ids, at[n], 0).x;
        depths[n] = texelFetch(centre_surface, at[n], 0).w;
    }
    // Give each sample's weight to the centres that saw its surface
    float weights[9] = float[9](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (int s = 0; s < SAMPLES; ++s) {
        float id = texelFetch(sample_ids, pixel, s).x;
        float depth = texelFetch(sample_surface, pixel, s).w;
        float best = 1e30;
        for (int n = 0; n < 9; ++n)
            if (ids[n] == id) best = min(best, abs(depths[n] - depth));
        float within = best + depth_tolerance * depth;
        if (best == 1e30 || (ids[4] == id && abs(depths[4] - depth) <= within)) {
            weights[4] += 1.0;  // this pixel's surface, or one no centre nearby saw
            continue;
        }
        float matches = 0.0;
        for (int n = 0; n < 9; ++n)
            if (ids[n] == id && abs(depths[n] - depth) <= within) matches += 1.0;
        for (int n = 0; n < 9; ++n)
            if (ids[n] == id && abs(depths[n] - depth) <= within) weights[n] += 1.0 / matches;
    }
    // The interior of a surface: the shaded colour as it is
    vec4 own = texelFetch(color, pixel, 0);
    if (weights[4] == float(SAMPLES)) {
        reconstructed = own;
        return;
    }
    vec4 sum = vec4(0.0);
    for (int n = 0; n < 9; ++n)
        if (weights[n] > 0.0) sum += weights[n] * texelFetch(color, at[n], 0);
    reconstructed = sum / float(SAMPLES);
}
