// The frustum and hierarchical-z tests of one world-space box, shared by the compute passes that
// test boxes (hiz_test.comp, gpu_driven_late.comp): included after their #version line.
// Conservative (proof in soc/culling/hiz_gpu.py): every mesh sample of what the box bounds lies
// inside it, so its pixel lies inside the box's projected rectangle and its depth is at least
// the box's nearest corner depth. The uniforms are set by soc.culling.hiz_gpu.set_test_uniforms.

uniform sampler2D depth;    // level 0: the occluder depth buffer (compare mode off)
uniform sampler2D quads;    // levels 2 and 3: texel e holds level-2 texels 2e + (0,0), (1,0),
                            // (0,1), (1,1) in .xyzw, level-3 texel e is their max; levels >= 4
                            // in .x, each a rectangle (the atlas) right of those
uniform vec4 planes[6];     // inward frustum planes (a, b, c, d), unit normals
uniform float plane_slack;  // relative slack of the plane test (soc.constants.FRUSTUM_SLACK)
uniform float plane_rounding;  // relative float32 rounding allowance of the plane test
uniform mat4 view_proj;
uniform ivec2 size;         // level 0, texels
uniform ivec2 displays[MAX_DISPLAYS]; // resolutions visibility is judged at (pixel centres), >= size
uniform int display_count;  // how many of them differ from size (those come first)
uniform float min_w;        // corners with clip w below this: keep the box untested
uniform float depth_bias;   // NDC units, pulls the box towards the camera
uniform float pixel_margin; // pixels added around the projected rectangle
uniform int footprint;      // texels per axis at the chosen level (2 or 4)
uniform int refine;         // levels finer than its own a box is judged at (0 = classic)
uniform int levels;         // number of levels including level 0
uniform ivec4 level_info[MAX_LEVELS];  // per level: corner in `quads` (levels 0-2: unused), width, height

// Whether the box [lo, hi] lies entirely outside one frustum plane: the signed distance of its
// most-inside corner is negative beyond the slack and beyond a bound on the float32 rounding
// of the sum (the p-vertex test of soc/culling/frustum.py).
bool outside_frustum(vec3 lo, vec3 hi) {
    vec3 c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
    float slack = plane_slack * (1.0 + length(h));
    for (int i = 0; i < 6; ++i) {
        vec3 n = planes[i].xyz;
        float d = dot(c, n) + planes[i].w + dot(h, abs(n));
        float rounding = plane_rounding * (dot(abs(c), abs(n)) + abs(planes[i].w) + dot(h, abs(n)));
        if (d < -(slack + rounding)) {
            return true;
        }
    }
    return false;
}

// node_frustum()'s answers.
const int NODE_OUTSIDE = 0;
const int NODE_INSIDE = 1;
const int NODE_CROSSING = 2;

// NODE_OUTSIDE when outside_frustum() holds for every box inside [lo, hi], NODE_INSIDE when it
// holds for none, else NODE_CROSSING. Beyond outside_frustum's slack (larger for the larger
// box), one more rounding allowance (1e-5 of the magnitudes, against float32 errors of about
// 1e-6 of them in both tests) on the outside side, and one on the inside side.
int node_frustum(vec3 lo, vec3 hi) {
    vec3 c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
    float slack = plane_slack * (1.0 + length(h));
    bool inside = true;
    for (int i = 0; i < 6; ++i) {
        vec3 n = planes[i].xyz;
        float centre = dot(c, n) + planes[i].w;
        float extent = dot(h, abs(n));
        float rounding = plane_rounding * (dot(abs(c), abs(n)) + abs(planes[i].w) + extent);
        if (centre + extent < -(slack + 2.0 * rounding)) return NODE_OUTSIDE;
        if (centre - extent < rounding) inside = false;
    }
    return inside ? NODE_INSIDE : NODE_CROSSING;
}

// Texel (x, y) of level k: levels 0 and 1 with one textureGather of the depth (its wrap clamps
// to the edge: a level-1 texel past an odd last row/column stands alone), levels >= 2 with one
// fetch of `quads` (llvmpipe runs every side of a branch, so a fetch per level would cost one
// each).
float texel(int k, int x, int y) {
    ivec2 p = ivec2(x, y);
    // gather corner: between texels p and p + 1 (texel p is .w), or the four of level-1 texel p
    vec4 g = textureGather(depth, vec2(k == 1 ? 2 * p + 1 : p + 1) / vec2(size));
    vec4 q = texelFetch(quads, k == 2 ? p >> 1 : level_info[k].xy + p, 0);
    float fine = k == 1 ? max(max(g.x, g.y), max(g.z, g.w)) : g.w;
    float coarse = k == 2 ? q[(x & 1) + 2 * (y & 1)] : (k == 3 ? max(max(q.x, q.y), max(q.z, q.w)) : q.x);
    return k <= 1 ? fine : coarse;
}

