#pragma once
// Shared by the bench subcommands.
#include <cstdlib>
#include <string>

namespace tessera::cli {

// The CS184 scene folder: TESSERA_CS184_DIR, else the path configured at build time.
inline std::string default_cs184_dir() {
    if (const char* e = std::getenv("TESSERA_CS184_DIR"); e && *e) return e;
    return TESSERA_DEFAULT_CS184_DIR;
}

int bench_figures(int argc, char** argv);
int bench_server(int argc, char** argv);
int bench_convergence(int argc, char** argv);
int bench_leave_out(int argc, char** argv);
int bench_rays(int argc, char** argv);
int bench_cluster(int argc, char** argv);

}  // namespace tessera::cli
