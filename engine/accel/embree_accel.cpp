#include "engine/accel/embree_accel.h"

#include <atomic>
#include <chrono>
#include <algorithm>
#include <cstdlib>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>

#include "engine/geometry/triangle.h"

#if defined(TESSERA_HAVE_EMBREE)
#include <embree3/rtcore.h>
#endif

namespace tessera {

#if defined(TESSERA_HAVE_EMBREE)

namespace {

// Embree's own count of the memory it holds (its memory monitor), and a lock that keeps
// builds and releases apart so that a build's difference is that build's memory.
std::atomic<int64_t> g_embree_bytes{0};
std::mutex g_embree_build;

bool count_bytes(void*, ssize_t bytes, bool) {
    g_embree_bytes += bytes;
    return true;
}

}  // namespace

struct EmbreeAccel {
    RTCScene scene = nullptr;
    std::vector<RTCScene> prototypes;
    std::vector<uint32_t> first_prim;  // per placement: its prototype's first triangle id
    size_t bytes = 0;
    ~EmbreeAccel() {
        std::lock_guard lock(g_embree_build);
        if (scene) rtcReleaseScene(scene);
        for (RTCScene p : prototypes) rtcReleaseScene(p);
    }
    // A hit's triangle id: an instanced scene's primID is its own triangle's index.
    uint32_t prim_of(uint32_t inst, uint32_t prim) const {
        return inst == RTC_INVALID_GEOMETRY_ID ? prim : first_prim[inst - 1] + prim;
    }
};

namespace {

// One device per thread count for the process (a device owns Embree's thread pool; 0: one
// thread per core), created on first use. Embree sizes its shared task scheduler for the
// largest count of the devices alive, so a 1-thread device is 1-thread only in a process
// that made no other (`tessera bench prepare` measures each count in a process of its own). TESSERA_EMBREE_CONFIG passes Embree's device
// configuration for diagnosis (e.g. "verbose=2" prints its BVH's shape and the kernels it
// chose; "isa=avx2" pins the kernels).
RTCDevice device(int threads) {
    static std::mutex lock;
    static std::map<int, RTCDevice> devices;
    std::lock_guard guard(lock);
    RTCDevice& dev = devices[std::max(0, threads)];
    if (!dev) {
        std::string config = threads > 0 ? "threads=" + std::to_string(threads) : "";
        if (const char* extra = std::getenv("TESSERA_EMBREE_CONFIG"); extra && *extra)
            config += (config.empty() ? "" : ",") + std::string(extra);
        dev = rtcNewDevice(config.c_str());
        if (dev) rtcSetDeviceMemoryMonitorFunction(dev, count_bytes, nullptr);
    }
    if (!dev) throw std::runtime_error("Embree: rtcNewDevice failed");
    return dev;
}

}  // namespace

bool embree_available() { return true; }

namespace {

RTCBuildQuality quality_of(EmbreeQuality q) {
    return q == EmbreeQuality::low ? RTC_BUILD_QUALITY_LOW : q == EmbreeQuality::high ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM;
}

RTCScene new_scene(RTCDevice dev, EmbreeQuality quality, bool filtered) {
    RTCScene scene = rtcNewScene(dev);
    if (filtered) rtcSetSceneFlags(scene, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    rtcSetSceneBuildQuality(scene, quality_of(quality));
    return scene;
}

// The triangles as one triangle geometry of `scene`, with geometry id `id`.
void attach_triangles(RTCDevice dev, RTCScene scene, std::span<const TriangleVerts> tris, EmbreeQuality quality, unsigned id) {
    RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (quality == EmbreeQuality::high) rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * tris.size()));
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), tris.size()));
    if (!v || !idx) {
        rtcReleaseGeometry(geom);
        throw std::runtime_error("Embree: cannot allocate the geometry buffers");
    }
    for (size_t i = 0; i < tris.size(); ++i) {
        const glm::vec3* p[3] = {&tris[i].p0, &tris[i].p1, &tris[i].p2};
        for (int k = 0; k < 3; ++k) {
            v[(i * 3 + size_t(k)) * 3 + 0] = p[k]->x;
            v[(i * 3 + size_t(k)) * 3 + 1] = p[k]->y;
            v[(i * 3 + size_t(k)) * 3 + 2] = p[k]->z;
            idx[i * 3 + size_t(k)] = unsigned(i * 3 + size_t(k));
        }
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(scene, geom, id);
    rtcReleaseGeometry(geom);
}

}  // namespace

