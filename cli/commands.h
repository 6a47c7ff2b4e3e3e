#pragma once
// The `tessera` subcommands. Each returns the process exit status.
namespace tessera::cli {

int render_command(int argc, char** argv);
int bench_command(int argc, char** argv);
int generate_command(int argc, char** argv);

}  // namespace tessera::cli
