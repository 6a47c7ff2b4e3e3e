#include "engine/render/denoise.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "engine/core/block_pool.h"
#include "engine/core/exp_nonpositive.h"
#include "engine/core/float_lanes.h"
#include "engine/render/convergence.h"
#include "engine/render/film.h"

namespace tessera {

namespace {

// Features: the shading normal (3, made unit: a silhouette pixel's is its surface's), depth, and
// the pixel's place (x and y over 16), so a window fits a gradient across the screen too, as
// NFOR's do. Not the albedo: the colour is divided by it, and a silhouette pixel's albedo is its
// coverage times its surface's, which a linear fit would read as a darker surface.
constexpr int kF = 6;
constexpr int kPairs = kF * (kF + 1) / 2;                 // f_a f_b, a ≤ b
constexpr int kY = 6;                                     // colour over albedo: half A (3), half B (3)
constexpr int kChannels = 1 + kF + kPairs + kY * (1 + kF);  // box-summed per pixel
constexpr int kBand = 32;                                 // rows per task: fixed, so the sums' order is too
constexpr int kSmooth = 4;                                // radius over which error estimates are pooled
constexpr int kBiasSmooth = 3;
constexpr int kSeenRadius = 4;                            // of the window the light seen directly is filtered over                            // ... bias estimates, before they are held at zero or more
constexpr float kBiasClamp = 1.f;                           // the first filter's cross-validation per pixel, against the noise around
constexpr int kBiasRounds = 8;                             // ... and the bias pooled so far, grown this many times
constexpr double kContradiction = 8.0;                    // a pixel's own error estimate against its noise, to refuse a candidate
constexpr double kDeparture = 9.0;                        // a candidate's move of a pixel against its noise (3 sigma), the same
// Below this albedo the colour is divided by it no further: what a dark albedo does not scale
// (a coat's reflection, the eye of a toy duck) would become a giant that spreads to neighbours.
constexpr float kAlbedoFloor = 0.1f;
// ... and a pixel below it beside one this many times brighter keeps its value (dark detail).
constexpr float kDarkDetail = 4.f;
constexpr double kEps = 0.01;                             // relMSE's ε
// Samples a pixel, on the image's mean, from which the image is given back as rendered when its
// estimate says denoising gains nothing (denoise_in_use's end).
constexpr double kTrustedMeanSamples = 64;
// Ridge: each feature's own variance in the window times kTau, plus kDelta (features lie in
// [-1, 1]): a feature that barely varies is not trusted to explain the colour's noise.
constexpr double kTau = 0.01, kDelta = 1e-4;

struct Inputs {
    int w = 0, h = 0;
    PoolVector<float> f;   // kF per pixel
    PoolVector<float> y;   // the halves over albedo, kY per pixel
    PoolVector<float> m;   // the albedo they were divided by (1 where there is none), 3 per pixel
    PoolVector<uint8_t> use;  // whether the pixel joins its neighbours' windows (it saw no light directly)
};

inline void pixel_channels(const float* f, const float* y, double* v) {
    v[0] = 1.0;
    for (int a = 0; a < kF; ++a) v[1 + a] = f[a];
    int o = 1 + kF;
    for (int a = 0; a < kF; ++a)
        for (int b = a; b < kF; ++b) v[o++] = double(f[a]) * f[b];
    for (int k = 0; k < kY; ++k) {
        v[o++] = y[k];
        for (int a = 0; a < kF; ++a) v[o++] = double(f[a]) * y[k];
    }
}
// Fewer pixels than this in a window (the rest saw light directly): the pixel is left as it is.
constexpr double kMinSupport = 3.0;

// Solves A z = r for symmetric positive definite A (n × n, row-major), by Cholesky in place.
bool cholesky(double* A, int n) {
    for (int j = 0; j < n; ++j) {
        double d = A[j * n + j];
        for (int k = 0; k < j; ++k) d -= A[j * n + k] * A[j * n + k];
        if (!(d > 0.0)) return false;
        d = std::sqrt(d);
        A[j * n + j] = d;
        for (int i = j + 1; i < n; ++i) {
            double s = A[i * n + j];
            for (int k = 0; k < j; ++k) s -= A[i * n + k] * A[j * n + k];
            A[i * n + j] = s / d;
        }
    }
    return true;
}
void cholesky_solve(const double* L, int n, double* z) {
    for (int i = 0; i < n; ++i) {
        double s = z[i];
        for (int k = 0; k < i; ++k) s -= L[i * n + k] * z[k];
        z[i] = s / L[i * n + i];
    }
    for (int i = n - 1; i >= 0; --i) {
        double s = z[i];
        for (int k = i + 1; k < n; ++k) s -= L[k * n + i] * z[k];
        z[i] = s / L[i * n + i];
    }
}

// One candidate's outputs for both halves at one pixel (in the colour's units), from the box
// sums S of its window: the same regression on the same features for each, so the filter is one
// linear map applied to two independent images.
void regress(const double* S, const float* fi, const float* yi, const float* mi, float* out) {
    const double n = S[0];
    if (n < kMinSupport || fi[3] > 1.5f) {  // too few to fit, or the pixel saw no surface (nothing to filter)
        for (int k = 0; k < kY; ++k) out[k] = yi[k] * mi[k % 3];
        return;
    }
    double mf[kF], A[kF * kF], d[kF];
    for (int a = 0; a < kF; ++a) mf[a] = S[1 + a] / n;
    int o = 1 + kF;
    for (int a = 0; a < kF; ++a)
        for (int b = a; b < kF; ++b) {
            const double c = S[o++] / n - mf[a] * mf[b];
            A[a * kF + b] = A[b * kF + a] = c;
        }
    for (int a = 0; a < kF; ++a) {
        A[a * kF + a] += kTau * std::max(0.0, A[a * kF + a]) + kDelta;
        d[a] = double(fi[a]) - mf[a];
    }
    // The fit at the pixel is mean + c·A⁻¹d for each channel's covariances c: one solve for the
    // pixel (A⁻¹d, A symmetric), not one per channel.
    const bool solved = cholesky(A, kF);
    if (solved) cholesky_solve(A, kF, d);
    for (int k = 0; k < kY; ++k) {
        const double my = S[o] / n;
        double pred = my;
        if (solved)
            for (int a = 0; a < kF; ++a) pred += (S[o + 1 + a] / n - mf[a] * my) * d[a];
        o += 1 + kF;
        out[k] = float(pred * mi[k % 3]);
    }
}

// Runs fn(band) for every band of kBand rows on `threads` threads.
template <class Fn>
void for_bands(int height, int threads, Fn&& fn) {
    const int bands = (height + kBand - 1) / kBand;
    std::atomic<int> next{0};
    BlockPool* const memory = BlockPool::current();
    auto work = [&] {
        const BlockPool::Use use(memory);
        for (int b; (b = next.fetch_add(1)) < bands;) fn(b * kBand, std::min(height, (b + 1) * kBand));
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < std::min(threads, bands); ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
}

// Runs fn(x0, x1) for `threads` strips of [0, count) at once: for work whose result does not
// depend on where the strips are cut.
template <class Fn>
void for_strips(int count, int threads, Fn&& fn) {
    const int parts = std::max(1, std::min(threads, count));
    BlockPool* const memory = BlockPool::current();
    std::vector<std::thread> pool;
    for (int t = 1; t < parts; ++t)
        pool.emplace_back([&, t] {
            const BlockPool::Use use(memory);
            fn(count * t / parts, count * (t + 1) / parts);
        });
    fn(0, count / parts);
    for (auto& t : pool) t.join();
}

// Runs fn(p) for every pixel p of a W × H map, bands of rows on `threads` threads: for work
// that is the pixel's own, so the result does not depend on the threads.
template <class Fn>
void for_pixels(int W, int H, int threads, Fn&& fn) {
    for_bands(H, threads, [&](int y0, int y1) {
        for (size_t p = size_t(y0) * W, end = size_t(y1) * W; p < end; ++p) fn(p);
    });
}

// The candidate of window radius r at every pixel: both halves filtered (kY per pixel).
void filter(const Inputs& in, int r, int threads, PoolVector<float>& out) {
    const int W = in.w, H = in.h;
    out.assign(size_t(W) * H * kY, 0.f);
    for_bands(H, threads, [&](int y0, int y1) {
        PoolVector<double> col(size_t(W) * kChannels, 0.0), v(kChannels), S(kChannels);
        auto add_row = [&](int y, double sign) {
            if (y < 0 || y >= H) return;
            for (int x = 0; x < W; ++x) {
                const size_t p = size_t(y) * W + x;
                if (!in.use[p]) continue;
                pixel_channels(&in.f[p * kF], &in.y[p * kY], v.data());
                double* c = &col[size_t(x) * kChannels];
                for (int k = 0; k < kChannels; ++k) c[k] += sign * v[k];
            }
        };
        for (int y = y0 - r; y <= y0 + r; ++y) add_row(y, 1.0);
        for (int y = y0; y < y1; ++y) {
            std::fill(S.begin(), S.end(), 0.0);
            for (int x = 0; x <= std::min(r, W - 1); ++x)
                for (int k = 0; k < kChannels; ++k) S[k] += col[size_t(x) * kChannels + k];
            for (int x = 0; x < W; ++x) {
                const size_t p = size_t(y) * W + x;
                regress(S.data(), &in.f[p * kF], &in.y[p * kY], &in.m[p * 3], &out[p * kY]);
                if (x + r + 1 < W)
                    for (int k = 0; k < kChannels; ++k) S[k] += col[size_t(x + r + 1) * kChannels + k];
                if (x - r >= 0)
                    for (int k = 0; k < kChannels; ++k) S[k] -= col[size_t(x - r) * kChannels + k];
            }
            add_row(y + r + 1, 1.0);
            add_row(y - r, -1.0);
        }
    });
}

// The candidate that weighs each neighbour by how alike it looks (NL-means as Rousselle, Knaus and
// Zwicker 2012 use it for rendering, first-order-free): shadows and glossy highlights, which the
// features do not explain, keep their edges. Half A is averaged with weights from half B's
// colour and B with A's (cross-filtering, as NFOR does), so neither half picks the neighbours
// its own noise happens to match. The guide is each half's colour over albedo, box-smoothed
// over 3×3 (a patch), its variance from the difference of the halves.
//
// The same weights make the NL-means regression candidate (`first`): a weighted least-squares
// fit of each half on (1, dx, dy), its value at the pixel. The slopes carry a ridge of
// kSlopeRidge times the weights' sum (dx, dy in window radii): a window whose weight lies on one
// side is not trusted to extrapolate far.
constexpr double kSlopeRidge = 0.01;
constexpr size_t kNlmRegression = 1;  // its place among the candidates
static_assert(kDenoiseCandidates[kNlmRegression].filter == DenoiseFilter::nlm_regression);
// The box regression: NL-means' guides, so it is filtered first.
constexpr size_t kBoxRegression = 2;
static_assert(kDenoiseCandidates[kBoxRegression].filter == DenoiseFilter::box_regression &&
              kBoxRegression < kDenoiseCandidates.size() - 1);
// The variance of a prefiltered guide, at least this share of the 3×3 mean's (docs/denoising.md:
// 0.25, 0.4, and the fit's halves alone measured within a few per cent of each other).
constexpr float kPrefilteredVariance = 0.4f;

// An NL-means guide at (x, y): the 3×3 means of two halves (3 channels each, `stride` floats
// apart from pixel to pixel) over the neighbours `joins` admits, into ga and gb; returns the
// variance of those means, one half's being (A − B)²/2 per channel.
template <class Joins>
float guide_3x3(int W, int H, int x, int y, const float* a, const float* b, size_t stride, Joins&& joins, float* ga, float* gb) {
    double sa[3] = {}, sb[3] = {}, d = 0;
    int cnt = 0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
            const size_t q = size_t(yy) * W + xx;
            if (!joins(q)) continue;
            for (int k = 0; k < 3; ++k) {
                const double va = a[q * stride + k], vb = b[q * stride + k];
                sa[k] += va;
                sb[k] += vb;
                d += (va - vb) * (va - vb);
            }
            ++cnt;
        }
    for (int k = 0; k < 3; ++k) {
        ga[k] = float(sa[k] / cnt);
        gb[k] = float(sb[k] / cnt);
    }
    return float(d / 3.0 / 2.0 / cnt / cnt);
}

// What the NL-means loop reads of a pixel, one plane each, so that a row of them is contiguous.
struct NlmPlanes {
    enum : int { nx, ny, nz, z, var, use, s2, gA = s2 + 3, gB = gA + 3, yA = gB + 3, yB = yA + 3, count = yB + 3 };
    std::array<PoolVector<float>, count> at;
};

constexpr float kNoiseCeiling = 1e20f;  // a neighbour's noise s² at most (NlmSums)

// Per pixel of a row, what the window's weights sum: per half h, Σw, Σw·{dx, dy, dx², dx·dy,
// dy²}; per channel Σw²·s²·{1, dx, dy, dx², dx·dy, dy²}, s² the neighbour's noise (its
// variance sandwiched between the fit's); and per channel Σw·y·{1, dx, dy}.
struct NlmSums {
    enum : int { w, wx, wy, wxx, wxy, wyy, v = 6, y = v + 18, per_half = y + 9, count = 2 * per_half };
};

// `prefiltered`: the box regression's halves, the guides where a pixel joins its neighbours.
// `variance`: per pixel, the variance of the two outputs' mix (`wa` the even half's share) as
// the weights make it, per channel in the colour's units: the regression's (3), NL-means' (3).
//
// Why not only the halves' difference, (f(A) − f(B))²/4: f(A)'s weights read B, f(B)'s read A,
// so the two outputs covary and their difference reads the variance low (20 % for the
// regression on the diffuse box at 16-64 spp, measured against two seeds' images). Each output
// is linear in its half for given weights: f = e₀ᵀ M⁻¹ Σ w_q m_q y_q, M = Σ w_q m_q m_qᵀ, m_q
// = (1, dx, dy), so its variance is e₀ᵀ M⁻¹ (Σ w_q² s_q² m_q m_qᵀ) M⁻¹ e₀ (the sandwich
// estimator of weighted least squares), s_q² the neighbour's own noise from its halves,
// (y_A − y_B)²/2, per channel (one for all three read a dark channel's noise, divided by its
// albedo, into the bright ones: 10-15 times too much on the Duck). It leaves out what the
// weights' own noise adds, which the halves' difference keeps: the estimate takes the larger.
void filter_nlm(const Inputs& in, int r, int threads, const PoolVector<float>& prefiltered, const PoolVector<float>& wa,
                PoolVector<float>& out, PoolVector<float>& first, PoolVector<float>& variance) {
    const int W = in.w, H = in.h;
    const size_t n = size_t(W) * H;
    // Guides (3×3 means of each half, or its box regression: below) and their variance per pixel.
    NlmPlanes P;
    for (auto& a : P.at) a.resize(n);
    for_bands(H, threads, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
        for (int x = 0; x < W; ++x) {
            const size_t p = size_t(y) * W + x;
            float g[kY];
            P.at[NlmPlanes::var][p] =
                guide_3x3(W, H, x, y, in.y.data(), in.y.data() + 3, kY, [&](size_t q) { return in.use[q] || q == p; }, g, g + 3);
            for (int k = 0; k < kY; ++k) {
                P.at[NlmPlanes::gA + k][p] = g[k];
                P.at[NlmPlanes::yA + k][p] = in.y[p * kY + k];
            }
            // Where the pixel joins its neighbours' windows, the guide is the half as the box
            // regression filtered it: its noise is what the weights lose most to ("Where the error
            // is", docs/denoising.md), and the regression reads its own half and the features
            // only, so the other half's weights stay independent of this half's noise. Its
            // variance: a share of the 3×3 mean's (neighbouring fits share most of their window,
            // so their difference carries less noise than either), or what the fit's two halves
            // show where that is more (features a lens or a shutter made noisy). The fit is in
            // the colour's units, the 3×3 mean's variance over the albedo: against the guide's
            // differences that is larger by 1/albedo², the weights more lenient on dark surfaces.
            // Measured so on purpose: the guide over the albedo too was up to 24 % worse in the
            // lamp room and 7-16 % on the boxes at 16-32 spp (docs/denoising.md).
            if (in.use[p]) {
                double d = 0;  // the fit's own halves' difference
                for (int k = 0; k < 3; ++k) {
                    const double e = double(prefiltered[p * kY + k]) - prefiltered[p * kY + 3 + k];
                    d += e * e;
                }
                for (int k = 0; k < kY; ++k) P.at[NlmPlanes::gA + k][p] = prefiltered[p * kY + k];
                P.at[NlmPlanes::var][p] = std::max(P.at[NlmPlanes::var][p] * kPrefilteredVariance, float(d / 3.0 / 2.0));
            }
            for (int k = 0; k < 4; ++k) P.at[NlmPlanes::nx + k][p] = in.f[p * kF + k];
            // Held finite (an infinite or NaN half, whose guide weighs it nothing, is the largest),
            // so that no sum below turns NaN or infinite and spreads through the poolings.
            for (int k = 0; k < 3; ++k) {
                const float e = in.y[p * kY + k] - in.y[p * kY + 3 + k];
                P.at[NlmPlanes::s2 + k][p] = std::fmin(0.5f * e * e, kNoiseCeiling);
            }
            P.at[NlmPlanes::use][p] = in.use[p] ? 1.f : 0.f;
        }
    });
    out.assign(n * kY, 0.f);
    first.assign(n * kY, 0.f);
    variance.assign(n * 6, 0.f);
    // The floor under the guides' variance, in the colour-over-albedo's units: what tolerance
    // the weights keep when the halves agree by chance. At 1e-4 it held the weights at about 1 %
    // of the colour from 64 spp on, so the regression's bias stopped falling with the samples
    // (on the diffuse box at 160×120 its error was 90 % bias at 256 spp); at 1e-5 the denoised
    // error is 13-32 % lower there from 128 spp, and within a few per cent either way at fewer
    // samples (docs/denoising.md).
    constexpr float kK2 = 0.45f * 0.45f, kVarFloor = 1e-5f;
    // Sixteen pixels of a row at a time, offset by offset, their sums in registers (Lanes, one
    // AVX-512 register each; with fewer or narrower registers some spill to the stack): first
    // the weights, with the sums that read nothing else, kept for the window; then per channel the
    // sums of the noise and the colour. Each pixel's sums still take the offsets in one fixed
    // order, so the image does not depend on the threads. Sixteen pixels whose window runs over the
    // image's edge read zeros there (no use: they weigh nothing). Not planes padded in memory:
    // their size, unlike the other maps', found no block to reuse, and a render's first
    // denoising at 1920×1440 took 12 % longer faulting their fresh pages in.
    const int D = 2 * r + 1;
    for_bands(H, threads, [&](int y0, int y1) {
        const size_t Ws = size_t(W) + kLanes;  // a row of sums, and room for the last pixels' lanes
        PoolVector<float> sums(size_t(NlmSums::count) * Ws);
        auto sum = [&](int h, int k) { return &sums[size_t(h * NlmSums::per_half + k) * Ws]; };
        std::vector<Lanes> weights(size_t(D) * D * 2);
        // Per offset, its moments {1, dx, dy, dx², dx·dy, dy²} (dx, dy in window radii).
        std::vector<std::array<float, 6>> moments(size_t(D) * D);
        for (int oy = -r; oy <= r; ++oy)
            for (int ox = -r; ox <= r; ++ox) {
                const float dx = float(ox) / float(r), dy = float(oy) / float(r);
                moments[size_t((oy + r) * D + ox + r)] = {1.f, dx, dy, dx * dx, dx * dy, dy * dy};
            }
        // No clearing per row: every sum the solve reads (the row's surface pixels, all within
        // the span below) is stored first; clearing was 66 floats a pixel of dead writes.
        for (int y = y0; y < y1; ++y) {
            const size_t row = size_t(y) * W;
            // Only the row's span of pixels that saw a surface: the void around a model has
            // nothing to filter.
            int first_x = W, end_x = 0;
            for (int x = 0; x < W; ++x)
                if (in.f[(row + size_t(x)) * kF + 3] <= 1.5f) { first_x = std::min(first_x, x); end_x = x + 1; }
            const int oy0 = std::max(-r, -y), oy1 = std::min(r, H - 1 - y);
            for (int xb = first_x; xb < end_x; xb += kLanes) {
                auto at = [&](int c, int oy, int ox) {
                    const float* row_q = P.at[size_t(c)].data() + size_t(y + oy) * W;
                    const int x0 = xb + ox;
                    if (x0 >= 0 && x0 + kLanes <= W) return load_lanes(row_q + x0);
                    float edge[kLanes];
                    for (int l = 0; l < kLanes; ++l) edge[l] = x0 + l >= 0 && x0 + l < W ? row_q[x0 + l] : 0.f;
                    return load_lanes(edge);
                };
                // The weights, and Σw·{1, dx, dy, dx², dx·dy, dy²} per half.
                {
                    const Lanes pnx = at(NlmPlanes::nx, 0, 0), pny = at(NlmPlanes::ny, 0, 0), pnz = at(NlmPlanes::nz, 0, 0);
                    const Lanes pz = at(NlmPlanes::z, 0, 0), vi = at(NlmPlanes::var, 0, 0);
                    const Lanes zscale = 1.f / (0.02f + pz);
                    Lanes acc[2][6] = {};
                    for (int oy = oy0; oy <= oy1; ++oy) {
                        for (int ox = -r; ox <= r; ++ox) {
                            const float* m = moments[size_t((oy + r) * D + ox + r)].data();
                            // Geometry: a neighbour on another surface is not one of this pixel's kind.
                            const Lanes e0 = pnx - at(NlmPlanes::nx, oy, ox), e1 = pny - at(NlmPlanes::ny, oy, ox),
                                        e2 = pnz - at(NlmPlanes::nz, oy, ox);
                            const Lanes dz = (pz - at(NlmPlanes::z, oy, ox)) * zscale;
                            const Lanes gf = (e0 * e0 + e1 * e1 + e2 * e2) / 0.05f + dz * dz / 0.0025f;
                            // A weight below 1e-4 counts as none; so does a neighbour that saw light
                            // directly (the pixel itself joins its window whatever it saw).
                            const Lanes use = ox == 0 && oy == 0 ? splat(1.f) : at(NlmPlanes::use, oy, ox);
                            const Lanes keep = select(gf <= 9.2f, use, splat(0.f));
                            const Lanes vq = at(NlmPlanes::var, oy, ox);
                            const Lanes scale = 1.f / (3.f * (kVarFloor + kK2 * (vi + vq)));
                            const Lanes floor = vi + min_lanes(vi, vq);
                            Lanes* w = &weights[size_t((oy + r) * D + ox + r) * 2];
                            for (int h = 0; h < 2; ++h) {
                                const int g = h == 0 ? NlmPlanes::gB : NlmPlanes::gA;  // the other half's guide
                                Lanes d2 = splat(0.f);
                                for (int k = 0; k < 3; ++k) {
                                    const Lanes e = at(g + k, 0, 0) - at(g + k, oy, ox);
                                    d2 += e * e - floor;
                                }
                                // A weight below e⁻²⁰ (2·10⁻⁹ of the pixel's own) is none: below about
                                // e⁻⁴⁴ a weight's square is a denormal float, and so are its products
                                // with small colours and noise well above that; a denormal costs the
                                // processor's microcode a hundred times a normal operation (this loop
                                // took 3 times as long with them). A NaN distance (a guide or its
                                // variance overflowed, beside a firefly of 10²⁰ and more) weighs the
                                // exponential's floor, 2.5·10⁻³⁸: where the pixel's own is NaN, all
                                // its neighbours' are, and its window is their plain mean (which
                                // keeps a firefly's own pixel from standing alone at a value whose
                                // square overflows the error maps downstream).
                                const Lanes e = -gf - max_lanes(d2 * scale, splat(0.f));
                                w[h] = select((e > -20.f) | (e != e), keep * exp_nonpositive(e), splat(0.f));
                                for (int k = 0; k < 6; ++k) acc[h][k] += w[h] * m[k];
                            }
                        }
                    }
                    for (int h = 0; h < 2; ++h)
                        for (int k = 0; k < 6; ++k) store_lanes(sum(h, NlmSums::w + k) + xb, acc[h][k]);
                }
                // Per channel: Σw²·s²·{1, dx, dy, dx², dx·dy, dy²} and Σw·y·{1, dx, dy}, per half.
                for (int ch = 0; ch < 3; ++ch) {
                    Lanes v[2][6] = {}, c[2][3] = {};
                    for (int oy = oy0; oy <= oy1; ++oy) {
                        for (int ox = -r; ox <= r; ++ox) {
                            const float* m = moments[size_t((oy + r) * D + ox + r)].data();
                            const Lanes* w = &weights[size_t((oy + r) * D + ox + r) * 2];
                            const Lanes s2 = at(NlmPlanes::s2 + ch, oy, ox);
                            const Lanes y2[2] = {at(NlmPlanes::yA + ch, oy, ox), at(NlmPlanes::yB + ch, oy, ox)};
                            for (int h = 0; h < 2; ++h) {
                                // s² is finite, so a neighbour of no weight adds nothing; its colour
                                // may not be (an infinite one), so that is masked.
                                const LaneMask weighs = w[h] > 0.f;
                                const Lanes cv = w[h] * w[h] * s2;
                                const Lanes ya = select(weighs, w[h] * y2[h], splat(0.f));
                                for (int k = 0; k < 6; ++k) v[h][k] += cv * m[k];
                                c[h][0] += ya;
                                c[h][1] += ya * m[1];
                                c[h][2] += ya * m[2];
                            }
                        }
                    }
                    for (int h = 0; h < 2; ++h) {
                        for (int k = 0; k < 6; ++k) store_lanes(sum(h, NlmSums::v + 6 * ch + k) + xb, v[h][k]);
                        for (int k = 0; k < 3; ++k) store_lanes(sum(h, NlmSums::y + 3 * ch + k) + xb, c[h][k]);
                    }
                }
            }
            for (int x = 0; x < W; ++x) {
                const size_t p = row + size_t(x);
                if (in.f[p * kF + 3] > 1.5f) {  // no surface: nothing to filter
                    for (int k = 0; k < kY; ++k) out[p * kY + k] = first[p * kY + k] = in.y[p * kY + k] * in.m[p * 3 + k % 3];
                    continue;
                }
                const double share[2] = {wa[p], 1.0 - double(wa[p])};
                for (int h = 0; h < 2; ++h) {
                    auto S = [&](int k) { return double(sum(h, k)[x]); };
                    const double w = S(NlmSums::w);
                    double A[9] = {w,           S(NlmSums::wx),  S(NlmSums::wy),
                                   S(NlmSums::wx), S(NlmSums::wxx) + kSlopeRidge * w, S(NlmSums::wxy),
                                   S(NlmSums::wy), S(NlmSums::wxy), S(NlmSums::wyy) + kSlopeRidge * w};
                    const bool solved = cholesky(A, 3);
                    double u[3] = {1.0, 0.0, 0.0};  // M⁻¹ e₀
                    if (solved) cholesky_solve(A, 3, u);
                    else u[0] = 1.0 / w, u[1] = u[2] = 0.0;
                    for (int k = 0; k < 3; ++k) {
                        const int o = NlmSums::v + 6 * k;
                        const double B[9] = {S(o), S(o + 1), S(o + 2), S(o + 1), S(o + 3), S(o + 4), S(o + 2), S(o + 4), S(o + 5)};
                        double vr = 0;
                        for (int i = 0; i < 3; ++i)
                            for (int j = 0; j < 3; ++j) vr += u[i] * B[i * 3 + j] * u[j];
                        const double mk = in.m[p * 3 + k], s2 = share[h] * share[h] * mk * mk;
                        variance[p * 6 + k] += float(s2 * vr);
                        variance[p * 6 + 3 + k] += float(s2 * S(o) / (w * w));
                    }
                    for (int k = 0; k < 3; ++k) {
                        const double mk = in.m[p * 3 + k];
                        out[p * kY + 3 * h + k] = float(S(NlmSums::y + 3 * k) / w * mk);
                        double z[3] = {S(NlmSums::y + 3 * k), S(NlmSums::y + 3 * k + 1), S(NlmSums::y + 3 * k + 2)};
                        if (solved) cholesky_solve(A, 3, z);
                        else z[0] /= w;
                        first[p * kY + 3 * h + k] = float(z[0] * mk);
                    }
                }
            }
        }
    });
}

// The light seen directly (emitters, the sky), each half averaged by NL-means over a window of
// radius r with weights from the other half's (cross-filtered, as the colour's candidates are).
// Through a lens or over a shutter it is a smooth halo whose pixels saw it with a few of their
// samples or none: a pixel whose samples all missed it has no light of its own to show, and its
// neighbours have. In focus it is a sharp edge, and its neighbours' light is far from the pixel's
// beyond both their noise, so they weigh nothing. Only where the seen light is noisy within r of
// the pixel, and every map only over the box around those pixels (fresh pages cost more than the
// sums on a megapixel).
struct SeenFiltered {
    int x0 = 0, y0 = 0, w = 0, h = 0;  // the box filtered (w = 0: none)
    PoolVector<float> fa, fb;         // 3 per pixel of the box, per half
    bool in(int x, int y) const { return x >= x0 && y >= y0 && x < x0 + w && y < y0 + h; }
    size_t at(int x, int y) const { return (size_t(y - y0) * size_t(w) + size_t(x - x0)) * 3; }
};

SeenFiltered filter_seen(int W, int H, int r, int threads, const PoolVector<float>& ea, const PoolVector<float>& eb) {
    SeenFiltered out;
    // Noisy: the halves differ by more than a thousandth of the light.
    auto noisy = [&](size_t p) {
        for (int k = 0; k < 3; ++k) {
            const float a = ea[p * 3 + k], b = eb[p * 3 + k], d = a - b;
            if (d * d > 1e-3f * 0.25f * (a + b) * (a + b) + 1e-8f) return true;
        }
        return false;
    };
    int nx0 = W, nx1 = -1, ny0 = H, ny1 = -1;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            if (noisy(size_t(y) * W + x)) nx0 = std::min(nx0, x), nx1 = std::max(nx1, x), ny0 = std::min(ny0, y), ny1 = std::max(ny1, y);
    if (nx1 < 0) return out;
    // The guides' box: what the windows of the pixels within r of a noisy one read.
    const int gx0 = std::max(0, nx0 - 2 * r), gy0 = std::max(0, ny0 - 2 * r);
    const int gw = std::min(W - 1, nx1 + 2 * r) - gx0 + 1, gh = std::min(H - 1, ny1 + 2 * r) - gy0 + 1;
    const size_t gn = size_t(gw) * gh;
    auto global = [&](int gx, int gy) { return size_t(gy0 + gy) * W + size_t(gx0 + gx); };
    PoolVector<uint8_t> is_noisy(gn, 0);
    for (int y = 0; y < gh; ++y)
        for (int x = 0; x < gw; ++x) is_noisy[size_t(y) * gw + x] = noisy(global(x, y));
    // Within d of a noisy pixel (rows, then columns), in the guides' box.
    auto within = [&](int d) {
        PoolVector<uint8_t> rows(gn, 0), mark(gn, 0);
        for (int y = 0; y < gh; ++y)
            for (int x = 0; x < gw; ++x)
                if (is_noisy[size_t(y) * gw + x])
                    for (int xx = std::max(0, x - d); xx <= std::min(gw - 1, x + d); ++xx) rows[size_t(y) * gw + xx] = 1;
        for (int y = 0; y < gh; ++y)
            for (int x = 0; x < gw; ++x)
                if (rows[size_t(y) * gw + x])
                    for (int yy = std::max(0, y - d); yy <= std::min(gh - 1, y + d); ++yy) mark[size_t(yy) * gw + x] = 1;
        return mark;
    };
    const PoolVector<uint8_t> near = within(r), read = within(2 * r);  // filtered; their windows
    // Guides (3×3 means of each half) and their variance, where a window reads them.
    PoolVector<float> gA(gn * 3), gB(gn * 3), var(gn);
    for_bands(gh, threads, [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y)
            for (int x = 0; x < gw; ++x) {
                const size_t g = size_t(y) * gw + x;
                if (!read[g]) continue;
                var[g] = guide_3x3(W, H, gx0 + x, gy0 + y, ea.data(), eb.data(), 3, [](size_t) { return true; }, &gA[g * 3], &gB[g * 3]);
            }
    });
    // The box filtered: the noisy pixels' grown by r.
    out.x0 = std::max(0, nx0 - r);
    out.y0 = std::max(0, ny0 - r);
    out.w = std::min(W - 1, nx1 + r) - out.x0 + 1;
    out.h = std::min(H - 1, ny1 + r) - out.y0 + 1;
    out.fa.resize(size_t(out.w) * out.h * 3);
    out.fb.resize(out.fa.size());
    constexpr float kK2 = 0.45f * 0.45f;
    for_bands(out.h, threads, [&](int y0, int y1) {
        for (int by = y0; by < y1; ++by)
            for (int bx = 0; bx < out.w; ++bx) {
                const int x = out.x0 + bx, y = out.y0 + by;
                const size_t p = size_t(y) * W + x, o = out.at(x, y), g = size_t(y - gy0) * gw + size_t(x - gx0);
                for (int k = 0; k < 3; ++k) {
                    out.fa[o + k] = ea[p * 3 + k];
                    out.fb[o + k] = eb[p * 3 + k];
                }
                if (!near[g]) continue;
                double s[2][3] = {}, w[2] = {};
                for (int oy = -r; oy <= r; ++oy)
                    for (int ox = -r; ox <= r; ++ox) {
                        const int xx = x + ox, yy = y + oy;
                        if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
                        const size_t q = size_t(yy) * W + xx, gq = size_t(yy - gy0) * gw + size_t(xx - gx0);
                        const float vi = var[g], vq = var[gq];
                        const float scale = 1.f / (3.f * (1e-8f + kK2 * (vi + vq)));
                        const float floor = vi + std::min(vi, vq);
                        for (int h = 0; h < 2; ++h) {
                            const PoolVector<float>& gd = h == 0 ? gB : gA;  // the other half's guide
                            float d2 = 0.f;
                            for (int k = 0; k < 3; ++k) {
                                const float e = gd[g * 3 + k] - gd[gq * 3 + k];
                                d2 += e * e - floor;
                            }
                            const float wt = exp_nonpositive(-std::max(d2 * scale, 0.f));
                            if (!(wt > 0.f)) continue;
                            const PoolVector<float>& v = h == 0 ? ea : eb;
                            for (int k = 0; k < 3; ++k) s[h][k] += double(wt) * v[q * 3 + k];
                            w[h] += wt;
                        }
                    }
                for (int k = 0; k < 3; ++k) {
                    if (w[0] > 0) out.fa[o + k] = float(s[0][k] / w[0]);
                    if (w[1] > 0) out.fb[o + k] = float(s[1][k] / w[1]);
                }
            }
    });
    return out;
}

