#version 450
// Inner-conservative occluder raster, stage 3: a texel is written only when its whole square
// lies inside every edge of the primitive, with a depth no nearer than the primitive's
// farthest point over the square (max of the planes at the corners, at most its farthest
// vertex). Anything else is discarded: the depth bound is never nearer than the real one.
flat in vec3 edges[8];
flat in int n_edges;
flat in vec3 planes[2];
flat in float zmax;

uniform vec2 half_size;

// Relative float32 rounding allowance of a plane evaluated at a texel (~8 ulps of its terms).
const float ROUNDING = 5e-7;

float bound(vec3 plane, vec3 p) {
    return dot(plane, p) + ROUNDING * dot(abs(plane), abs(p));
}

void main() {
    vec3 p = vec3(gl_FragCoord.xy - half_size, 1.0);
    for (int i = 0; i < n_edges; ++i) {
        if (dot(edges[i], p) < 0.0) discard;
    }
    gl_FragDepth = min(max(bound(planes[0], p), bound(planes[1], p)), zmax);
}
