// Direct light on diffuse receivers with shadow maps, plus unoccluded ambient from the
// environment's SH irradiance. Host defines: MAX_LIGHTS (passes/shading/shadows.py sets it; 8 here alone);
// LIGHT_POINT, _DIRECTIONAL, _SPOT (scene/codes.py: light_type's codes; the shader library sets them
// in every program).
#ifndef MAX_LIGHTS
#define MAX_LIGHTS 8
#endif

uniform int light_count;
uniform int light_type[MAX_LIGHTS];
uniform vec3 light_position[MAX_LIGHTS];
uniform vec3 light_direction[MAX_LIGHTS];      // travel direction (directional, spot axis)
uniform vec3 light_intensity[MAX_LIGHTS];      // W/sr (point, spot) or irradiance (directional)
uniform vec2 light_cone_cos[MAX_LIGHTS];       // spot: cos(inner), cos(outer)
uniform mat4 light_clip_from_world[MAX_LIGHTS]; // directional and spot shadow projection
uniform sampler2D shadow_map[MAX_LIGHTS];      // r32f: distance to the light (atlas of 6 faces for points)
uniform vec3 cube_forward[6];
uniform vec3 cube_up[6];
uniform float shadow_bias;                     // normal offset, in the map's texels at the receiver
uniform vec3 irradiance_sh[9];

// Shadows: a 3x3 percentage-closer filter against the receiver plane (the tangent plane at p, normal n).
// A texel stores the distance to the nearest surface along its own ray from the light, so each tap
// compares it with where that ray meets the receiver plane, not with p's distance: a receiver sloped away
// from the light then agrees with every tap at any angle. (A constant bias does not: at grazing angles
// the plane's distance changes by more than the bias across one texel, and floors shadowed themselves
// in stripes.) The plane is first moved shadow_bias texel widths along n (a normal offset), which covers
// rounding, the rasterizer's sub-texel snapping and the shading normal's departure from the mesh's
// facets; as the offset is along n, the point still sees an occluder resting on the surface, so contact
// shadows stay attached. A tap is shadowed only by a surface nearer the light than the receiver itself:
// at the foot of a wall that faces the light, the wall hides the plane's continuation behind it, not
// the receiver, and the corner stays lit.

// Which face of the point-light atlas a direction falls on, and its [0,1]^2 coordinates.
vec2 cube_atlas_uv(vec3 v, out int face) {
    vec3 a = abs(v);
    if (a.x >= a.y && a.x >= a.z) face = v.x > 0.0 ? 0 : 1;
    else if (a.y >= a.z) face = v.y > 0.0 ? 2 : 3;
    else face = v.z > 0.0 ? 4 : 5;
    vec3 f = cube_forward[face], up = cube_up[face], r = cross(f, up);
    float depth = dot(v, f);
    return vec2(dot(v, r), dot(v, up)) / depth * 0.5 + 0.5;
}

// Fraction of light i that reaches p (normal n, facing the light): map_visibility of its map, which
// also serves the environment's lobes (an atlas of directional maps, tile k from column k N).
//
// Each map is N x N texels (a cube face of the point atlas: N x N from column x0). Texel t's ray, s its
// centre in ndc, is axis + s.x a + s.y b with axis, a, b orthogonal and axis unit: from the light for
// perspective maps (point faces, spot; the metric is the distance from the light), from q + (s - s_q).x a
// + (s - s_q).y b for the orthographic (directional) one (the metric is q's plus the distance along axis).
// Where it meets the plane (q, n), the metric is, with s.V = s.x V.x + s.y V.y,
//     expected = (P + s.U) sqrt(1 + s^2.W) / (dot(axis, n) + s.V)
// perspective: P = dot(q - light, n), U = 0, W = (a.a, b.b), V = (a.n, b.n);
// orthographic: P = m_q dot(axis, n) + s_q.V', U = -V', V' = (a.n, b.n), W = V = 0.
// The denominator is negative where the ray meets the plane from the light's side (the numerator too),
// so the tap is lit when stored * den <= num * sqrt(..) there, and wherever stored >= m_q (q's metric).
// One receiver's lookup in a map: its 3x3 taps around texel c of tile x0, each lit (tap_lit) when the
// stored metric passes the receiver-plane test above. outside >= 0: q falls outside a directional or spot
// map, whose visibility is then outside (1 or 0) and no tap is read.
struct MapLookup { int N, x0; ivec2 c; float P, an, m_q, outside; vec2 U, V, W; };

