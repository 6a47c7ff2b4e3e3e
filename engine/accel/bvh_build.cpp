// The four BVH builders: none (one leaf), midpoint and median splits on the largest axis of
// the centroid bounds, and binned SAH (Wald, "On fast construction of SAH-based bounding
// volume hierarchies", 2007; pbrt-v4 section 7.3) over all three axes.
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>
#include <system_error>
#include <thread>

#include "engine/accel/bvh.h"
#include "engine/core/parallel.h"

namespace tessera {

const char* to_string(BvhType t) {
    switch (t) {
        case BvhType::none: return "none";
        case BvhType::midpoint: return "midpoint";
        case BvhType::median: return "median";
        case BvhType::sah: return "sah";
        case BvhType::embree: return "embree";
    }
    return "?";
}

bool parse_bvh_type(const std::string& s, BvhType& out) {
    for (BvhType t : {BvhType::none, BvhType::midpoint, BvhType::median, BvhType::sah, BvhType::embree})
        if (s == to_string(t)) { out = t; return true; }
    return false;
}

namespace {

// 32 bytes, two to a cache line (Embree's PrimRef): the centroid is recomputed where it is
// read, which costs less than carrying it through every partition.
// Laid out as two 16-byte rows (lo, id) and (hi, pad) so that binning loads each as one vector.
struct PrimRef {
    glm::vec3 lo;
    uint32_t id;
    glm::vec3 hi;
    uint32_t pad;
    Aabb bounds() const { return Aabb{lo, hi}; }
    // Halves first: lo + hi overflows near the float range (bit for bit Aabb::centroid elsewhere,
    // halving being exact).
    glm::vec3 centroid() const { return 0.5f * lo + 0.5f * hi; }
};
static_assert(sizeof(PrimRef) == 32);

// The SAH bin of a centroid's scaled offset: its whole part below nbins; 0 for NaN (a skipped
// axis), never a float-to-int conversion out of range.
inline int bin_of(float x, int nbins) { return x >= 1.f ? (x < float(nbins) ? int(x) : nbins - 1) : 0; }

// A bin's bounds: SSE rows where available (one min and one max per primitive and axis).
#if defined(__SSE2__)
struct Bin {
    __m128 lo = _mm_set1_ps(INFINITY), hi = _mm_set1_ps(-INFINITY);
    uint32_t n = 0;
    // Operands in glm::min/max's order (the new value wins only when strictly smaller or
    // larger), so that even the sign of a zero bound is what the scalar code would give.
    void add(__m128 plo, __m128 phi) { lo = _mm_min_ps(plo, lo); hi = _mm_max_ps(phi, hi); ++n; }
    Aabb box() const {
        alignas(16) float l[4], h[4];
        _mm_store_ps(l, lo);
        _mm_store_ps(h, hi);
        return Aabb{{l[0], l[1], l[2]}, {h[0], h[1], h[2]}};
    }
};
#else
struct Bin {
    Aabb b;
    uint32_t n = 0;
    Aabb box() const { return b; }
};
#endif

struct Builder {
    const BvhBuildOptions& opt;
    LargeVector<PrimRef>& refs;
    LargeVector<BvhNode>& nodes;
    int max_depth_seen = 0;
    // Scratch reused across nodes, so that a build allocates O(1) times, not once per node.
    std::vector<Bin> bins;
    std::vector<float> right_area;
    std::vector<uint32_t> right_count;

    struct Split {
        int axis = -1;
        size_t mid = 0;  // refs[begin, mid) go left after partitioning
        Aabb lb, lcb, rb, rcb;  // children's bounds and centroid bounds (SAH only)
        bool bounds_known = false;
    };

    // Partitions by `goes_left` and accumulates both sides' bounds in the same pass, so the
    // children need no pass of their own to find them.
    template <class Pred>
    size_t partition_with_bounds(size_t begin, size_t end, Pred goes_left, Split& s) {
        size_t i = begin, j = end;
        for (;;) {
            while (i < j && goes_left(refs[i])) { s.lb.expand(refs[i].bounds()); s.lcb.expand(refs[i].centroid()); ++i; }
            while (i < j && !goes_left(refs[j - 1])) { s.rb.expand(refs[j - 1].bounds()); s.rcb.expand(refs[j - 1].centroid()); --j; }
            if (i >= j) break;
            std::swap(refs[i], refs[j - 1]);
        }
        s.bounds_known = true;
        return i;
    }