// Box means over radius r, each pixel pooled with its own kind only (`kind` 1 or 0): an error
// estimate of a pixel that saw a lamp or the sky beside it (an edge whose coverage noise no
// filter removes) says nothing of the surface next to it. Every map of a denoising is pooled
// over the same kinds, so their share around each pixel is found once.
class Pooling {
public:
    // `scratch`: the row sums, which poolings used one after another share.
    Pooling(const PoolVector<uint8_t>& kind, int W, int H, int r, int threads, PoolVector<double>& scratch)
        : kind_(kind), w_(W), h_(H), r_(r), threads_(threads), rows_(scratch) {
        share_.resize(kind.size());
        means(PoolVector<float>(kind.size(), 1.f), [&](size_t p, double, double m1) { share_[p] = float(m1); });
    }
    PoolVector<float> operator()(const PoolVector<float>& a) const {
        PoolVector<float> out(a.size());
        means(a, [&](size_t p, double m0, double m1) {
            out[p] = kind_[p] ? float(m1) / std::max(share_[p], 1e-6f) : float(m0) / std::max(1.f - share_[p], 1e-6f);
        });
        return out;
    }

private:
    // emit(p, m0, m1): the box means at p of `a` where the kind is 0 and where it is 1 (zero
    // elsewhere). Rows then columns, each row's and each column's running sum its own (O(1) per
    // pixel whatever the radius), so bands of rows and strips of columns run on threads of their
    // own and every sum is taken in one order. Both kinds in one pass, into scratch kept between
    // calls (a denoising pools some twenty maps; fresh pages for each cost more than the sums).
    template <class Emit>
    void means(const PoolVector<float>& a, Emit&& emit) const {
        const int W = w_, H = h_, r = r_;
        PoolVector<double>& rows = rows_;
        rows.resize(a.size() * 2);
        for_bands(H, threads_, [&](int y0, int y1) {
            for (int y = y0; y < y1; ++y) {
                const size_t row = size_t(y) * W;
                auto in = [&](int x, int k) { return (kind_[row + x] != 0) == (k == 1) ? double(a[row + x]) : 0.0; };
                double s[2] = {0, 0};
                for (int x = 0; x <= std::min(W - 1, r); ++x)
                    for (int k = 0; k < 2; ++k) s[k] += in(x, k);
                for (int x = 0; x < W; ++x) {
                    const double cnt = double(std::min(W - 1, x + r) - std::max(0, x - r) + 1);
                    for (int k = 0; k < 2; ++k) {
                        rows[(row + x) * 2 + k] = s[k] / cnt;
                        if (x + r + 1 < W) s[k] += in(x + r + 1, k);
                        if (x - r >= 0) s[k] -= in(x - r, k);
                    }
                }
            }
        });
        // A strip of columns per thread: each column's sums are its own whatever the strips, and
        // wide strips read the rows in long runs.
        for_strips(W, threads_, [&](int x0, int x1) {
            const size_t span = size_t(x1 - x0) * 2;
            PoolVector<double> col(span, 0.0);
            auto add = [&](int y, double sign) {
                const double* rw = &rows[(size_t(y) * W + x0) * 2];
                for (size_t i = 0; i < span; ++i) col[i] += sign * rw[i];
            };
            for (int y = 0; y <= std::min(H - 1, r); ++y) add(y, 1.0);
            for (int y = 0; y < H; ++y) {
                const double cnt = double(std::min(H - 1, y + r) - std::max(0, y - r) + 1);
                for (int x = x0; x < x1; ++x)
                    emit(size_t(y) * W + x, col[size_t(x - x0) * 2] / cnt, col[size_t(x - x0) * 2 + 1] / cnt);
                if (y + r + 1 < H) add(y + r + 1, 1.0);
                if (y - r >= 0) add(y - r, -1.0);
            }
        });
    }