MapLookup map_lookup(int N, int tile, int type, vec3 light, vec3 direction, mat4 m, vec3 p, vec3 n) {
    MapLookup l;
    l.N = N;
    l.outside = -1.0;
    float width;                 // a texel's width at the receiver
    vec3 axis, a, b;
    bool point = type == LIGHT_POINT, ortho = type == LIGHT_DIRECTIONAL;
    if (point) {
        // A face's texel spans 2 / N in tangent at unit depth: about 2 dist / N wide at the receiver.
        width = 2.0 * length(p - light) / float(N);
    } else {
        // Rows of clip_from_world: x, y are (the light's right, up) / (half width at unit depth, or half
        // width); w is the view axis (spot) or (0, 0, 0, 1) (directional). a, b: world per unit of ndc.
        vec3 row_x = vec3(m[0][0], m[1][0], m[2][0]), row_y = vec3(m[0][1], m[1][1], m[2][1]);
        a = row_x / dot(row_x, row_x);
        b = row_y / dot(row_y, row_y);
        axis = ortho ? direction : vec3(m[0][3], m[1][3], m[2][3]);
        width = 2.0 * length(a) / float(N) * (ortho ? 1.0 : length(p - light));
    }
    vec3 q = p + n * (shadow_bias * width);
    l.x0 = tile * N;  // a directional or spot map's tile in an atlas of N x N tiles
    vec2 s_q;
    if (point) {
        int face;
        s_q = cube_atlas_uv(q - light, face) * 2.0 - 1.0;
        axis = cube_forward[face];
        b = cube_up[face];
        a = cross(axis, b);
        l.x0 = face * N;
    } else {
        vec4 clip = m * vec4(q, 1.0);
        s_q = clip.xy / clip.w;
        if (any(greaterThan(abs(s_q), vec2(1.0)))) l.outside = ortho ? 1.0 : 0.0;
    }
    l.m_q = ortho ? dot(q - light, axis) : length(q - light);
    l.an = dot(axis, n);
    vec2 v = vec2(dot(a, n), dot(b, n));
    l.P = ortho ? l.m_q * l.an + dot(s_q, v) : dot(q - light, n);
    l.U = ortho ? -v : vec2(0.0);
    l.W = ortho ? vec2(0.0) : vec2(dot(a, a), dot(b, b));
    l.V = ortho ? vec2(0.0) : v;
    l.c = clamp(ivec2(floor((s_q * 0.5 + 0.5) * float(N))), ivec2(0), ivec2(N - 1));
    return l;
}

// Tap (x, y) of the 3x3 around l.c: its texel in the map (the atlas's column x0 + t.x).
ivec2 map_tap(MapLookup l, int x, int y) {
    ivec2 t = clamp(l.c + ivec2(x, y), ivec2(0), ivec2(l.N - 1));
    return ivec2(l.x0 + t.x, t.y);
}

// The tap at texel ``texel`` (map_tap): where its ray meets the receiver plane, as (den, num) of the
// comparison above (num: (P + s.U) sqrt(1 + s^2.W)).
vec2 tap_plane(MapLookup l, ivec2 texel) {
    vec2 s = (vec2(texel.x - l.x0, texel.y) + 0.5) * (2.0 / float(l.N)) - 1.0;
    return vec2(l.an + dot(s, l.V), (l.P + dot(s, l.U)) * sqrt(1.0 + dot(s * s, l.W)));
}

// Whether a tap (its tap_plane) storing ``stored`` leaves the receiver lit.
bool tap_lit(MapLookup l, vec2 plane, float stored) {
    return (plane.x < 0.0 && stored * plane.x <= plane.y) || stored >= l.m_q;
}

float map_visibility(sampler2D map, int tile, int type, vec3 light, vec3 direction, mat4 m, vec3 p, vec3 n) {
    MapLookup l = map_lookup(textureSize(map, 0).y, tile, type, light, direction, m, p, n);
    if (l.outside >= 0.0) return l.outside;
    float lit = 0.0;
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) {
            ivec2 t = map_tap(l, x, y);
            lit += tap_lit(l, tap_plane(l, t), texelFetch(map, t, 0).r) ? 1.0 : 0.0;
        }
    return lit / 9.0;
}

