"""Order-independent flux sums for the compute splats: 64-bit fixed point with integer atomics.

Float atomics (imageAtomicAdd on r32f, GL_NV_shader_atomic_float) round after
every add, and the order of the adds follows the scheduling of the shader
threads, so the sums can differ by float ulps from one run to the next.
Integer addition is associative, so here each add is
rounded once, to a fixed-point step, and the steps are summed exactly: the same
inputs give the same bytes in any order (``shaders/passes/caustics/fixed_point_flux.glsl``,
core GL 4.3 atomics on an SSBO of uints, resolved back into three r32f textures).

Scale: a first dispatch of the splat (``FLUX_BOUND`` 1) takes the largest single
add B on the GPU (atomicMax on the float bits; no readback). One step is
2^(e - 31) with B < 2^e: an add is below 2^31 steps, and a step is at most 2^-30
(about 1e-9) of B, B at most the brightest photon's flux, so each add is off by
at most half of that, well below float32's own rounding (6e-8). Overflow: a
photon adds at most B to any texel (the splat kernels are normalised), so a
texel holds less than N 2^31 steps for N photons, and the two 32-bit words (low,
high by carry) hold 2^64 steps: safe for up to 2^33 (8.6e9) photons, far above
any photon grid here (512^2 x 3 channels < 2^20). The point-sprite splat needs
none of this: blending follows primitive order (a GL rule), so it is
deterministic as it is.
"""
from __future__ import annotations

from ...gpu.meshes import set_uniform
from ...gpu.shaders import run_compute
from ...render.bindings import STORAGE_BINDINGS

CHANNELS = 3


def splat_fixed_point(frame, size: tuple[int, int], dispatch) -> list:
    """Three pooled r32f textures of ``size`` (R, G, B) holding the flux that ``dispatch`` splats.

    ``dispatch(bind, bound)`` runs the caller's splat shader(s), built with
    ``FLUX_BOUND`` = ``bound``, each after ``bind(program)``: first with bound 1
    (the shaders only raise the bound, ``flux_bound``), then with 0 (``flux_add``).
    """
    ctx = frame.gpu.ctx
    width, height = int(size[0]), int(size[1])
    with frame.scoped(ctx.buffer(reserve=4 * (1 + 2 * CHANNELS * width * height))) as words:
        return _splat(frame, words, width, height, dispatch)


def _splat(frame, words, width: int, height: int, dispatch) -> list:
    """splat_fixed_point into the cleared ``words`` buffer."""
    ctx = frame.gpu.ctx
    words.clear()

    def bind(program) -> None:
        words.bind_to_storage_buffer(STORAGE_BINDINGS["fixed_point_flux"])
        set_uniform(program, "flux_size", (width, height))

    # Bound, then adds: every add of the second dispatch sees the final bound.
    for bound in (1, 0):
        dispatch(bind, bound)
        ctx.memory_barrier()
    # Resolve the sums into float textures.
    textures = [frame.texture((width, height), "r32f") for _ in range(CHANNELS)]
    program = frame.gpu.shaders.compute("passes/caustics/fixed_point_resolve.comp")
    bind(program)
    for unit, texture in enumerate(textures):
        texture.bind_to_image(unit, read=False, write=True)
    run_compute(program, (width + 7) // 8, (height + 7) // 8)
    ctx.memory_barrier()
    return textures