    const PoolVector<uint8_t>& kind_;
    int w_, h_, r_, threads_;
    PoolVector<float> share_;
    PoolVector<double>& rows_;
};

}  // namespace

bool can_denoise(const Film& film) {
    const AovLayout& l = film.aov_layout;
    return !film.sum_odd.empty() && l.has(Aov::albedo) && l.has(Aov::normal) && l.has(Aov::depth);
}

namespace {

std::optional<Denoised> denoise_in_use(const Film& film, int threads, DenoiseCandidates* candidates) {
    if (!can_denoise(film) || film.sum.empty()) return std::nullopt;
    if (*std::min_element(film.count.begin(), film.count.end()) < 2) return std::nullopt;
    if (threads <= 0) threads = int(std::max(1u, std::thread::hardware_concurrency()));
    const int W = film.width, H = film.height;
    const size_t n = size_t(W) * H;
    auto plane = [&](Aov a) {  // can_denoise checked albedo, normal and depth are there
        PoolVector<float> v(n * size_t(aov_info(a).components));
        film.resolve_aov(a, v.data());
        return v;
    };
    const PoolVector<float> albedo = plane(Aov::albedo), normal = plane(Aov::normal), depth = plane(Aov::depth);
    // The variance of each pixel's mean from its samples' second moment, where the film keeps it
    // (films written before it did not): the rules below that judge a pixel by its own noise.
    const PoolVector<float> spread_plane = film.aov_layout.has(Aov::variance) ? plane(Aov::variance) : PoolVector<float>();
    const PoolVector<float>* spread = spread_plane.empty() ? nullptr : &spread_plane;

    Inputs in;
    in.w = W;
    in.h = H;
    in.f.resize(n * kF);
    in.y.resize(n * kY);
    in.m.resize(n * 3);
    in.use.resize(n);
    PoolVector<float> xa(n * 3), xb(n * 3), wa(n);  // the halves, and the even half's share of the samples
    PoolVector<float> ea(n * 3), eb(n * 3);          // the light each half saw directly
    float zmax = 0.f;
    for (size_t p = 0; p < n; ++p)
        if (depth[p] < float(kNoDepth) * 0.5f) zmax = std::max(zmax, depth[p]);
    const float zscale = zmax > 0.f ? 1.f / zmax : 1.f;
    for_pixels(W, H, threads, [&](size_t p) {
        const uint32_t c = film.count[p];
        const double na = double((c + 1) / 2), nb = double(c / 2);
        wa[p] = float(na / double(c));
        in.use[p] = film.seen[p] == glm::dvec3(0.0) && depth[p] < float(kNoDepth) * 0.5f;
        // The share of the pixel's samples that hit a surface: a miss adds a zero normal, so the
        // mean normal's length (of a pixel on one surface). Albedo is over the hits, so that a
        // pixel on a silhouette divides by its surface's albedo times its coverage, as its colour is.
        const glm::vec3 nn(normal[p * 3], normal[p * 3 + 1], normal[p * 3 + 2]);
        const float len = glm::length(nn), cover = std::clamp(len, 0.05f, 1.f);
        for (int k = 0; k < 3; ++k) {
            ea[p * 3 + k] = float((film.seen[p][k] - film.seen_odd[p][k]) / na);
            eb[p * 3 + k] = float(film.seen_odd[p][k] / nb);
            const float a = albedo[p * 3 + k];
            const float m = std::max(a / cover, kAlbedoFloor) * cover;
            xa[p * 3 + k] = float((film.sum[p][k] - film.sum_odd[p][k]) / na);
            xb[p * 3 + k] = float(film.sum_odd[p][k] / nb);
            in.m[p * 3 + k] = m;
            in.y[p * kY + k] = (xa[p * 3 + k] - ea[p * 3 + k]) / m;
            in.y[p * kY + 3 + k] = (xb[p * 3 + k] - eb[p * 3 + k]) / m;
        }
        for (int k = 0; k < 3; ++k) in.f[p * kF + k] = len > 1e-6f ? nn[k] / len : 0.f;
        in.f[p * kF + 3] = depth[p] < float(kNoDepth) * 0.5f ? depth[p] * zscale : 2.f;
        in.f[p * kF + 4] = float(p % size_t(W)) / 16.f;
        in.f[p * kF + 5] = float(p / size_t(W)) / 16.f;
    });

    PoolVector<double> pooling_rows;
    const Pooling pool_wide(in.use, W, H, kSmooth, threads, pooling_rows),
        pool_bias(in.use, W, H, kBiasSmooth, threads, pooling_rows), pool_near(in.use, W, H, 1, threads, pooling_rows);
    constexpr size_t C = kDenoiseCandidates.size();
    std::array<PoolVector<float>, C> halves;  // each candidate's two filtered halves
    PoolVector<float> nlm_variance;            // the NL-means pair's variance as their weights make it (filter_nlm)
    for (size_t c = 1; c < C; ++c) {
        const DenoiseCandidate& cand = kDenoiseCandidates[c];
        if (cand.filter == DenoiseFilter::box_regression) filter(in, cand.radius, threads, halves[c]);
        else if (cand.filter == DenoiseFilter::nlm)
            filter_nlm(in, cand.radius, threads, halves[kBoxRegression], wa, halves[c], halves[kNlmRegression], nlm_variance);
        else continue;  // the NL-means regression: made with NL-means, from its weights
    }
    halves[0].resize(n * kY);  // the noisy halves themselves
    for_pixels(W, H, threads, [&](size_t p) {
        for (size_t c = 1; c < C; ++c)
            for (int k = 0; k < 3; ++k) {
                halves[c][p * kY + k] += ea[p * 3 + k];
                halves[c][p * kY + 3 + k] += eb[p * 3 + k];
            }
        for (int k = 0; k < 3; ++k) {
            halves[0][p * kY + k] = xa[p * 3 + k];
            halves[0][p * kY + 3 + k] = xb[p * 3 + k];
        }
    });
    auto combined = [&](size_t c, size_t p, int k) {
        return wa[p] * halves[c][p * kY + k] + (1.f - wa[p]) * halves[c][p * kY + 3 + k];
    };
    // Relative errors are taken against a stand-in for the truth, the same for every candidate:
    // the NL-means candidate's output, which keeps shadows and highlights and carries little
    // noise. (Not a box window's: beside a highlight it is wrong both ways; not the noisy pixel:
    // where it is bright by chance, its error would be weighed the least.)
    auto at = [&](size_t c, size_t p, int k, int half) { return double(halves[c][p * kY + 3 * half + k]); };
    PoolVector<float> q(n * 3);
    for_pixels(W, H, threads, [&](size_t p) {
        for (int k = 0; k < 3; ++k) {
            // The product of the two halves' outputs: unbiased for the square of the truth, where
            // the square of their mean is too large by its variance (which made every relative
            // error a third too small at 4 spp). No less than a quarter of that square, though:
            // a lamp's edge seen by one half only would make it zero.
            const double fa = at(C - 1, p, k, 0), fb = at(C - 1, p, k, 1);  // NL-means is the last
            const double r2 = std::max(fa * fb, 0.0625 * (fa + fb) * (fa + fb));
            q[p * 3 + k] = float(1.0 / (r2 + kEps));
        }
    });
    // The pixel's own noise from its samples' spread, relative as `rel` is. Two halves alone
    // cannot tell a highlight the features do not explain from a rare bright path that both
    // halves happened to sample (in a diffuse box at 32 spp, 1.4% of the pixels; they carried
    // 46% of the denoised image's error, every candidate refused by the rules below): both make
    // the halves agree far from their neighbours. The samples' spread tells them apart: a
    // highlight's samples agree with each other, a bright path's do not.
    PoolVector<double> spread_q(n, 0.0), spread0(n, 0.0);
    if (spread)
        for_pixels(W, H, threads, [&](size_t p) {
            for (int k = 0; k < 3; ++k) spread_q[p] += q[p * 3 + k] * double((*spread)[p * 3 + k]) / 3.0;
        });
    // Each candidate's error per pixel from the two independent halves A and B; f is the
    // candidate, applied to each. Exactly, with nothing to calibrate:
    //   MSE = [(f(A) − B)² + (f(B) − A)²]/2 − (A − B)²/2 − (f(A) − f(B))²/4         (cross-validation)
    // but per pixel that is about (A − μ)(B − μ), the product of two raw noises, whose heavy tail
    // (a firefly in one half) swamps a strong filter's small error. So only the first filter's
    // bias is taken from it, pooled over a wide neighbourhood; the rest from filtered
    // differences, which carry little noise:
    //   variance of candidate c: (f_c(A) − f_c(B))²/4, or for the NL-means pair the variance
    //     their weights give where more (variance_of, below)
    //   its bias beyond the first filter's: (d_c − d_1)² less the variance of d_c − d_1,
    //     ((f_c(A) − f_1(A)) − (f_c(B) − f_1(B)))²/4
    // and for the noisy image, (A − B)²/4. The first filter's bias subtracts its halves' variance,
    // not the larger one from its weights: its cross-validation is itself read low by the same
    // cross-filtering (docs/denoising.md, "Why it leans low"), so what the halves miss is not in
    // it. Subtracting the larger one instead: estimates 3-10 % lower, errors within ±6 % either
    // way on the four bench scenes at 320×240 (docs/denoising.md).
    PoolVector<float> cv1(n);
    for_pixels(W, H, threads, [&](size_t p) {
        double e = 0, v = 0;
        for (int k = 0; k < 3; ++k) {
            const double fa = at(1, p, k, 0), fb = at(1, p, k, 1), a = xa[p * 3 + k], b = xb[p * 3 + k];
            e += q[p * 3 + k] * (0.5 * ((fa - b) * (fa - b) + (fb - a) * (fb - a)) - 0.5 * (a - b) * (a - b) - 0.25 * (fa - fb) * (fa - fb));
            v += q[p * 3 + k] * 0.25 * (fa - fb) * (fa - fb);
        }
        cv1[p] = float((e - v) / 3.0);  // the first filter's bias², per pixel (noisy)
    });
    // Each pixel's term held within K times the noise around: (A − μ)(B − μ) is symmetric about
    // zero where the filter has no bias and heavy-tailed (a rare bright path that both halves
    // sampled makes it huge); pooled as it is, the tail was read as bias over whole
    // neighbourhoods (the Cornell box's estimate at 8 spp, 48×36: 3.6 times the truth, once the
    // rules below let such pixels be filtered).
    PoolVector<float> bias1(n, 0.f);  // the last round's pooled terms
    {
        PoolVector<float> noise(n);
        for_pixels(W, H, threads, [&](size_t p) {
            double v = 0;
            for (int k = 0; k < 3; ++k) v += q[p * 3 + k] * 0.25 * (xa[p * 3 + k] - xb[p * 3 + k]) * (xa[p * 3 + k] - xb[p * 3 + k]);
            noise[p] = float(v / 3.0);
        });
        noise = pool_wide(noise);
        // Where the filter is biased every term is about the bias², which a bound of the noise
        // alone would cut (at 1024 spp the estimate fell to 0.4 of the truth): the bound grows
        // with the bias pooled under the bound before, by up to the noise each round (so to
        // about nine times the noise in eight; four rounds put the glossy box's estimate at 0.49
        // of the truth at 1024 spp, and doubling each round the small Cornell box's at 2.08
        // times at 8 spp). A lone bright path barely moves its
        // neighbourhood's pooled bias, so its bound stays near the noise. Where the bias is far
        // above the noise the estimate errs low (docs/denoising.md).
        PoolVector<float>& bias = bias1;
        PoolVector<float> held(n);
        for (int round = 0; round < kBiasRounds; ++round) {
            for_pixels(W, H, threads, [&](size_t p) {
                const float bound = kBiasClamp * (noise[p] + std::max(0.f, bias[p]));
                held[p] = std::clamp(cv1[p], -bound, bound);
            });
            bias = pool_bias(held);
        }
    }
    // Per candidate: its variance, and its bias beyond the first filter's, pooled over the
    // neighbourhood (filtered differences are smooth: a pixel's own value says little that its
    // neighbours do not) and held at zero or more.
    // A candidate's variance per channel: its halves' difference, and for the NL-means pair, whose
    // halves read it low (filter_nlm), the larger of that and the variance their weights give.
    auto variance_of = [&](size_t c, size_t p, int k) {
        const double fa = at(c, p, k, 0), fb = at(c, p, k, 1), v = 0.25 * (fa - fb) * (fa - fb);
        if (!in.use[p] || (c != kNlmRegression && c != C - 1)) return v;
        return std::max(v, double(nlm_variance[p * 6 + (c == kNlmRegression ? 0 : 3) + k]));
    };
    std::array<PoolVector<float>, C> rel, pooled, bias_of;
    for (size_t c = 0; c < C; ++c) {
        rel[c].resize(n);
        bias_of[c].assign(n, 0.f);
        PoolVector<float> bias(n, 0.f);
        for_pixels(W, H, threads, [&](size_t p) {
            double v = 0, b = 0;
            for (int k = 0; k < 3; ++k) {
                const double fa = at(c, p, k, 0), fb = at(c, p, k, 1);
                v += q[p * 3 + k] * variance_of(c, p, k);
                if (c > 1) {
                    const double dc = combined(c, p, k) - combined(1, p, k);
                    const double vd = (fa - at(1, p, k, 0)) - (fb - at(1, p, k, 1));
                    b += q[p * 3 + k] * (dc * dc - 0.25 * vd * vd);
                }
            }
            rel[c][p] = float(v / 3.0);
            bias[p] = float(b / 3.0) + (c > 0 ? bias1[p] : 0.f);
        });
        if (c > 0) {
            bias = pool_bias(bias);
            for_pixels(W, H, threads, [&](size_t p) {
                bias_of[c][p] = std::max(0.f, bias[p]);
                rel[c][p] += bias_of[c][p];
            });
        }
        pooled[c] = pool_wide(rel[c]);
    }

    Denoised d;
    d.image = Image(W, H);
    d.error.resize(n);
    double est = 0, noisy_est = 0;
    std::array<size_t, C> taken{};
    // The pixel's own cross-validation (noisy, but not pooled away): a candidate whose output its
    // own samples contradict by far more than their noise is refused there, such as a highlight
    // the regression carried to a neighbour that has none (the features do not explain it).
    auto contradicted = [&](size_t c, size_t p) {
        double e = 0;
        for (int k = 0; k < 3; ++k) {
            const double fa = at(c, p, k, 0), fb = at(c, p, k, 1), a = xa[p * 3 + k], b = xb[p * 3 + k];
            e += q[p * 3 + k] * (0.5 * ((fa - b) * (fa - b) + (fb - a) * (fb - a)) - 0.5 * (a - b) * (a - b) - 0.25 * (fa - fb) * (fa - fb));
        }
        return e / 3.0 > kContradiction * (std::max(double(rel[0][p]), spread_q[p]) + double(pooled[0][p]) + double(pooled[c][p]));
    };
    // The pixel's departure from its own value, against its noise here and just around (not the
    // pooled neighbourhood's, which a highlight beside it inflates): a candidate that moves a
    // pixel by far more than both is wrong there, such as a pupil averaged with the white of the
    // eye beside it, which the pooled estimates do not see.
    // All relative to the pixel's own value (the product of its halves): the stand-in for the
    // truth used elsewhere is the NL-means candidate's output, which is the one at fault here.
    // `kept`: the noisy pixel's own error estimate as the convergence curve takes it
    // (kHalvesProductFloor), for the pixels that keep their value.
    PoolVector<float> q0(n * 3), own0(n), kept(n);
    for_pixels(W, H, threads, [&](size_t p) {
        double e = 0, ek = 0;
        for (int k = 0; k < 3; ++k) {
            const double a = xa[p * 3 + k], b = xb[p * 3 + k], x = combined(0, p, k), v = 0.25 * (a - b) * (a - b);
            q0[p * 3 + k] = float(1.0 / (std::max(a * b, 0.0625 * x * x) + kEps));
            e += q0[p * 3 + k] * v;
            ek += v / (std::max(a * b, kHalvesProductFloor * x * x) + kEps);
        }
        own0[p] = float(e / 3.0);
        kept[p] = float(ek / 3.0);
        if (spread)
            for (int k = 0; k < 3; ++k) spread0[p] += q0[p * 3 + k] * double((*spread)[p * 3 + k]) / 3.0;
    });
    const PoolVector<float> local0 = pool_near(own0);
    auto departs = [&](size_t c, size_t p) {
        double d = 0, v = 0;
        for (int k = 0; k < 3; ++k) {
            const double e = double(combined(c, p, k)) - combined(0, p, k), fa = at(c, p, k, 0), fb = at(c, p, k, 1);
            d += q0[p * 3 + k] * e * e;
            v += q0[p * 3 + k] * 0.25 * (fa - fb) * (fa - fb);
        }
        return d / 3.0 > kDeparture * (std::max({double(own0[p]), double(local0[p]), spread0[p]}) + v / 3.0);
    };
    if (candidates) {
        candidates->taken.assign(n, 0);
        candidates->weight.assign(n * C, 0.f);
        candidates->seen_shift.assign(n * 3, 0.f);
        for (size_t c = 0; c < C; ++c) {
            candidates->rgb[c].resize(n * 3);
            candidates->half_gap[c].resize(n * 3);
            candidates->variance[c].resize(n * 3);
            for (size_t p = 0; p < n; ++p)
                for (int k = 0; k < 3; ++k) {
                    candidates->half_gap[c][p * 3 + k] = float(0.5 * (at(c, p, k, 0) - at(c, p, k, 1)));
                    candidates->variance[c][p * 3 + k] = float(variance_of(c, p, k));
                }
            for (size_t p = 0; p < n; ++p)
                for (int k = 0; k < 3; ++k)
                    candidates->rgb[c][p * 3 + k] = c == 0 ? float(film.sum[p][k] / double(film.count[p])) : combined(c, p, k);
        }
    }
    // Dark detail: a pixel whose albedo is below the floor it is divided by (its colour is not
    // demodulated whole) beside one far brighter, such as the Duck's pupil by the white of its
    // eye. Every filter carries the bright side into it, and its own noise is large enough (a
    // highlight in part of it) that no estimate notices: measured, two such pixels made the
    // whole loss of the Duck at 16 spp (320×240), twice the noisy image's error.
    PoolVector<uint8_t> dark_detail(n, 0);
    for_bands(H, threads, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
        for (int x = 0; x < W; ++x) {
            const size_t p = size_t(y) * W + x;
            for (int k = 0; k < 3 && !dark_detail[p]; ++k) {
                if (!(albedo[p * 3 + k] < 0.999f * in.m[p * 3 + k])) continue;  // divided by its own albedo
                for (int dy = -1; dy <= 1 && !dark_detail[p]; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int xx = x + dx, yy = y + dy;
                        if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
                        if (in.m[(size_t(yy) * W + xx) * 3 + k] > kDarkDetail * in.m[p * 3 + k]) dark_detail[p] = 1;
                    }
            }
        }
    });
    // Each pixel's own; the sums over the image after, in one order whatever the threads.
    PoolVector<double> error_of(n);
    PoolVector<uint8_t> best_of(n);
    for_pixels(W, H, threads, [&](size_t p) {
        size_t best = 0;
        // A pixel that saw a lamp or the sky in part keeps its value: its colour less that light
        // is its surface's times a coverage known only from the same samples (the mean normal's
        // length), whose noise a filter of its neighbours would not share. That was most of the
        // Duck's loss at 16 and 32 spp (its silhouette against the sky).
        std::array<bool, C> allowed{};
        allowed[0] = true;
        if (in.use[p] && !dark_detail[p])
            for (size_t c = 1; c < C; ++c) {
                allowed[c] = !contradicted(c, p) && !departs(c, p);
                if (allowed[c] && pooled[c][p] < pooled[best][p]) best = c;
            }
        // Nor where its own estimate here is above what the noisy pixel's is, here or around.
        if (rel[best][p] > std::max(rel[0][p], pooled[0][p])) best = 0;
        best_of[p] = uint8_t(best);
        if (candidates) candidates->taken[p] = uint8_t(best);
        // A filtered pixel is the blend of the noisy pixel and every candidate not refused there,
        // each weighed by the inverse square of its pooled estimate (so the best leads): their
        // errors differ in kind (a regression's bias at a gradient, NL-means' at a shadow). Its
        // error estimate: its variance from its own halves, or from its candidates' where more
        // (below), and its bias² no more than the weighted mean of theirs (the square is
        // convex). The noisy candidate is the film's own mean, not the halves' mix (the same up
        // to rounding).
        std::array<double, C> w{};
        double wsum = 0;
        if (best != 0)
            for (size_t c = 0; c < C; ++c) {
                if (!allowed[c]) continue;
                const double e = double(pooled[c][p]) + 1e-12;
                w[c] = 1.0 / (e * e);
                wsum += w[c];
            }
        else
            w[0] = wsum = 1.0;
        double e = 0;
        for (int k = 0; k < 3; ++k) {
            double v = w[0] / wsum * (film.sum[p][k] / double(film.count[p])), ba = 0, bb = 0;
            for (size_t c = 0; c < C; ++c)
                if (w[c] > 0) {
                    if (c > 0) v += w[c] / wsum * combined(c, p, k);
                    ba += w[c] / wsum * at(c, p, k, 0);
                    bb += w[c] / wsum * at(c, p, k, 1);
                }
            d.image.rgb[p * 3 + k] = float(v);
            // Its variance: its halves' difference, or where more, what its candidates' give it
            // if their noise were one (they filter the same samples): (Σ w_c σ_c)².
            double sd = 0;
            if (best != 0)
                for (size_t c = 0; c < C; ++c)
                    if (w[c] > 0) sd += w[c] / wsum * std::sqrt(variance_of(c, p, k));
            e += q[p * 3 + k] * std::max(0.25 * (ba - bb) * (ba - bb), sd * sd) / 3.0;
        }
        for (size_t c = 0; c < C; ++c) {
            e += w[c] / wsum * bias_of[c][p];
            if (candidates) candidates->weight[p * C + c] = float(w[c] / wsum);
        }
        // A pixel that keeps its value: its error relative to its own halves (the candidates'
        // common stand-in is another filter's output, wrong for a pixel no filter may touch, such
        // as a silhouette against the sky), as the convergence curve's estimate is.
        if (best == 0) e = kept[p];
        d.error[p] = float(e);
        d.image.sample_count[p] = float(film.count[p]);
        error_of[p] = e;
    });
    // The light seen directly, blended with its own NL-means (filter_seen) by their estimated
    // errors, pooled over every pixel around whatever it saw: the seen light's own (its halves'
    // difference, which a pixel whose samples all missed a halo shows as none while its
    // neighbours show it) and the filtered light's (its halves' difference, and its bias against
    // the light as seen, which is unbiased: their squared difference less its variance).
    const SeenFiltered sf = filter_seen(W, H, kSeenRadius, threads, ea, eb);
    // Only where the filter moved the light (elsewhere it is the same signal), and only over the
    // box around those pixels that their poolings read.
    int bx0 = W, bx1 = -1, by0 = H, by1 = -1;
    for (int y = sf.y0; y < sf.y0 + sf.h; ++y)
        for (int x = sf.x0; x < sf.x0 + sf.w; ++x) {
            const size_t p = size_t(y) * W + x, o = sf.at(x, y);
            bool moved = false;
            for (int k = 0; k < 3; ++k) moved = moved || sf.fa[o + k] != ea[p * 3 + k] || sf.fb[o + k] != eb[p * 3 + k];
            if (moved) bx0 = std::min(bx0, x), bx1 = std::max(bx1, x), by0 = std::min(by0, y), by1 = std::max(by1, y);
        }
    if (bx1 >= 0) {
        constexpr int reach = std::max(kSmooth, kBiasSmooth);
        bx0 = std::max(0, bx0 - reach), by0 = std::max(0, by0 - reach), bx1 = std::min(W - 1, bx1 + reach), by1 = std::min(H - 1, by1 + reach);
        const int bw = bx1 - bx0 + 1, bh = by1 - by0 + 1;
        const size_t bn = size_t(bw) * bh;
        auto xy = [&](size_t b) { return std::pair<int, int>(bx0 + int(b % size_t(bw)), by0 + int(b / size_t(bw))); };
        // The filtered light at a pixel of the box (the light as seen outside what was filtered).
        auto filtered = [&](int x, int y, int k, int half) {
            const PoolVector<float>& raw = half == 0 ? ea : eb;
            if (!sf.in(x, y)) return raw[(size_t(y) * W + x) * 3 + k];
            return (half == 0 ? sf.fa : sf.fb)[sf.at(x, y) + k];
        };
        PoolVector<float> own(bn), fvar(bn), fbias(bn);
        PoolVector<uint8_t> moved(bn, 0);
        for_pixels(bw, bh, threads, [&](size_t b) {
            const auto [x, y] = xy(b);
            const size_t p = size_t(y) * W + x;
            double o = 0, v = 0, bias = 0;
            for (int k = 0; k < 3; ++k) {
                const size_t i = p * 3 + k;
                const double fa = filtered(x, y, k, 0), fb = filtered(x, y, k, 1);
                moved[b] = moved[b] || fa != ea[i] || fb != eb[i];
                const double em = wa[p] * ea[i] + (1.0 - wa[p]) * eb[i], fm = wa[p] * fa + (1.0 - wa[p]) * fb;
                const double dv = (fa - ea[i]) - (fb - eb[i]);
                o += q[i] * 0.25 * (double(ea[i]) - eb[i]) * (double(ea[i]) - eb[i]);
                v += q[i] * 0.25 * (fa - fb) * (fa - fb);
                bias += q[i] * ((fm - em) * (fm - em) - 0.25 * dv * dv);
            }
            own[b] = float(o / 3.0);
            fvar[b] = float(v / 3.0);
            fbias[b] = float(bias / 3.0);
        });
        const PoolVector<uint8_t> every(bn, 1);
        const Pooling pool_all(every, bw, bh, kSmooth, threads, pooling_rows), pool_all_bias(every, bw, bh, kBiasSmooth, threads, pooling_rows);
        const PoolVector<float> raw_e = pool_all(own), f_e = pool_all(fvar), f_b = pool_all_bias(fbias);
        for_pixels(bw, bh, threads, [&](size_t b) {
            const auto [x, y] = xy(b);
            const size_t p = size_t(y) * W + x;
            // (Box means of running sums: a map of zeros can come back as ±1e-19.)
            const double er = raw_e[b], ef = std::max(0.0, double(f_e[b])) + std::max(0.0, double(f_b[b]));
            if (!moved[b] || !(er > 1e-12)) return;
            const double w = er / (er + ef);
            if (!std::isfinite(w)) return;
            for (int k = 0; k < 3; ++k) {
                const size_t i = p * 3 + k;
                const double em = wa[p] * ea[i] + (1.0 - wa[p]) * eb[i];
                const double fm = wa[p] * double(filtered(x, y, k, 0)) + (1.0 - wa[p]) * double(filtered(x, y, k, 1));
                const double shift = w * (fm - em);
                d.image.rgb[i] = float(double(d.image.rgb[i]) + shift);
                if (candidates) candidates->seen_shift[i] = float(shift);
            }
            const double e = std::max(0.0, error_of[p] - double(own[b])) + w * w * ef + (1.0 - w) * (1.0 - w) * er;
            d.error[p] = float(e);
            error_of[p] = e;
        });
    }
    for (size_t p = 0; p < n; ++p) {
        est += error_of[p];
        noisy_est += kept[p];
        ++taken[best_of[p]];
    }
    d.est_rel_mse = est / double(n);
    d.noisy_est_rel_mse = noisy_est / double(n);
    // Where the estimate says the whole image gains nothing (a render so converged that the
    // filters' changes are within its pixels' own noise), it is given back as rendered: the
    // blend's per-pixel choices then move pixels by their noise alone, a coin flip over seeds
    // (docs/denoising.md, "Never worse"). Its error map is then the noisy pixels', which guided
    // sampling spends the next pass by: the image it refines is the rendered one. Only from
    // kTrustedMeanSamples a pixel: below, the halves' estimate of the noisy image is itself too
    // noisy to decide by (through a thin lens at 8 spp it said nothing was gained where the
    // denoiser gained 1.7 times).
    double mean_count = 0;
    for (size_t p = 0; p < n; ++p) mean_count += film.count[p];
    mean_count /= double(n);
    if (mean_count >= kTrustedMeanSamples && !(d.est_rel_mse < d.noisy_est_rel_mse)) {
        film.resolve_into(d.image);  // bit for bit the rendered image
        for (size_t p = 0; p < n; ++p) d.error[p] = kept[p];
        if (candidates) {
            std::fill(candidates->taken.begin(), candidates->taken.end(), uint8_t(0));
            std::fill(candidates->seen_shift.begin(), candidates->seen_shift.end(), 0.f);
            for (size_t p = 0; p < n; ++p)
                for (size_t c = 0; c < C; ++c) candidates->weight[p * C + c] = c == 0 ? 1.f : 0.f;
        }
        d.est_rel_mse = d.noisy_est_rel_mse;
        taken.fill(0);
        taken[0] = n;
    }
    for (size_t c = 0; c < C; ++c) d.share[c] = double(taken[c]) / double(n);
    return d;
}

}  // namespace

std::optional<Denoised> denoise(const Film& film, int threads, DenoiseCandidates* candidates, BlockPool* memory) {
    const auto t0 = std::chrono::steady_clock::now();
    std::optional<Denoised> d;
    {
        const BlockPool::Use use(memory);  // every map below, on every thread, takes from it
        if (memory) memory->set_fault_threads(threads > 0 ? threads : int(std::max(1u, std::thread::hardware_concurrency())));
        d = denoise_in_use(film, threads, candidates);
    }
    if (memory) memory->trim();
    if (d) d->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return d;
}

}  // namespace tessera
