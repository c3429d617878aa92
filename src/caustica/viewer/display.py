"""Drawing textures into the window: tone mapping, channel views and the difference view.

A linear color texture is shown as ``caustica render`` writes PNGs (2**exposure,
the tone curve of ``--tonemap``: clip or filmic, exact sRGB curve), pixel for
pixel when the texture is the view's size (times the supersampling factor,
averaged k x k like the renderer's box filter). Any other texture (shadow maps,
caustic maps) is letterboxed. The filmic curve's constants are images.py's,
written into the shader source, so the window and the PNGs share one definition.
"""
from __future__ import annotations

import numpy as np

from ..images import ACES_FIT, FILMIC_INPUT_SCALE, TONEMAPS

MODES = ("color", "signed", "range", "difference")  # how a texture's values become colours
_LAYER = len(MODES)  # internal mode: the premultiplied UI layer (ui_layer.py), blended over the window
# The shader's filmic input cap: images.filmic caps at 1e30 for float64; in float32 y * y must stay finite
# (< 3.4e38). In float32 the curve is within one step of 1.0 from y ~ 1e6 on, so the cap changes no 8-bit code.
_GLSL_FILMIC_INPUT_MAX = 1e15


def _filmic_defines() -> str:
    """images.filmic's constants as GLSL defines (repr: the shortest text that reads back as the same double)."""
    names = ("ACES_A", "ACES_B", "ACES_C", "ACES_D", "ACES_E")
    values = {**dict(zip(names, ACES_FIT)), "FILMIC_INPUT_SCALE": float(FILMIC_INPUT_SCALE),
              "FILMIC_INPUT_MAX": _GLSL_FILMIC_INPUT_MAX}
    return "".join(f"#define {name} {float(value)!r}\n" for name, value in values.items())

_VERTEX = """
#version 430
void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
"""

# Compiled once per (MODE, FIT, K, TONEMAP): a CPU rasterizer runs every side of a branch, even a uniform one.
_FRAGMENT = """
#version 430
// MODE: 0 color, 1 signed (x/2 + 1/2), 2 range (x - lo) / (hi - lo), 3 |a - b| * gain, 4 UI layer.
// FIT 1: the texture holds K x K samples per view pixel (box average); FIT 0: letterboxed lookup.
// TONEMAP (MODE 0): 0 clip, 1 filmic (images.filmic; ACES_* and FILMIC_* are defined from images.py).
uniform sampler2D image_a;
uniform sampler2D image_b;
uniform int components;      // of image_a: 1 grey, 2 (r, g, 0), 3/4 rgb
uniform ivec2 origin;        // the view's lower-left corner in window pixels
uniform ivec2 view_size;
uniform float exposure;
uniform vec2 value_range;
uniform float gain;
out vec4 frag_color;

vec3 srgb(vec3 x) {
    x = clamp(x, 0.0, 1.0);
    return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), x));
}

// images.filmic: Narkowicz's ACES fit divided by its asymptote, the input pre-scaled so 0.18 stays 0.18.
vec3 filmic(vec3 x) {
    vec3 y = min(max(x, 0.0) * FILMIC_INPUT_SCALE, FILMIC_INPUT_MAX);
    return y * (ACES_A * y + ACES_B) / (y * (ACES_C * y + ACES_D) + ACES_E) * (ACES_C / ACES_A);
}

vec3 tone_map(vec3 x) {
#if TONEMAP == 1
    return filmic(x);
#else
    return clamp(x, 0.0, 1.0);
#endif
}

vec3 expand(vec4 v) {
    if (components == 1) return v.rrr;
    if (components == 2) return vec3(v.rg, 0.0);
    return v.rgb;
}

// The pixel's value: a K x K box average when the texture matches the view, else a letterboxed lookup.
vec4 sample_pixel(sampler2D image, ivec2 pixel, out bool inside) {
    inside = true;
#if FIT
    vec4 sum = vec4(0.0);
    for (int j = 0; j < K; ++j)
        for (int i = 0; i < K; ++i)
            sum += texelFetch(image, pixel * K + ivec2(i, j), 0);
    return sum / float(K * K);
#else
    ivec2 size = textureSize(image, 0);
    float scale = min(float(view_size.x) / float(size.x), float(view_size.y) / float(size.y));
    vec2 shown = vec2(size) * scale;
    vec2 uv = (vec2(pixel) + 0.5 - (vec2(view_size) - shown) * 0.5) / shown;
    inside = all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)));
    return textureLod(image, uv, 0.0);
#endif
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy) - origin;
#if MODE == 4
    // The UI layer (window-sized): ImGui blended over a cleared target, so colour is premultiplied, alpha a * a.
    vec4 layer = texelFetch(image_a, ivec2(gl_FragCoord.xy), 0);
    if (layer.a <= 0.0) discard;
    frag_color = vec4(layer.rgb, sqrt(layer.a));
    return;
#endif
    bool inside;
    vec3 a = expand(sample_pixel(image_a, pixel, inside));
    if (!inside) { frag_color = vec4(0.08, 0.08, 0.09, 1.0); return; }
#if MODE == 0
    vec3 shown = srgb(tone_map(a * exp2(exposure)));
#elif MODE == 1
    vec3 shown = clamp(a * 0.5 + 0.5, 0.0, 1.0);
#elif MODE == 2
    vec3 shown = clamp((a - value_range.x) / max(value_range.y - value_range.x, 1e-20), 0.0, 1.0);
#else
    bool inside_b;
    vec3 b = sample_pixel(image_b, pixel, inside_b).rgb;
    vec3 shown = srgb(abs(a - b) * exp2(exposure) * gain);
#endif
    frag_color = vec4(shown, 1.0);
}
"""