    void make_leaf(uint32_t node, const Aabb& b, size_t begin, size_t end) {
        nodes[node] = BvhNode{b.lo, uint32_t(begin), b.hi, uint32_t(end - begin)};
    }

    size_t median_split(size_t begin, size_t end, int axis) {
        const size_t mid = begin + (end - begin) / 2;
        std::nth_element(refs.begin() + begin, refs.begin() + mid, refs.begin() + end,
                         [axis](const PrimRef& a, const PrimRef& b) { return a.centroid()[axis] < b.centroid()[axis]; });
        return mid;
    }

    size_t midpoint_split(size_t begin, size_t end, int axis, const Aabb& cb) {
        const float plane = 0.5f * (cb.lo[axis] + cb.hi[axis]);
        auto it = std::partition(refs.begin() + begin, refs.begin() + end,
                                 [axis, plane](const PrimRef& r) { return r.centroid()[axis] < plane; });
        size_t mid = size_t(it - refs.begin());
        if (mid == begin || mid == end) mid = median_split(begin, end, axis);
        return mid;
    }

    // Returns the SAH split, or axis -1 when a leaf is cheaper (and allowed).
    Split sah_split(size_t begin, size_t end, const Aabb& b, const Aabb& cb) {
        // Small nodes get fewer bins: more bins than primitives only add fixed cost, and the
        // ~n/2 nodes near the leaves would otherwise dominate the build.
        const int nbins = std::max(2, std::min(opt.sah_bins, int(end - begin)));
        bins.assign(size_t(nbins) * 3, Bin{});
        glm::vec3 scale;
        const glm::vec3 ext = cb.extent();
        // An extent too small for a finite scale (centroids within ~1e-37) or too large for a
        // non-zero one (coordinates near the float range) is not binned: that axis is skipped.
        for (int a = 0; a < 3; ++a) {
            const float sa = ext[a] > 0.f ? float(nbins) * (1.f - 1e-6f) / ext[a] : 0.f;
            scale[a] = std::isfinite(sa) && sa > 0.f && std::isfinite(ext[a]) ? sa : 0.f;
        }
#if defined(__SSE2__)
        // The same arithmetic as the scalar centroid and bin index, four lanes at once (the
        // fourth, id and padding, is never read).
        const __m128 base = _mm_setr_ps(cb.lo.x, cb.lo.y, cb.lo.z, 0.f), mul = _mm_setr_ps(scale.x, scale.y, scale.z, 0.f);
        const __m128 half = _mm_set1_ps(0.5f);
        // The fourth lane (the id read as a float: a denormal below 2^23) is cleared, or every
        // add and multiply on it would take the processor's slow path for denormals.
        const __m128 xyz = _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0));
        Bin* const bx = bins.data();
        Bin* const by = bx + nbins;
        Bin* const bz = by + nbins;
        for (size_t i = begin; i < end; ++i) {
            const __m128 lo = _mm_and_ps(_mm_loadu_ps(&refs[i].lo.x), xyz), hi = _mm_and_ps(_mm_loadu_ps(&refs[i].hi.x), xyz);
            alignas(16) int k[4];
            _mm_store_si128(reinterpret_cast<__m128i*>(k),
                            _mm_cvttps_epi32(_mm_mul_ps(_mm_sub_ps(_mm_add_ps(_mm_mul_ps(half, lo), _mm_mul_ps(half, hi)), base), mul)));
            // A skipped axis (scale 0) can give 0·∞ = NaN, which converts to INT_MIN: bin 0.
            bx[std::clamp(k[0], 0, nbins - 1)].add(lo, hi);
            by[std::clamp(k[1], 0, nbins - 1)].add(lo, hi);
            bz[std::clamp(k[2], 0, nbins - 1)].add(lo, hi);
        }
#else
        for (size_t i = begin; i < end; ++i) {
            const PrimRef& r = refs[i];
            const glm::vec3 c = r.centroid();
            for (int a = 0; a < 3; ++a) {
                Bin& bin = bins[size_t(a) * nbins + bin_of((c[a] - cb.lo[a]) * scale[a], nbins)];
                bin.b.expand(r.bounds());
                ++bin.n;
            }
        }
#endif
        const size_t n = end - begin;
        const uint32_t block = uint32_t(std::max(1, opt.leaf_block));
        auto blocks = [block](uint32_t count) { return float((count + block - 1) / block); };
        float best_cost = INFINITY;
        int best_axis = -1, best_bin = 0;
        right_area.assign(nbins, 0.f);
        right_count.assign(nbins, 0);
        for (int a = 0; a < 3; ++a) {
            if (scale[a] == 0.f) continue;
            const Bin* ab = &bins[size_t(a) * nbins];
            Aabb acc; uint32_t cnt = 0;
            for (int k = nbins - 1; k > 0; --k) {
                acc.expand(ab[k].box()); cnt += ab[k].n;
                right_area[k] = acc.surface_area(); right_count[k] = cnt;
            }
            acc = Aabb{}; cnt = 0;
            for (int k = 0; k < nbins - 1; ++k) {
                acc.expand(ab[k].box()); cnt += ab[k].n;
                if (cnt == 0 || right_count[k + 1] == 0) continue;
                const float cost = acc.surface_area() * blocks(cnt) + right_area[k + 1] * blocks(right_count[k + 1]);
                if (cost < best_cost) { best_cost = cost; best_axis = a; best_bin = k; }
            }
        }
        const float area = b.surface_area();
        const float leaf_cost = opt.intersection_cost * blocks(uint32_t(n));
        float split_cost = area > 0.f ? opt.traversal_cost + opt.intersection_cost * best_cost / area : INFINITY;
        if (best_axis < 0 || (n <= size_t(opt.max_leaf_size) && leaf_cost <= split_cost)) return {};
        const int axis = best_axis;
        const float lo = cb.lo[axis], sc = scale[axis];
        Split split;
        split.axis = axis;
        split.mid = partition_with_bounds(begin, end, [&](const PrimRef& r) {
            return bin_of((r.centroid()[axis] - lo) * sc, nbins) <= best_bin;
        }, split);
        if (split.mid == begin || split.mid == end) {
            split.mid = median_split(begin, end, axis);
            split.bounds_known = false;
        }
        return split;
    }

