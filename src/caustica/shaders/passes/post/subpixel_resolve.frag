// Subpixel reconstruction of the shaded image from multisampled geometry (passes/post/subpixel.py; Chajed,
// Lefohn and Luebke, "Subpixel Reconstruction Antialiasing for Deferred Shading", I3D 2011, section 3).
// The colour was shaded once per pixel, at its centre; the geometry (labels.frag with ID_DEPTH: object
// id, view depth) was drawn twice, at the centres and at SAMPLES samples per pixel. Each sample takes the
// colour of the pixel centres in the 3 x 3 neighbourhood that saw the same surface: same object, nearest
// depth (those within depth_tolerance of it share the sample), this pixel's own centre first. The pixel
// is the mean of its samples. Where every sample sees this pixel's own surface (the inside of a surface)
// the colour is returned unchanged.
// Host defines: SAMPLES (samples per pixel of the multisampled geometry).
#version 430 core
uniform sampler2D color;              // shaded at pixel centres
uniform sampler2D centre_geometry;    // x: object index + 1 (0: background), y: view depth, at the centres
uniform sampler2DMS sample_geometry;  // the same at SAMPLES samples per pixel
uniform float depth_tolerance;        // a depth within this fraction of the sample's of the best match is as good
in vec2 ndc;
out vec4 reconstructed;

// Whether a centre's geometry g shows the surface of sample s within ``within`` of its depth.
bool shows(vec2 g, vec2 s, float within) { return g.x == s.x && abs(g.y - s.y) <= within; }

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 own = texelFetch(color, pixel, 0);
    vec2 centre = texelFetch(centre_geometry, pixel, 0).xy;
    // The inside of a surface: every sample on this centre's object, the colour as it is
    vec2 samples[SAMPLES];
    bool inside = true;
    for (int s = 0; s < SAMPLES; ++s) {
        samples[s] = texelFetch(sample_geometry, pixel, s).xy;
        inside = inside && shows(centre, samples[s], depth_tolerance * samples[s].y);
    }
    if (inside) {
        reconstructed = own;
        return;
    }
    // Read the centres around this pixel (index 4: the pixel itself)
    ivec2 last = textureSize(color, 0) - 1;
    vec2 around[9];
    ivec2 at[9];
    for (int n = 0; n < 9; ++n) {
        at[n] = clamp(pixel + ivec2(n % 3 - 1, n / 3 - 1), ivec2(0), last);
        around[n] = texelFetch(centre_geometry, at[n], 0).xy;
    }
    // Give each sample's weight to the centres that saw its surface
    float weights[9] = float[9](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (int s = 0; s < SAMPLES; ++s) {
        float best = 1e30;
        for (int n = 0; n < 9; ++n)
            if (around[n].x == samples[s].x) best = min(best, abs(around[n].y - samples[s].y));
        float within = best + depth_tolerance * samples[s].y;
        if (best == 1e30 || shows(around[4], samples[s], within)) {
            weights[4] += 1.0;  // this pixel's surface, or one no centre nearby saw
            continue;
        }
        float matches = 0.0;
        for (int n = 0; n < 9; ++n) matches += shows(around[n], samples[s], within) ? 1.0 : 0.0;
        for (int n = 0; n < 9; ++n) weights[n] += shows(around[n], samples[s], within) ? 1.0 / matches : 0.0;
    }
    vec4 sum = vec4(0.0);
    for (int n = 0; n < 9; ++n)
        if (weights[n] > 0.0) sum += weights[n] * texelFetch(color, at[n], 0);
    reconstructed = sum / float(SAMPLES);
}