float light_visibility(int i, vec3 p, vec3 n) {
    return map_visibility(shadow_map[i], 0, light_type[i], light_position[i], light_direction[i],
                          light_clip_from_world[i], p, n);
}

// Light i at p: the irradiance it brings to a surface facing it (a spot's falloff included, no shadow) and
// the unit direction towards it.
vec3 light_arrival(int i, vec3 p, out vec3 to_light) {
    vec3 incident;
    if (light_type[i] == LIGHT_DIRECTIONAL) {
        to_light = -light_direction[i];
        incident = light_intensity[i];
    } else {
        vec3 v = light_position[i] - p;
        float d2 = dot(v, v);
        to_light = v / sqrt(d2);
        incident = light_intensity[i] / d2;
        if (light_type[i] == LIGHT_SPOT) {
            float c = dot(-to_light, light_direction[i]);
            float t = clamp((c - light_cone_cos[i].y) / max(light_cone_cos[i].x - light_cone_cos[i].y, 1e-9), 0.0, 1.0);
            incident *= t * t * (3.0 - 2.0 * t);
        }
    }
    return incident;
}

// Irradiance at p with normal n from every light, shadowed.
vec3 direct_irradiance(vec3 p, vec3 n) {
    vec3 e = vec3(0.0);
    for (int i = 0; i < light_count; ++i) {
        vec3 to_light;
        vec3 incident = light_arrival(i, p, to_light);
        float cos_theta = dot(n, to_light);
        if (cos_theta <= 0.0) continue;
        e += incident * cos_theta * light_visibility(i, p, n);
    }
    return e;
}

// Cosine-convolved environment (Ramamoorthi and Hanrahan 2001) from 9 SH coefficients.
vec3 ambient_irradiance(vec3 n) {
    float x = n.x, y = n.y, z = n.z;
    vec3 e = irradiance_sh[0] * 0.282095
           + irradiance_sh[1] * 0.488603 * y + irradiance_sh[2] * 0.488603 * z + irradiance_sh[3] * 0.488603 * x
           + irradiance_sh[4] * 1.092548 * x * y + irradiance_sh[5] * 1.092548 * y * z
           + irradiance_sh[6] * 0.315392 * (3.0 * z * z - 1.0) + irradiance_sh[7] * 1.092548 * x * z
           + irradiance_sh[8] * 0.546274 * (x * x - y * y);
    return max(e, vec3(0.0));
}

// The environment's lobes (passes/shading/environment.py): the rest of the environment cut
// into strata of equal power, each with a directional shadow map (tiles of env_shadow_atlas). Where a
// stratum's map says its direction is blocked at p, its share max(0, n . -direction) * irradiance leaves
// the SH ambient; unblocked, the ambient is the SH's exactly. Host define: ENVIRONMENT_SHADOWS (0 or 1,
// ShadeSurfaces sets it where EnvironmentLobeMaps drew the lobes).
#ifndef ENVIRONMENT_SHADOWS
#define ENVIRONMENT_SHADOWS 0
#endif
#if ENVIRONMENT_SHADOWS
#define MAX_ENV_LOBES 32
uniform int env_lobe_count;
uniform vec3 env_lobe_origin[MAX_ENV_LOBES];
uniform vec3 env_lobe_direction[MAX_ENV_LOBES];   // travel direction
uniform vec3 env_lobe_irradiance[MAX_ENV_LOBES];  // per channel, facing the stratum
uniform vec3 env_lobe_span[MAX_ENV_LOBES];        // |sum of solid angle * direction| over the stratum (each component)
uniform mat4 env_lobe_clip_from_world[MAX_ENV_LOBES];
uniform sampler2D env_shadow_atlas;
uniform sampler2D env_nearest_atlas;  // rg32f: the nearest opaque, glass distance over each texel's 3x3 taps
#endif
// One bounce (host define ENVIRONMENT_BOUNCE; passes/shading/lobe_bounce.frag): per texel, the radiance of the
// nearest opaque surface facing along the lobe, which a receiver whose tap the opaque map shadows sees
// instead of the sky.
#ifndef ENVIRONMENT_BOUNCE
#define ENVIRONMENT_BOUNCE 0
#endif
#if ENVIRONMENT_SHADOWS && ENVIRONMENT_BOUNCE
uniform sampler2D env_bounce_atlas;
#endif
// Glass in the lobes' maps (host define ENVIRONMENT_GLASS, 1 where the scene has glass): a second atlas, rgb
// the glass's optical depth along each lobe (-log of its transmittance per channel: two Fresnel interfaces
// and Beer-Lambert absorption over the chord; passes/shading/glass_optical_depth.frag), a its nearest distance (as
// env_shadow_atlas's). A tap that the glass's distance shadows lets exp(-depth) through.
#ifndef ENVIRONMENT_GLASS
#define ENVIRONMENT_GLASS 0
#endif
#if ENVIRONMENT_SHADOWS && ENVIRONMENT_GLASS
uniform sampler2D env_glass_atlas;
#endif