    void bounds_of(size_t begin, size_t end, Aabb& b, Aabb& cb) const {
        b = Aabb{};
        cb = Aabb{};
        for (size_t i = begin; i < end; ++i) { b.expand(refs[i].bounds()); cb.expand(refs[i].centroid()); }
    }

    // Chooses how refs[begin, end) (bounds b, centroid bounds cb) is split: false when
    // `node` became a leaf; otherwise refs are partitioned at `mid` and `split` holds both
    // sides' bounds.
    bool choose(uint32_t node, size_t begin, size_t end, int depth, const Aabb& b, const Aabb& cb, Split& split, size_t& mid) {
        max_depth_seen = std::max(max_depth_seen, depth);
        const size_t n = end - begin;
        if (opt.type == BvhType::none || n <= 1 ||
            (n <= size_t(opt.max_leaf_size) && opt.type != BvhType::sah)) {
            make_leaf(node, b, begin, end);
            return false;
        }
        const int axis = cb.largest_axis();
        if (cb.extent()[axis] <= 0.f) {
            // All centroids coincide: no plane separates them, so only the leaf-size limit matters.
            if (n <= size_t(opt.max_leaf_size)) { make_leaf(node, b, begin, end); return false; }
            mid = begin + n / 2;
        } else if (depth >= kMaxBvhDepth / 2) {
            mid = median_split(begin, end, axis);  // bounded depth whatever the input
        } else if (opt.type == BvhType::median) {
            mid = median_split(begin, end, axis);
        } else if (opt.type == BvhType::midpoint) {
            mid = midpoint_split(begin, end, axis, cb);
        } else if (n <= size_t(opt.max_leaf_size) && n <= size_t(std::max(1, opt.leaf_block)) &&
                   opt.intersection_cost >= 0.f && opt.intersection_cost <= opt.traversal_cost &&
                   std::isfinite(b.surface_area())) {
            // One block: the leaf costs one test, and any split costs a node visit (no less)
            // plus its children's tests, so the SAH's answer is known without binning. Half of
            // all nodes reach here. (An infinite area, from bounds near the float range's
            // end, makes the SAH's comparison NaN and split: left to sah_split to decide.)
            make_leaf(node, b, begin, end);
            return false;
        } else {
            split = sah_split(begin, end, b, cb);
            if (split.axis < 0) { make_leaf(node, b, begin, end); return false; }
            mid = split.mid;
        }
        if (!split.bounds_known) {
            bounds_of(begin, mid, split.lb, split.lcb);
            bounds_of(mid, end, split.rb, split.rcb);
        }
        nodes[node].lo = b.lo;
        nodes[node].hi = b.hi;
        nodes[node].count = 0;
        return true;
    }

