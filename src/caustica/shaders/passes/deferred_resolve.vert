// Deferred shading's resolve triangle: covers the viewport at the window depth of one object's
// key (deferred_key.frag), so an EQUAL depth test keeps exactly that object's pixels.
#version 430 core
uniform float deferred_key;  // window depth in [0, 1]

void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2) * 2.0 - 1.0;
    gl_Position = vec4(p, 2.0 * deferred_key - 1.0, 1.0);
}