#if ENVIRONMENT_SHADOWS
// Per channel, the fraction of lobe k's light that reaches p: the opaque map's 3x3 filter, each lit tap
// dimmed by the glass's transmittance where the glass's distance shadows it (ENVIRONMENT_GLASS); ``seen``,
// the mean over the taps of the bounce radiance where the opaque map shadows them (0 where lit).
vec3 lobe_light(int k, vec3 p, vec3 n, out vec3 seen) {
    seen = vec3(0.0);
    MapLookup l = map_lookup(textureSize(env_shadow_atlas, 0).y, k, LIGHT_DIRECTIONAL, env_lobe_origin[k],
                             env_lobe_direction[k], env_lobe_clip_from_world[k], p, n);
    if (l.outside >= 0.0) return vec3(l.outside);
    vec2 nearest = texelFetch(env_nearest_atlas, ivec2(l.x0 + l.c.x, l.c.y), 0).rg;
    if (nearest.x >= l.m_q && nearest.y >= l.m_q) return vec3(1.0);  // every tap lit (lobe_nearest.comp)
    vec3 lit = vec3(0.0);
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) {
            ivec2 t = map_tap(l, x, y);
            vec2 plane = tap_plane(l, t);
            if (!tap_lit(l, plane, texelFetch(env_shadow_atlas, t, 0).r)) {
#if ENVIRONMENT_BOUNCE
                seen += texelFetch(env_bounce_atlas, t, 0).rgb;
#endif
                continue;
            }
#if ENVIRONMENT_GLASS
            vec4 glass = texelFetch(env_glass_atlas, t, 0);
            if (tap_lit(l, plane, glass.a)) lit += vec3(1.0);  // a branch: most taps see no glass
            else lit += exp(-max(glass.rgb, vec3(0.0)));
#else
            lit += vec3(1.0);
#endif
        }
    seen /= 9.0;
    return lit / 9.0;
}
#endif

// The light maps (host define ENVIRONMENT_BAKE, 1 where EnvironmentLightMaps baked them: raytrace/environment_bake.py,
// passes/shading/environment.py scene_bake): the ambient environment's irradiance, occluded, through glass, with
// one bounce, on the diffuse receivers, in one rgba32f atlas env_bake: the maps' tiles (rgb); from row
// env_bake_layout.x a table of its env_bake_layout.y rectangles, one a row of five texels (rectangle_rows:
// origin and slack, how far off its plane a point may lie; u / |u|^2; v / |v|^2; normal; tile x0, y0, columns,
// rows); from row env_bake_layout.z the per-vertex irradiance of curved receivers, row-major
// (common/baked_vertex.glsl reads it). Each object's own rectangles (a box's six, a plane's two sides, the floor's
// top) come as its uniforms env_bake_rect (the same five rows each) and env_bake_rect_count, so a fragment tries
// those alone, whatever the scene's count, and reads no table. Host define ENVIRONMENT_BAKE_VERTICES (0 or 1;
// ShadeSurfaces sets it for diffuse variants where the bake has vertices): the vertex stage passes
// baked_vertex_irradiance, used where env_bake_vertex_first >= 0.
#ifndef ENVIRONMENT_BAKE
#define ENVIRONMENT_BAKE 0
#endif
#ifndef ENVIRONMENT_BAKE_VERTICES
#define ENVIRONMENT_BAKE_VERTICES 0
#endif
#define MAX_OBJECT_RECTS 6
#if ENVIRONMENT_BAKE
uniform sampler2D env_bake;
uniform ivec4 env_bake_layout;   // the table's first row, its rectangles, the vertices' first row, 0
uniform int env_bake_rect_count;  // this object's rectangles, at most MAX_OBJECT_RECTS
uniform vec4 env_bake_rect[5 * MAX_OBJECT_RECTS];  // their rows (origin and slack, u', v', normal, tile), five each
#endif
#if ENVIRONMENT_BAKE_VERTICES
uniform int env_bake_vertex_first;  // this object's first vertex in the atlas's vertex rows; -1: none
in vec3 baked_vertex_irradiance;
#endif