    // `b` and `cb` are the bounds and centroid bounds of refs[begin, end).
    void build(uint32_t node, size_t begin, size_t end, int depth, const Aabb& b, const Aabb& cb) {
        Split split;
        size_t mid = 0;
        if (!choose(node, begin, end, depth, b, cb, split, mid)) return;
        const uint32_t left = uint32_t(nodes.size());
        nodes.emplace_back();
        build(left, begin, mid, depth + 1, split.lb, split.lcb);
        const uint32_t right = uint32_t(nodes.size());
        nodes.emplace_back();
        nodes[node].offset = right;
        build(right, mid, end, depth + 1, split.rb, split.rcb);
    }
};

// Below this many primitives a subtree is built on the thread that reached it: a thread
// costs more than the work.
constexpr size_t kParallelMin = 4096;

// A subtree built in parallel: either nodes built on one thread (nodes[0] its root, child
// offsets relative to nodes), or a split node whose halves were built at once.
struct Part {
    LargeVector<BvhNode> nodes;
    BvhNode root{};
    std::unique_ptr<Part> left, right;
    size_t size() const { return left ? 1 + left->size() + right->size() : nodes.size(); }
};

// Lays a part out depth-first at out[0...], as the sequential builder would have, its
// nodes' child offsets moved by `base` (out[0]'s index in the whole tree).
void splice(const Part& p, BvhNode* out, uint32_t base) {
    if (!p.left) {
        for (size_t k = 0; k < p.nodes.size(); ++k) {
            BvhNode n = p.nodes[k];
            if (!n.is_leaf()) n.offset += base;  // leaves name refs, whose indices are global
            out[k] = n;
        }
        return;
    }
    const uint32_t left_size = uint32_t(p.left->size());
    out[0] = p.root;
    out[0].offset = base + 1 + left_size;
    splice(*p.left, out + 1, base + 1);
    splice(*p.right, out + 1 + left_size, base + 1 + left_size);
}

// Builds refs[begin, end) into `part`. The two halves of a split are built at once, down to
// `spawn` levels, each into its own part, and spliced once at the end in the sequential
// builder's depth-first order, so the tree is the same whatever the thread count: both halves
// touch disjoint ranges of refs, and every split is decided by the same code on the same
// primitives.
void build_subtree(const BvhBuildOptions& opt, LargeVector<PrimRef>& refs, Part& part, size_t begin,
                   size_t end, int depth, const Aabb& b, const Aabb& cb, int spawn, int& max_depth) {
    Builder builder{opt, refs, part.nodes, 0, {}, {}, {}};
    // A binary tree over n primitives has at most 2n - 1 nodes: reserved (as address space;
    // only what is written is faulted in), the array never moves while it grows.
    part.nodes.reserve(spawn <= 0 || end - begin < kParallelMin ? 2 * (end - begin) : 1);
    part.nodes.emplace_back();
    if (spawn <= 0 || end - begin < kParallelMin) {
        builder.build(0, begin, end, depth, b, cb);
        max_depth = builder.max_depth_seen;
        return;
    }
    Builder::Split split;
    size_t mid = 0;
    if (!builder.choose(0, begin, end, depth, b, cb, split, mid)) { max_depth = depth; return; }
    part.root = part.nodes[0];
    part.nodes = {};
    part.left = std::make_unique<Part>();
    part.right = std::make_unique<Part>();
    int left_depth = depth, right_depth = depth;
    auto build_left = [&] { build_subtree(opt, refs, *part.left, begin, mid, depth + 1, split.lb, split.lcb, spawn - 1, left_depth); };
    std::thread worker;
    try {
        worker = std::thread(build_left);
    } catch (const std::system_error&) {
        build_left();  // no thread to be had (a busy server): the same tree, built here
    }
    build_subtree(opt, refs, *part.right, mid, end, depth + 1, split.rb, split.rcb, spawn - 1, right_depth);
    if (worker.joinable()) worker.join();
    max_depth = std::max(left_depth, right_depth);
}

}  // namespace

