// Impostor texture (Hu and Qin, TVCG 2007, 2.2.1) or Wyman's nearby-geometry view: radiance and the
// depth of the surface each texel sees, packed into one rgba32f texture (a = 0: empty).
// Host defines: none. Uniforms: color, depth (the rendering's colour and depth buffers),
// world_from_clip, origin, axis, radial (1: a = distance from origin; 0: a = depth along axis),
// cell (the texel offset of the viewport: an impostor's square in its reflector's atlas).
#version 430 core
uniform sampler2D color;
uniform sampler2D depth;
uniform mat4 world_from_clip;
uniform vec3 origin;
uniform vec3 axis;
uniform int radial;
uniform ivec2 cell;
in vec2 ndc;
out vec4 texel_out;

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy) - cell;
    float z = texelFetch(depth, texel, 0).r;
    if (z >= 1.0) {
        texel_out = vec4(0.0);
        return;
    }
    vec4 p = world_from_clip * vec4(ndc, 2.0 * z - 1.0, 1.0);
    vec3 world = p.xyz / p.w;
    float d = radial != 0 ? length(world - origin) : dot(world - origin, axis);
    texel_out = vec4(texelFetch(color, texel, 0).rgb, max(d, 1e-6));
}
