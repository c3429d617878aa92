// Footprint splats (passes/caustics/light_space.py, SplatPhotons with photons on a grid): each photon's Gaussian is
// shaped by the area its grid cell lands on. Shape a = (A_xx, A_xy, A_yy), the inverse covariance in
// caustic-map texels; the kernel is exp(-m / 2), m = d^T A d, cut at m = FOOTPRINT_CUT^2 (3 sigma: the
// 2-sigma cut of splat_kernel jumps by e^-2 at its edge, and that edge alone beats as a moire against
// the texels where the photons lie about a texel apart). caustic_footprint.comp makes the shapes and
// each photon's normaliser; caustic_splat.comp and the point sprites (caustic_splat.vert/.frag) read them.
#define FOOTPRINT_CUT 3.0

float footprint_kernel(vec2 c, vec2 texel_centre, vec3 a) {
    vec2 d = texel_centre - c;
    float m = a.x * d.x * d.x + 2.0 * a.y * d.x * d.y + a.z * d.y * d.y;
    return m < FOOTPRINT_CUT * FOOTPRINT_CUT ? exp(-0.5 * m) : 0.0;
}

// Texels either side of floor(c) that the kernel can reach, per axis: the ellipse m = cut^2 lies within
// r = cut sqrt(Sigma_xx) (and cut sqrt(Sigma_yy)) of c (Sigma = A^-1), so a texel q off floor(c), its centre
// at least |q| - 1/2 from c, lies outside once |q| > r + 1/2.
ivec2 footprint_reach(vec3 a) {
    float det = max(a.x * a.z - a.y * a.y, 1e-30);
    return ivec2(floor(FOOTPRINT_CUT * sqrt(vec2(a.z, a.x) / det) + 0.5));
}

// The texel columns q (off floor(c).x) of row j (off floor(c).y) whose centres may lie inside the ellipse
// (x: first, y: last; first > last where none does): the row's chord, widened by a texel for rounding.
// Loops over these rows and columns visit the ellipse, not its bounding box (a footprint stretched along
// a diagonal fills a small part of the box).
ivec2 footprint_row(vec2 c, int j, vec3 a, int reach_x) {
    float dy = floor(c.y) + float(j) + 0.5 - c.y;
    float disc = a.y * a.y * dy * dy - a.x * (a.z * dy * dy - FOOTPRINT_CUT * FOOTPRINT_CUT);
    if (disc < 0.0) return ivec2(1, 0);
    float root = sqrt(disc), offset = c.x - floor(c.x) - 0.5;
    int first = int(floor((-a.y * dy - root) / a.x + offset)) - 1;
    int last = int(ceil((-a.y * dy + root) / a.x + offset)) + 1;
    return ivec2(max(first, -reach_x), min(last, reach_x));
}

// Whether texel `texel` lies in the box footprint_reach gives around the photon at pixel c.
bool footprint_covers(vec2 c, ivec2 texel, ivec2 reach) {
    return all(lessThanEqual(abs(texel - ivec2(floor(c))), reach));
}
