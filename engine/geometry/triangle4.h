#pragma once
// Four triangles against one ray in one pass of SSE arithmetic: the watertight test of
// triangle.h, lane by lane with the same operations in the same order (so a lane's answer is
// the scalar test's answer, bit for bit), over triangles stored as structure-of-arrays. The
// test's per-ray axis permutation costs nothing here: it only picks which rows to load.
// (Embree's Triangle4 leaves; Woop, Benthin, Wald, JCGT 2013.)
#include <bit>
#include <cstdint>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "engine/geometry/triangle.h"

namespace tessera {

struct alignas(16) Triangle4 {
    float p[3][3][4];   // [vertex][axis][lane]: exact copies of the mesh's vertices
    uint32_t prim[4];   // the triangle in each lane; a leaf's last block repeats its last triangle
};
static_assert(sizeof(Triangle4) == 160, "nine rows of four floats and the four ids");

inline glm::vec3 triangle4_vertex(const Triangle4& t, int v, int lane) {
    return {t.p[v][0][lane], t.p[v][1][lane], t.p[v][2][lane]};
}

inline TriangleVerts triangle4_verts(const Triangle4& t, int lane) {
    return {triangle4_vertex(t, 0, lane), triangle4_vertex(t, 1, lane), triangle4_vertex(t, 2, lane)};
}

// The ray as the 4-wide test wants it: origin and shear broadcast, in the permuted axis order.
struct Triangle4Ray {
    WatertightRay w;
    // Ray::origin_tri: lanes holding it never hit.
#if defined(__SSE2__)
    __m128i skip;  // in every lane
    __m128 o[3];  // o[kx], o[ky], o[kz]
    __m128 sx, sy, sz;
#else
    uint32_t skip;
#endif
};

inline Triangle4Ray make_triangle4_ray(const Ray& ray) {
    Triangle4Ray r;
    r.w = make_watertight_ray(ray.d);
#if defined(__SSE2__)
    r.skip = _mm_set1_epi32(int(ray.origin_tri));
    const float o[3] = {ray.o.x, ray.o.y, ray.o.z};  // not glm's operator[], a switch
    r.o[0] = _mm_set1_ps(o[r.w.kx]);
    r.o[1] = _mm_set1_ps(o[r.w.ky]);
    r.o[2] = _mm_set1_ps(o[r.w.kz]);
    r.sx = _mm_set1_ps(r.w.sx);
    r.sy = _mm_set1_ps(r.w.sy);
    r.sz = _mm_set1_ps(r.w.sz);
#else
    r.skip = ray.origin_tri;
#endif
    return r;
}

// The lanes hit within (tmin, tmax), with each lane's distance and barycentrics.
struct Triangle4Hits {
    int mask = 0;
    alignas(16) float t[4];
    alignas(16) float b1[4];
    alignas(16) float b2[4];
};

inline void intersect_triangle4(const Ray& ray, const Triangle4Ray& r, const Triangle4& tri, Triangle4Hits& out) {
#if defined(__SSE2__)
    const int kx = r.w.kx, ky = r.w.ky, kz = r.w.kz;
    const __m128 zero = _mm_setzero_ps();
    // Translate to the ray origin and shear (rows picked by the permutation).
    const __m128 Akz = _mm_sub_ps(_mm_load_ps(tri.p[0][kz]), r.o[2]);
    const __m128 Bkz = _mm_sub_ps(_mm_load_ps(tri.p[1][kz]), r.o[2]);
    const __m128 Ckz = _mm_sub_ps(_mm_load_ps(tri.p[2][kz]), r.o[2]);
    __m128 ax = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(tri.p[0][kx]), r.o[0]), _mm_mul_ps(r.sx, Akz));
    __m128 ay = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(tri.p[0][ky]), r.o[1]), _mm_mul_ps(r.sy, Akz));
    __m128 bx = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(tri.p[1][kx]), r.o[0]), _mm_mul_ps(r.sx, Bkz));
    __m128 by = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(tri.p[1][ky]), r.o[1]), _mm_mul_ps(r.sy, Bkz));
    __m128 cx = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(tri.p[2][kx]), r.o[0]), _mm_mul_ps(r.sx, Ckz));
    __m128 cy = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(tri.p[2][ky]), r.o[1]), _mm_mul_ps(r.sy, Ckz));
    __m128 u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
    __m128 v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
    __m128 e = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
    const int zero_edge = _mm_movemask_ps(
        _mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)), _mm_cmpeq_ps(e, zero)));
    if (zero_edge) {
        // As in the scalar test: edge functions that round to zero are redone in double.
        alignas(16) float AX[4], AY[4], BX[4], BY[4], CX[4], CY[4], U[4], V[4], E[4];
        _mm_store_ps(AX, ax); _mm_store_ps(AY, ay); _mm_store_ps(BX, bx); _mm_store_ps(BY, by);
        _mm_store_ps(CX, cx); _mm_store_ps(CY, cy); _mm_store_ps(U, u); _mm_store_ps(V, v); _mm_store_ps(E, e);
        for (int l = 0; l < 4; ++l) {
            if (!(zero_edge & (1 << l))) continue;
            U[l] = float(double(CX[l]) * double(BY[l]) - double(CY[l]) * double(BX[l]));
            V[l] = float(double(AX[l]) * double(CY[l]) - double(AY[l]) * double(CX[l]));
            E[l] = float(double(BX[l]) * double(AY[l]) - double(BY[l]) * double(AX[l]));
        }
        u = _mm_load_ps(U); v = _mm_load_ps(V); e = _mm_load_ps(E);
    }
    const __m128 neg = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)), _mm_cmplt_ps(e, zero));
    const __m128 pos = _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)), _mm_cmpgt_ps(e, zero));
    const __m128 det = _mm_add_ps(_mm_add_ps(u, v), e);
    __m128 ok = _mm_andnot_ps(_mm_and_ps(neg, pos), _mm_cmpneq_ps(det, zero));
    ok = _mm_andnot_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(tri.prim)), r.skip)), ok);
    if (!_mm_movemask_ps(ok)) { out.mask = 0; return; }
    const __m128 az = _mm_mul_ps(r.sz, Akz), bz = _mm_mul_ps(r.sz, Bkz), cz = _mm_mul_ps(r.sz, Ckz);
    const __m128 T = _mm_add_ps(_mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)), _mm_mul_ps(e, cz));
    const __m128 inv_det = _mm_div_ps(_mm_set1_ps(1.f), det);
    const __m128 t = _mm_mul_ps(T, inv_det);
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpgt_ps(t, _mm_set1_ps(ray.tmin)), _mm_cmplt_ps(t, _mm_set1_ps(ray.tmax))));
    if (!_mm_movemask_ps(ok)) { out.mask = 0; return; }
    // pbrt-v4's bound on t's rounding error (see triangle.h), lane by lane.
    const __m128 sign = _mm_set1_ps(-0.f);
    auto abs = [sign](__m128 x) { return _mm_andnot_ps(sign, x); };
    const __m128 max_zt = _mm_max_ps(abs(az), _mm_max_ps(abs(bz), abs(cz)));
    const __m128 max_xt = _mm_max_ps(abs(ax), _mm_max_ps(abs(bx), abs(cx)));
    const __m128 max_yt = _mm_max_ps(abs(ay), _mm_max_ps(abs(by), abs(cy)));
    const __m128 delta_z = _mm_mul_ps(_mm_set1_ps(gamma(3)), max_zt);
    const __m128 delta_x = _mm_mul_ps(_mm_set1_ps(gamma(5)), _mm_add_ps(max_xt, max_zt));
    const __m128 delta_y = _mm_mul_ps(_mm_set1_ps(gamma(5)), _mm_add_ps(max_yt, max_zt));
    const __m128 delta_e = _mm_mul_ps(_mm_set1_ps(2.f),
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(gamma(2)), max_xt), max_yt), _mm_mul_ps(delta_y, max_xt)),
                   _mm_mul_ps(delta_x, max_yt)));
    const __m128 max_e = _mm_max_ps(abs(u), _mm_max_ps(abs(v), abs(e)));
    const __m128 sum = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(gamma(3)), max_e), max_zt),
                                             _mm_mul_ps(delta_e, max_zt)),
                                  _mm_mul_ps(delta_z, max_e));
    const __m128 delta_t = _mm_mul_ps(_mm_mul_ps(_mm_set1_ps(3.f), sum), abs(inv_det));
    ok = _mm_and_ps(ok, _mm_cmpgt_ps(t, delta_t));
    out.mask = _mm_movemask_ps(ok);
    if (!out.mask) return;
    _mm_store_ps(out.t, t);
    _mm_store_ps(out.b1, _mm_mul_ps(v, inv_det));
    _mm_store_ps(out.b2, _mm_mul_ps(e, inv_det));
