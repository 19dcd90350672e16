#version 450
// Inner-conservative occluder raster, stage 2 (Hasselgren, Akenine-Möller & Ohlsson,
// "Conservative Rasterization", GPU Gems 2 ch. 42, the underestimating variant): per primitive
// the polygon it covers on screen, its inward edge functions already shifted so that a texel
// passes only when its whole square (plus `margin` texels) lies inside, and the planes whose
// maximum over a texel bounds the primitive's depth there.
//
// A primitive is 4 vertices (lines_adjacency). v3 == v2: one triangle (v0, v1, v2). Otherwise a
// quad v0 v1 v2 v3 made of the triangles (v0, v1, v2) and (v0, v2, v3) sharing the diagonal
// v0-v2; drawn as one convex polygon (so texels on the diagonal are covered) only when all four
// vertices lie in front of the near plane and their projection is strictly convex — then the
// union of the two projected triangles is exactly that polygon. Else the two triangles are drawn
// one by one. Polygons are clipped in clip space against the near plane and a guard band
// (|x|, |y| <= guard * w, which keeps window coordinates small and precise).
//
// Coordinates passed on are window coordinates of the target relative to its centre (texels).
layout(lines_adjacency) in;
layout(triangle_strip, max_vertices = 16) out;

uniform vec2 half_size;  // target (width, height) / 2, texels
uniform float margin;    // texels a texel square must lie inside the edges by
uniform float guard;     // guard band, NDC units

flat out vec3 edges[8];  // a, b, c: a texel centre p passes edge i when a p.x + b p.y + c >= 0
flat out int n_edges;
flat out vec3 planes[2]; // window depth bound over the texel at centre p: a p.x + b p.y + c
flat out float zmax;     // largest window depth of the primitive's (near-clipped) vertices

const int MAXV = 8;

// Sutherland-Hodgman against the half-space dot(plane, v) >= 0, in clip space.
int clip_plane(inout vec4 p[MAXV], int n, vec4 plane) {
    vec4 q[MAXV];
    int m = 0;
    for (int i = 0; i < n; ++i) {
        vec4 a = p[i], b = p[(i + 1) % n];
        float da = dot(plane, a), db = dot(plane, b);
        if (da >= 0.0 && m < MAXV) q[m++] = a;
        if ((da >= 0.0) != (db >= 0.0) && m < MAXV) q[m++] = mix(a, b, da / (da - db));
    }
    p = q;
    return m;
}

// Window-depth plane (centred texel coordinates) of the triangle a b c, already raised to its
// maximum over a texel square; from the 4D null vector of the clip coordinates, so vertices
// behind the eye are no problem. An edge-on triangle (no finite plane) gets zmax.
vec3 depth_plane(vec4 a_, vec4 b_, vec4 c_, float zmax_) {
    // In double: the 3x3 determinants cancel heavily (clip coordinates of tens of units, a
    // depth of 0.999…), float32 lost ~3e-6 of window depth here, more than the test's bias.
    dvec4 a = dvec4(a_), b = dvec4(b_), c = dvec4(c_);
    dvec4 n = dvec4(
        determinant(dmat3(a.yzw, b.yzw, c.yzw)),
        -determinant(dmat3(a.xzw, b.xzw, c.xzw)),
        determinant(dmat3(a.xyw, b.xyw, c.xyw)),
        -determinant(dmat3(a.xyz, b.xyz, c.xyz)));
    if (abs(n.z) <= 1e-6 * length(n)) return vec3(0.0, 0.0, zmax_);
    // NDC: z = -(n.x x + n.y y + n.w) / n.z with x = X / half_size.x, window depth 0.5 z + 0.5.
    double ga = -0.5 * n.x / (n.z * double(half_size.x));
    double gb = -0.5 * n.y / (n.z * double(half_size.y));
    double gc = 0.5 - 0.5 * n.w / n.z;
    return vec3(ga, gb, gc + 0.5 * (abs(ga) + abs(gb)));
}

