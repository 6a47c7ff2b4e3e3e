#pragma once
// `tessera serve` (the HTTP render server with its queue and store) and `tessera worker` (a
// render node of a farm).
namespace tessera::server {

// Parses the serve options (flags, or TESSERA_<NAME> environment variables) and serves until
// SIGINT/SIGTERM; returns the process exit status.
int serve_command(int argc, char** argv);

// `tessera worker`: a render node of a farm (--redis), with no HTTP.
int worker_command(int argc, char** argv);

}  // namespace tessera::server