#if ENVIRONMENT_BAKE
// Whether p (normal n) lies on the rectangle whose five rows are ``r``, and its map's irradiance there (bilinear,
// clamped to the tile's texel centres).
bool on_rectangle(vec4 r[5], vec3 p, vec3 n, out vec3 e) {
    e = vec3(0.0);
    if (dot(n, r[3].xyz) <= 0.99) return false;
    vec3 d = p - r[0].xyz;
    vec2 st = vec2(dot(d, r[1].xyz), dot(d, r[2].xyz));
    if (abs(dot(d, r[3].xyz)) > r[0].w || any(lessThan(st, vec2(0.0))) || any(greaterThan(st, vec2(1.0))))
        return false;
    vec2 texel = r[4].xy + clamp(st * r[4].zw, vec2(0.5), r[4].zw - 0.5);
    e = texture(env_bake, texel / vec2(textureSize(env_bake, 0))).rgb;
    return true;
}
#endif

// Whether p (normal n) lies on one of the shaded object's rectangles, and that map's irradiance there.
bool baked_irradiance(vec3 p, vec3 n, out vec3 e) {
    e = vec3(0.0);
#if ENVIRONMENT_BAKE
    for (int k = 0; k < env_bake_rect_count; ++k) {
        vec4 r[5] = vec4[5](env_bake_rect[5 * k], env_bake_rect[5 * k + 1], env_bake_rect[5 * k + 2],
                            env_bake_rect[5 * k + 3], env_bake_rect[5 * k + 4]);
        if (on_rectangle(r, p, n, e)) return true;
    }
#endif
    return false;
}

// The light maps' irradiance where any rectangle of the table holds p (a point the impostors' nearby planes
// found, whose object the shader does not know: a search over the whole table), elsewhere the SH's (no lobes).
vec3 baked_or_sh_irradiance(vec3 p, vec3 n) {
#if ENVIRONMENT_BAKE
    vec3 e;
    for (int k = 0; k < env_bake_layout.y; ++k) {
        int row = env_bake_layout.x + k;
        vec4 r[5];
        for (int i = 0; i < 5; ++i) r[i] = texelFetch(env_bake, ivec2(i, row), 0);
        if (on_rectangle(r, p, n, e)) return e;
    }
#endif
    return ambient_irradiance(n);
}

// Ambient irradiance at p with normal n: on one of this object's light maps that map's, on a receiver baked per
// vertex the interpolated vertices'; elsewhere the SH's less what the
// environment's lobes find blocked, plus what the blocked directions show instead (the occluders' bounce, over
// each stratum's span as irradiance is).
// ``shading_n``: the normal the irradiance is taken about (a normal map's), where n (the surface's) finds the
// light maps and the lobes' shadow-map taps.
vec3 ambient_irradiance(vec3 p, vec3 n, vec3 shading_n) {
    vec3 e;
    if (baked_irradiance(p, n, e)) return e;
#if ENVIRONMENT_BAKE_VERTICES
    if (env_bake_vertex_first >= 0) return baked_vertex_irradiance;
#endif
    e = ambient_irradiance(shading_n);
#if ENVIRONMENT_SHADOWS
    vec3 blocked = vec3(0.0), bounce = vec3(0.0);
    for (int k = 0; k < env_lobe_count; ++k) {
        float c = -dot(shading_n, env_lobe_direction[k]);
        if (c <= 0.0) continue;
        vec3 seen;
        vec3 v = lobe_light(k, p, n, seen);
        blocked += (1.0 - v) * c * env_lobe_irradiance[k];
        bounce += seen * c * env_lobe_span[k];
    }
    e = max(e - blocked, vec3(0.0)) + bounce;
#endif
    return e;
}

vec3 ambient_irradiance(vec3 p, vec3 n) { return ambient_irradiance(p, n, n); }