std::shared_ptr<EmbreeAccel> build_embree(std::span<const TriangleVerts> tris, EmbreeQuality quality, double& build_seconds,
                                          int threads, bool filtered, std::span<const EmbreePrototype> prototypes,
                                          std::span<const EmbreePlacement> placements) {
    RTCDevice dev = device(threads);
    std::lock_guard lock(g_embree_build);
    const int64_t before = g_embree_bytes;
    const auto t0 = std::chrono::steady_clock::now();
    auto accel = std::make_shared<EmbreeAccel>();
    accel->scene = new_scene(dev, quality, filtered);
    // Geometry 0: the world-space triangles; 1 + k: placement k (so a hit's instID names it).
    if (!tris.empty()) attach_triangles(dev, accel->scene, tris, quality, 0);
    for (const EmbreePrototype& p : prototypes) {
        RTCScene ps = new_scene(dev, quality, filtered);
        accel->prototypes.push_back(ps);
        attach_triangles(dev, ps, p.tris, quality, 0);
        rtcCommitScene(ps);  // before the instances that place it
    }
    accel->first_prim.reserve(placements.size());
    for (size_t k = 0; k < placements.size(); ++k) {
        const EmbreePlacement& pl = placements[k];
        RTCGeometry inst = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(inst, accel->prototypes.at(pl.prototype));
        rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, &pl.to_world[0][0]);
        rtcCommitGeometry(inst);
        rtcAttachGeometryByID(accel->scene, inst, unsigned(k + 1));
        rtcReleaseGeometry(inst);
        accel->first_prim.push_back(prototypes[pl.prototype].first_id);
    }
    rtcCommitScene(accel->scene);
    if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) throw std::runtime_error("Embree: the scene build failed");
    build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    accel->bytes = size_t(std::max<int64_t>(0, g_embree_bytes - before));
    return accel;
}

size_t embree_memory_bytes(const EmbreeAccel& accel) { return accel.bytes; }

namespace {

// The context Embree hands the filter, with our filter behind it (Embree's documented way to pass
// per-query data: a context extended at its end).
struct FilterContext {
    RTCIntersectContext ctx;
    const EmbreeHitFilter* filter;
    const EmbreeAccel* accel;
};

void run_filter(const RTCFilterFunctionNArguments* args) {
    const auto* fc = reinterpret_cast<const FilterContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (!args->valid[i]) continue;
        const uint32_t prim = fc->accel->prim_of(RTCHitN_instID(args->hit, args->N, i, 0), RTCHitN_primID(args->hit, args->N, i));
        if (!fc->filter->accept(fc->filter->user, prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i)))
            args->valid[i] = 0;
    }
}

void init_context(FilterContext& fc, const EmbreeHitFilter* filter, const EmbreeAccel& accel) {
    rtcInitIntersectContext(&fc.ctx);
    fc.filter = filter;
    fc.accel = &accel;
    if (filter) fc.ctx.filter = run_filter;
}

}  // namespace

bool embree_intersect(const EmbreeAccel& accel, Ray& ray, uint32_t& prim, float& b1, float& b2, const EmbreeHitFilter* filter,
                      uint32_t* instance) {
    FilterContext fc;
    init_context(fc, filter, accel);
    RTCIntersectContext& ctx = fc.ctx;
    RTCRayHit rh;
    rh.ray.org_x = ray.o.x; rh.ray.org_y = ray.o.y; rh.ray.org_z = ray.o.z;
    rh.ray.dir_x = ray.d.x; rh.ray.dir_y = ray.d.y; rh.ray.dir_z = ray.d.z;
    rh.ray.tnear = ray.tmin;
    rh.ray.tfar = ray.tmax;
    rh.ray.time = 0.f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(accel.scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    ray.tmax = rh.ray.tfar;
    prim = accel.prim_of(rh.hit.instID[0], rh.hit.primID);
    if (instance) *instance = rh.hit.instID[0] == RTC_INVALID_GEOMETRY_ID ? ~0u : rh.hit.instID[0] - 1;
    b1 = rh.hit.u;
    b2 = rh.hit.v;
    return true;
}

bool embree_occluded(const EmbreeAccel& accel, const Ray& ray, const EmbreeHitFilter* filter) {
    FilterContext fc;
    init_context(fc, filter, accel);
    RTCIntersectContext& ctx = fc.ctx;
    RTCRay r;
    r.org_x = ray.o.x; r.org_y = ray.o.y; r.org_z = ray.o.z;
    r.dir_x = ray.d.x; r.dir_y = ray.d.y; r.dir_z = ray.d.z;
    r.tnear = ray.tmin;
    r.tfar = ray.tmax;
    r.time = 0.f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(accel.scene, &ctx, &r);
    return r.tfar < 0.f;  // Embree marks an occluded ray with tfar = −∞
}

#else

struct EmbreeAccel {};

bool embree_available() { return false; }

std::shared_ptr<EmbreeAccel> build_embree(std::span<const TriangleVerts>, EmbreeQuality, double&, int, bool,
                                          std::span<const EmbreePrototype>, std::span<const EmbreePlacement>) {
    throw std::runtime_error("this build of tessera has no Embree (install libembree-dev and rebuild)");
}
size_t embree_memory_bytes(const EmbreeAccel&) { return 0; }
bool embree_intersect(const EmbreeAccel&, Ray&, uint32_t&, float&, float&, const EmbreeHitFilter*, uint32_t*) { return false; }
bool embree_occluded(const EmbreeAccel&, const Ray&, const EmbreeHitFilter*) { return false; }

#endif

}  // namespace tessera