// Orientation of the projected triangle a b c (w > 0), as a sine: the determinant of the
// (x, y, w) vectors over the product of their lengths.
float orient(vec4 a, vec4 b, vec4 c) {
    return determinant(mat3(a.xyw, b.xyw, c.xyw)) /
           max(length(a.xyw) * length(b.xyw) * length(c.xyw), 1e-30);
}

void emit_polygon(vec4 p[MAXV], int n, vec3 plane0, vec3 plane1) {
    // Near plane first (z >= -w): the depths of what is left are finite, their max bounds
    // the polygon's depth; then the guard band.
    n = clip_plane(p, n, vec4(0.0, 0.0, 1.0, 1.0));
    if (n < 3) return;
    float zm = 0.0;
    for (int i = 0; i < n; ++i) zm = max(zm, 0.5 * p[i].z / p[i].w + 0.5);
    n = clip_plane(p, n, vec4(-1.0, 0.0, 0.0, guard));
    n = clip_plane(p, n, vec4(1.0, 0.0, 0.0, guard));
    n = clip_plane(p, n, vec4(0.0, -1.0, 0.0, guard));
    n = clip_plane(p, n, vec4(0.0, 1.0, 0.0, guard));
    if (n < 3) return;
    vec2 q[MAXV];
    float area = 0.0;
    for (int i = 0; i < n; ++i) q[i] = p[i].xy / p[i].w * half_size;
    for (int i = 0; i < n; ++i) {
        vec2 a = q[i], b = q[(i + 1) % n];
        area += a.x * b.y - a.y * b.x;
    }
    if (abs(area) < 1e-6) return;  // no texel can lie inside
    float s = sign(area);
    vec3 e[8];
    for (int i = 0; i < n; ++i) {
        vec2 a = q[i], d = q[(i + 1) % n] - a;
        vec2 ab = s * vec2(-d.y, d.x);  // inward normal
        float c = -dot(ab, a) - (0.5 + margin) * (abs(ab.x) + abs(ab.y));
        e[i] = vec3(ab, c);
    }
    // A convex polygon as a strip: 0, 1, n-1, 2, n-2, ...
    int lo = 1, hi = n - 1;
    for (int k = 0; k < n; ++k) {
        int i = k == 0 ? 0 : ((k & 1) == 1 ? lo++ : hi--);
        edges = e;
        n_edges = n;
        planes[0] = plane0;
        planes[1] = plane1;
        zmax = zm;
        gl_Position = vec4(q[i] / half_size, 0.0, 1.0);
        EmitVertex();
    }
    EndPrimitive();
}

void main() {
    vec4 v0 = gl_in[0].gl_Position, v1 = gl_in[1].gl_Position;
    vec4 v2 = gl_in[2].gl_Position, v3 = gl_in[3].gl_Position;
    vec4 p[MAXV];
    bool quad = v3 != v2;
    if (quad) {
        bool front = all(greaterThanEqual(vec4(v0.z + v0.w, v1.z + v1.w, v2.z + v2.w, v3.z + v3.w),
                                          vec4(0.0)));
        vec4 o = vec4(orient(v0, v1, v2), orient(v1, v2, v3), orient(v2, v3, v0),
                      orient(v3, v0, v1));
        // Strictly convex, with room for float rounding (a sine of 1e-5).
        bool convex = all(greaterThan(o, vec4(1e-5))) || all(lessThan(o, vec4(-1e-5)));
        if (front && convex) {
            p[0] = v0; p[1] = v1; p[2] = v2; p[3] = v3;
            vec3 a = depth_plane(v0, v1, v2, 1.0), b = depth_plane(v0, v2, v3, 1.0);
            emit_polygon(p, 4, a, b);
            return;
        }
    }
    p[0] = v0; p[1] = v1; p[2] = v2;
    vec3 a = depth_plane(v0, v1, v2, 1.0);
    emit_polygon(p, 3, a, a);
    if (quad) {
        p[0] = v0; p[1] = v2; p[2] = v3;
        vec3 b = depth_plane(v0, v2, v3, 1.0);
        emit_polygon(p, 3, b, b);
    }
}
