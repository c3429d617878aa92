// Deferred shading's resolve quad: one object's screen rectangle (its bounds projected; the whole
// viewport when they reach behind the eye) at the window depth of the object's key
// (deferred_key.frag), so an EQUAL depth test keeps exactly that object's pixels. Six vertices.
#version 430 core
uniform float deferred_key;   // window depth in [0, 1]
uniform vec4 deferred_rect;   // ndc x0, y0, x1, y1

void main() {
    const ivec2 corners[6] = ivec2[6](ivec2(0, 0), ivec2(1, 0), ivec2(0, 1), ivec2(0, 1), ivec2(1, 0), ivec2(1, 1));
    ivec2 c = corners[gl_VertexID];
    vec2 p = vec2(c.x == 0 ? deferred_rect.x : deferred_rect.z, c.y == 0 ? deferred_rect.y : deferred_rect.w);
    gl_Position = vec4(p, 2.0 * deferred_key - 1.0, 1.0);
}
