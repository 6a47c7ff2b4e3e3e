#pragma once
// Running a CLI11 parser over a subcommand's arguments, with Tessera's exit statuses: 0 after
// --help, 2 for a bad flag or value (the message names the flag). Here, in the lowest layer
// with a command (serve), so that every command above shares it.
#include <csignal>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace tessera::server {

// argv holds the subcommand's own arguments (no program name). Returns the exit status to end
// with, or nothing when parsing succeeded and the command should run.
inline std::optional<int> parse_args(CLI::App& app, int argc, char** argv) {
    std::vector<std::string> args;
    for (int i = argc - 1; i >= 0; --i) args.emplace_back(argv[i]);  // CLI11 takes them reversed
    try {
        app.parse(args);
    } catch (const CLI::CallForHelp&) {
        std::fputs(app.help().c_str(), stdout);
        return 0;
    } catch (const CLI::ExtrasError& e) {
        std::string extras = e.what();
        for (const std::string lead : {"The following arguments were not expected: ", "The following argument was not expected: "})
            if (extras.rfind(lead, 0) == 0) extras = extras.substr(lead.size());
        std::fprintf(stderr, "tessera %s: unknown flag or argument %s (see --help)\n", app.get_name().c_str(), extras.c_str());
        return 2;
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "tessera %s: %s\n", app.get_name().c_str(), e.what());
        return 2;
    }
    return std::nullopt;
}

// Blocks SIGTERM and SIGINT in this thread and every thread started after it, for one thread to
// take with sigwait (so stopping runs as ordinary code, not in a signal handler), and ignores
// SIGPIPE (a client gone mid-answer). Call before any thread starts; returns the set to wait on.
inline sigset_t block_stop_signals() {
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    std::signal(SIGPIPE, SIG_IGN);
    return signals;
}

}  // namespace tessera::server