#else
    out.mask = 0;
    for (int l = 0; l < 4; ++l) {
        if (tri.prim[l] == r.skip) continue;
        TriangleHit h;
        const TriangleVerts tv = triangle4_verts(tri, l);
        if (!intersect_triangle_watertight(ray, r.w, tv.p0, tv.p1, tv.p2, h)) continue;
        out.mask |= 1 << l;
        out.t[l] = h.t; out.b1[l] = h.b1; out.b2[l] = h.b2;
    }
#endif
}

// The nearest lane of a non-empty mask (the first of equals, so a repeated triangle is found
// at its first lane).
inline int nearest_lane(const Triangle4Hits& h) {
#if defined(__SSE2__)
    // Without branches (which lane is nearest is unpredictable): the minimum over the hit
    // lanes, then the lowest lane holding it.
    const __m128i bits = _mm_setr_epi32(1, 2, 4, 8);
    const __m128 hit = _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(h.mask), bits), bits));
    const __m128 t = _mm_or_ps(_mm_and_ps(hit, _mm_load_ps(h.t)), _mm_andnot_ps(hit, _mm_set1_ps(INFINITY)));
    __m128 m = _mm_min_ps(t, _mm_shuffle_ps(t, t, _MM_SHUFFLE(2, 3, 0, 1)));
    m = _mm_min_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
    return std::countr_zero(unsigned(_mm_movemask_ps(_mm_cmpeq_ps(t, m)) & h.mask));
#else
    int best = -1;
    for (int l = 0; l < 4; ++l)
        if ((h.mask & (1 << l)) && (best < 0 || h.t[l] < h.t[best])) best = l;
    return best;
#endif
}

}  // namespace tessera