// Does any texel of level `leaf` holding a level-0 texel of [p0, p1] reach `nearest` (max
// depth >= nearest)? Depth first from the texels of level `lvl`, into the children of a texel
// only when it reaches `nearest` itself: a texel's max bounds its children's, so a subtree
// under a texel that does not reach it cannot either. Stops at the first leaf that does.
// The answer is that of reading every leaf texel of the range (the max over them >= nearest),
// at a fraction of the reads: occluded regions are skipped whole, visible boxes stop early.
// Without a stack: the node (x, y, l) alone says where the walk is (its siblings are the
// children of (x, y) >> 1 inside the range), because a local array costs llvmpipe more per
// invocation than the whole walk.
bool reaches(int lvl, int leaf, ivec2 p0, ivec2 p1, float nearest) {
    ivec2 t0 = p0 >> lvl, t1 = p1 >> lvl;
    ivec2 node = t0;
    int l = lvl;
    while (true) {
        if (texel(l, node.x, node.y) >= nearest) {
            if (l <= leaf) return true;
            --l;  // first child inside the range
            node = max(2 * node, p0 >> l);
            continue;
        }
        // Next sibling (row by row inside the parent's children and the range), else the
        // parent's next sibling, and so on up to the texels of level `lvl`.
        while (true) {
            ivec2 lo = l == lvl ? t0 : max(2 * (node >> 1), p0 >> l);
            ivec2 hi = l == lvl ? t1 : min(2 * (node >> 1) + 1, p1 >> l);
            if (node.x < hi.x) {
                ++node.x;
                break;
            }
            if (node.y < hi.y) {
                node = ivec2(lo.x, node.y + 1);
                break;
            }
            if (l == lvl) return false;
            node >>= 1;
            ++l;
        }
    }
    return false;
}

// Pixels (i, j) of a `res` grid whose centres lie inside the NDC rectangle [rmin, rmax]
// widened by `pixel_margin` pixels: [c0, c1] per axis; false when there is none.
bool centres(vec2 rmin, vec2 rmax, ivec2 res, out ivec2 c0, out ivec2 c1) {
    vec2 wsize = vec2(res);
    vec2 pmin = clamp((rmin * 0.5 + 0.5) * wsize, vec2(-2.0), wsize + 2.0) - pixel_margin;
    vec2 pmax = clamp((rmax * 0.5 + 0.5) * wsize, vec2(-2.0), wsize + 2.0) + pixel_margin;
    c0 = max(ivec2(ceil(pmin - 0.5)), ivec2(0));
    c1 = min(ivec2(floor(pmax - 0.5)), res - 1);
    return all(lessThanEqual(c0, c1));
}

// The clip-space bounds of the box [lo, hi] from its 8 projected corners: the NDC rectangle
// [rmin, rmax], the nearest NDC depth zmin and the smallest clip w (wmin).
void project_corners(vec3 lo, vec3 hi, out vec2 rmin, out vec2 rmax, out float zmin,
                     out float wmin) {
    rmin = vec2(1e30);
    rmax = vec2(-1e30);
    zmin = 1e30;
    wmin = 1e30;
    for (int c = 0; c < 8; ++c) {
        vec3 t = vec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        vec4 p = view_proj * vec4(mix(lo, hi, t), 1.0);
        wmin = min(wmin, p.w);
        p.w = max(p.w, 1e-30);  // only matters when the box is kept below anyway
        vec3 ndc = p.xyz / p.w;
        rmin = min(rmin, ndc.xy);
        rmax = max(rmax, ndc.xy);
        zmin = min(zmin, ndc.z);
    }
}

// 1 unless the NDC rectangle [rmin, rmax] at nearest NDC depth zmin certainly covers no pixel
// centre or is behind the depth at every pixel centre it may cover; else 0. The box is judged
// down to `refine_levels` levels finer than its own.
uint judge_rect(vec2 rmin, vec2 rmax, float zmin, int refine_levels) {
    // Pixel centres (i + 0.5, j + 0.5) inside the rectangle widened by the margin, at level
    // 0's own resolution and at each display resolution; the level-0 texels holding any of
    // them are read (their index ranges joined per axis). A display centre i lies in texel
    // floor((i + 0.5) s), s = size / display; one within 1e-3 texel of a texel border takes
    // both. At size == display both ranges are the same: such displays are skipped.
    ivec2 p0, p1;
    bool any_centre = centres(rmin, rmax, size, p0, p1);
    if (!any_centre) {
        p0 = size;
        p1 = ivec2(-1);
    }
    for (int d = 0; d < display_count; ++d) {
        ivec2 i0, i1;
        if (centres(rmin, rmax, displays[d], i0, i1)) {
            vec2 s = vec2(size) / vec2(displays[d]);
            p0 = min(p0, max(ivec2(floor((vec2(i0) + 0.5) * s - 1e-3)), ivec2(0)));
            p1 = max(p1, min(ivec2(floor((vec2(i1) + 0.5) * s + 1e-3)), size - 1));
            any_centre = true;
        }
    }
    if (!any_centre) {  // covers no pixel centre at any of the resolutions
        return 0u;
    }

    // The finest level at which the pixel range spans at most `footprint` texels per axis.
    int lvl = 0;
    while (lvl < levels - 1 &&
           any(greaterThanEqual((p1 >> lvl) - (p0 >> lvl), ivec2(footprint)))) {
        ++lvl;
    }
    float nearest = 0.5 * (zmin - depth_bias) + 0.5;  // window depth of the nearest corner
    // Refinement: a box not behind the texels at this level is judged at up to `refine`
    // levels finer, whose texels cover the same pixels with maxima no larger: this only turns
    // boxes occluded, never the other way.
    return reaches(lvl, max(lvl - refine_levels, 0), p0, p1, nearest) ? 1u : 0u;
}

// 1 unless the box [lo, hi] certainly covers no pixel centre or is behind the depth at every
// pixel centre it may cover (or 1: it reaches the near plane, kept untested); else 0.
uint judge(vec3 lo, vec3 hi) {
    vec2 rmin, rmax;
    float zmin, wmin;
    project_corners(lo, hi, rmin, rmax, zmin, wmin);
    if (wmin < min_w) {  // reaches the near plane (or behind the eye): keep untested
        return 1u;
    }
    return judge_rect(rmin, rmax, zmin, refine);
}