double sah_cost(const Bvh& bvh, float traversal_cost, float intersection_cost, int leaf_block) {
    const uint32_t block = uint32_t(std::max(1, leaf_block));
    if (bvh.nodes.empty()) return 0.0;
    auto area = [](const BvhNode& n) { return double(Aabb{n.lo, n.hi}.surface_area()); };
    const double root = area(bvh.nodes[0]);
    if (root <= 0.0) return intersection_cost * double((bvh.prim_index.size() + block - 1) / block);
    double cost = 0.0;
    for (const BvhNode& n : bvh.nodes)
        cost += (n.is_leaf() ? intersection_cost * double((n.count + block - 1) / block) : double(traversal_cost)) * area(n) / root;
    return cost;
}

Bvh build_bvh(std::span<const Aabb> prim_bounds, const BvhBuildOptions& options) {
    return build_bvh(prim_bounds.size(), [prim_bounds](size_t i) { return prim_bounds[i]; }, options);
}

Bvh build_bvh(size_t count, const std::function<Aabb(size_t)>& bounds_of, const BvhBuildOptions& options) {
    const auto t0 = std::chrono::steady_clock::now();
    Bvh bvh;
    if (count == 0) return bvh;
    const int threads = options.build_threads > 0 ? options.build_threads : int(std::max(1u, std::thread::hardware_concurrency()));
    LargeVector<PrimRef> refs(count);
    // Each range's bounds apart, merged in range order: the union is the same whatever the split.
    const int ref_threads = pass_threads(count, threads);
    std::vector<Aabb> part_b(static_cast<size_t>(ref_threads)), part_cb(static_cast<size_t>(ref_threads));
    parallel_ranges(count, ref_threads, [&](size_t begin, size_t end, int part) {
        Aabb pb, pcb;
        for (size_t i = begin; i < end; ++i) {
            const Aabb bi = bounds_of(i);
            refs[i] = PrimRef{bi.lo, uint32_t(i), bi.hi, 0};
            pb.expand(bi);
            pcb.expand(bi.centroid());
        }
        part_b[size_t(part)] = pb;
        part_cb[size_t(part)] = pcb;
    });
    Aabb b, cb;
    for (int t = 0; t < ref_threads; ++t) { b.expand(part_b[size_t(t)]); cb.expand(part_cb[size_t(t)]); }
    // Levels of two-way splits: enough for every thread, plus two so that lopsided splits
    // (a ground plane beside a building) still leave none idle for long. One thread: none.
    const int spawn = threads > 1 ? std::bit_width(unsigned(threads - 1)) + 2 : 0;
    int max_depth = 0;
    Part tree;
    build_subtree(options, refs, tree, 0, refs.size(), 0, b, cb, spawn, max_depth);
    if (tree.left) {
        bvh.nodes.resize(tree.size());
        splice(tree, bvh.nodes.data(), 0);
    } else {
        bvh.nodes = std::move(tree.nodes);
    }
    bvh.prim_index.resize(refs.size());
    for (size_t i = 0; i < refs.size(); ++i) bvh.prim_index[i] = refs[i].id;

    BvhBuildStats& s = bvh.stats;
    s.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    s.node_count = bvh.nodes.size();
    s.depth = max_depth;
    s.leaf_size_histogram.assign(size_t(std::max(options.max_leaf_size, 1)) + 2, 0);
    for (const BvhNode& n : bvh.nodes) {
        if (!n.is_leaf()) continue;
        ++s.leaf_count;
        ++s.leaf_size_histogram[std::min<size_t>(n.count, s.leaf_size_histogram.size() - 1)];
    }
    s.sah_cost = sah_cost(bvh, options.traversal_cost, options.intersection_cost, options.leaf_block);
    s.memory_bytes = bvh.nodes.size() * sizeof(BvhNode) + bvh.prim_index.size() * sizeof(uint32_t);
    return bvh;
}

}  // namespace tessera
