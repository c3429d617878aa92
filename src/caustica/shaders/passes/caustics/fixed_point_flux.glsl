// Flux per texel summed in 64-bit fixed point with 32-bit integer atomics (core GL 4.3), so that the
// sums do not depend on the order the adds run in (float atomics round after every add, in whatever
// order the threads come, which can differ from one run to the next). See passes/caustics/fixed_flux.py.
// Layout of flux_words: [0] floatBitsToUint of the largest single add (the bound: a first dispatch
// takes the atomicMax, FLUX_BOUND 1; non-negative floats order as their bit patterns), then for
// accumulator i = (channel * height + y) * width + x the low word at 1 + 2 i and the high at 2 + 2 i.
// One step is 2^(e - 31), e the exponent with bound < 2^e: an add is below 2^31 steps, a step at most
// 2^-30 of the bound. Host defines: none. Uniform: flux_size (the atlas's width and height).
layout(std430, binding = 3) buffer FixedFlux { uint flux_words[]; };
uniform ivec2 flux_size;

const float FLUX_WORD = 4294967296.0;  // 2^32: the high word's weight

// Raise the bound to the largest component of flux (the FLUX_BOUND dispatch).
void flux_bound(vec3 flux) {
    atomicMax(flux_words[0], floatBitsToUint(max(max(flux.r, flux.g), max(flux.b, 0.0))));
}

// The binary exponent of one step (clamped so that steps and their inverse stay normal floats).
int flux_step_exponent() {
    int e;
    frexp(uintBitsToFloat(flux_words[0]), e);
    return clamp(e, -94, 127) - 31;
}

int flux_word(int channel, ivec2 texel) {
    return 1 + 2 * ((channel * flux_size.y + texel.y) * flux_size.x + texel.x);
}

// Add value (>= 0, at most the bound) to one channel of a texel, rounded to the nearest step.
void flux_add(int channel, ivec2 texel, float value, int step_exponent) {
    uint q = uint(ldexp(max(value, 0.0), -step_exponent) + 0.5);
    if (q == 0u) return;
    int i = flux_word(channel, texel);
    uint before = atomicAdd(flux_words[i], q);
    if (before + q < before) atomicAdd(flux_words[i + 1], 1u);  // the low word wrapped: carry
}

// The summed value of one channel of a texel.
float flux_sum(int channel, ivec2 texel, int step_exponent) {
    int i = flux_word(channel, texel);
    return ldexp(float(flux_words[i + 1]) * FLUX_WORD + float(flux_words[i]), step_exponent);
}
