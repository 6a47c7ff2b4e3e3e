#pragma once
// The render job's fields as command-line flags, made from the field table (api/job_fields.h):
// every field with command-line names becomes a CLI11 option with the table's help, choices
// and default; the values given become the JSON job that api::parse_render_job checks, so the
// CLI and the server validate alike.
#include <map>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

namespace tessera::cli {

class JobFlags {
public:
    // Adds one option per flagged field of the render job table to `app`, in group `group`.
    void add_to(CLI::App& app, const std::string& group);
    // The fields given on the command line, as JSON job fields; throws std::invalid_argument
    // naming the flag when a value is not of the field's type ("-s needs a whole number").
    nlohmann::json given() const;

private:
    struct Given {
        CLI::Option* option = nullptr;
        std::string value;
    };
    std::map<std::string, Given> values_;  // by field name
};

}  // namespace tessera::cli