def auto_mode(name: str, texture) -> str:
    """The natural view of a channel: directions and normals signed, depths and distances ranged."""
    lowered = name.lower()
    if any(word in lowered for word in ("normal", "direction")):
        return "signed"
    if texture.depth or texture.components <= 2 or any(w in lowered for w in ("depth", "distance", "shadow", "dn")):
        return "range"
    return "color"


def value_range(texture) -> tuple[float, float]:
    """The 1st and 99th percentiles of a texture's finite values below 1e19 (backgrounds hold huge ones)."""
    if texture.depth:
        data = np.frombuffer(texture.read(), dtype="f4")
    else:
        data = np.frombuffer(texture.read(), dtype=texture.dtype if texture.dtype in ("f4", "f2") else "u1")
        data = data.reshape(-1, texture.components)[:, : min(3, texture.components)].ravel().astype("f4")
    data = data[np.isfinite(data) & (np.abs(data) < 1e19)]
    if data.size == 0:
        return 0.0, 1.0
    low, high = np.percentile(data, [1.0, 99.0])
    return float(low), float(high if high > low else low + 1.0)


class Display:
    """Shader variants, each with an empty vertex array: each call draws a texture into a rectangle of the window."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.programs: dict[tuple[int, int, int, int], tuple] = {}  # key -> (program, its empty vertex array)

    def variant(self, mode: int, fit: bool, k: int, tonemap: str = "clip"):
        """The variant for ``mode`` (index in MODES), a view-sized texture of k x k samples or a letterbox,
        and (colour mode only) the tone curve ``tonemap`` (one of images.TONEMAPS)."""
        key = (mode, int(fit), k if fit else 1, TONEMAPS.index(tonemap) if mode == 0 else 0)
        if key not in self.programs:
            header = (f"#version 430\n#define MODE {key[0]}\n#define FIT {key[1]}\n#define K {key[2]}\n"
                      f"#define TONEMAP {key[3]}\n{_filmic_defines()}")
            program = self.ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT.replace("#version 430\n", header, 1))
            self.programs[key] = (program, self.ctx.vertex_array(program, []))
        return self.programs[key]

    def draw(self, texture, rect: tuple[int, int, int, int], mode: str = "color", exposure: float = 0.0,
             supersampling: int = 1, values: tuple[float, float] = (0.0, 1.0), other=None, gain: float = 4.0,
             tonemap: str = "clip") -> None:
        """Draw ``texture`` into ``rect`` (x, y from the window's lower left, width, height); ``tonemap`` is the
        colour mode's tone curve after the exposure (images.TONEMAPS; the other modes ignore it)."""
        x, y, width, height = (int(v) for v in rect)
        if width <= 0 or height <= 0:
            return
        k = int(supersampling)
        layer = mode == "layer"  # reads the window-sized layer at each pixel: neither fit nor k applies
        fit = not layer and tuple(texture.size) == (width * k, height * k)
        program, vao = self.variant(_LAYER if layer else MODES.index(mode), fit, k, tonemap)
        screen = self.ctx.screen
        screen.use()
        screen.viewport = (x, y, width, height)
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND | self.ctx.CULL_FACE)
        compare = texture.compare_func if texture.depth else None
        if texture.depth:
            texture.compare_func = ""  # read depths as values, not as shadow comparisons
        texture.use(0)
        (other if other is not None else texture).use(1)
        values_of = {"image_a": 0, "image_b": 1, "components": texture.components, "origin": (x, y),
                     "view_size": (width, height), "exposure": float(exposure),
                     "value_range": tuple(float(v) for v in values), "gain": float(gain)}
        for name, value in values_of.items():
            if name in program:
                program[name].value = value
        if layer:
            self.ctx.enable(self.ctx.BLEND)
            self.ctx.blend_func = self.ctx.ONE, self.ctx.ONE_MINUS_SRC_ALPHA
        vao.render(vertices=3)
        if layer:
            self.ctx.disable(self.ctx.BLEND)
            self.ctx.blend_func = self.ctx.SRC_ALPHA, self.ctx.ONE_MINUS_SRC_ALPHA
        if compare is not None:
            texture.compare_func = compare

    def release(self) -> None:
        for program, vao in self.programs.values():
            vao.release()
            program.release()
        self.programs.clear()
