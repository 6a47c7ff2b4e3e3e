#pragma once
// Shared by the bench subcommands.
#include "build_paths.h"
#include <cstdlib>
#include <string>
#include <vector>

namespace tessera::cli {

// The CS184 scene folder: TESSERA_CS184_DIR, else the path configured at build time.
inline std::string default_cs184_dir() {
    if (const char* e = std::getenv("TESSERA_CS184_DIR"); e && *e) return e;
    return TESSERA_DEFAULT_CS184_DIR;
}

// The shared glTF sample models (gltf-pbr): TESSERA_GLTF_PBR_DIR, else the path configured at build time.
inline std::string default_gltf_pbr_dir() {
    if (const char* e = std::getenv("TESSERA_GLTF_PBR_DIR"); e && *e) return e;
    return TESSERA_DEFAULT_GLTF_PBR_DIR;
}

// One job of a preview submitted again and again to a fresh in-process server (the scene cache).
struct CacheLatency {
    bool hit;
    double end_to_end_ms;   // submit to succeeded, as a client sees it
    double preparation_ms;  // load and preparation inside the job
};
// Prints the table and returns one row per job (none when a request failed).
std::vector<CacheLatency> scene_cache_latency(int triangles, int jobs);

// The live updates' costs (event latency, keeping each pass, a running job's image per
// request): prints them; false when a request or an event failed.
bool live_update_costs(int jobs);

int bench_figures(int argc, char** argv);
int bench_prepare(int argc, char** argv);
int bench_server(int argc, char** argv);
int bench_convergence(int argc, char** argv);
int bench_leave_out(int argc, char** argv);
int bench_rays(int argc, char** argv);
int bench_cluster(int argc, char** argv);
int bench_materials(int argc, char** argv);
int bench_instances(int argc, char** argv);
int bench_shot(int argc, char** argv);
int bench_denoise(int argc, char** argv);

}  // namespace tessera::cli
