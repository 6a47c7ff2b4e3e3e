#include "cli/job_flags.h"

#include <cstring>
#include <regex>
#include <stdexcept>

#include "api/job_fields.h"

namespace tessera::cli {
namespace {

// The first of an option's names, for messages ("-s" of "-s,--spp").
std::string flag_name(std::string_view cli) { return std::string(cli.substr(0, cli.find(','))); }

// --frames as render managers write it: "1-120", "1-120:2" (every second), "1,5,9" or "7".
nlohmann::json frames_json(const std::string& text) {
    static const std::regex range(R"(^(-?\d{1,9})-(-?\d{1,9})(?::(\d{1,9}))?$)"), list(R"(^-?\d{1,9}(,-?\d{1,9})*$)");
    std::smatch m;
    if (std::regex_match(text, m, range)) {
        nlohmann::json f = {{"start", std::stoll(m[1])}, {"end", std::stoll(m[2])}};
        if (m[3].matched) f["step"] = std::stoll(m[3]);
        return f;
    }
    if (std::regex_match(text, list)) {
        nlohmann::json l = nlohmann::json::array();
        size_t at = 0;
        while (at <= text.size()) {
            const size_t comma = std::min(text.find(',', at), text.size());
            l.push_back(std::stoll(text.substr(at, comma - at)));
            at = comma + 1;
        }
        return l;
    }
    throw std::invalid_argument("--frames needs START-END, START-END:STEP or a list N,M,..., got '" + text + "'");
}

}  // namespace

void JobFlags::add_to(CLI::App& app, const std::string& group) {
    for (const api::Field<api::RenderJob>& f : api::render_job_fields()) {
        if (f.cli.empty()) continue;
        std::string help(f.help);
        help += " (job field " + std::string(f.name);
        const api::JobLimits limits;  // the CLI's: the defaults
        if (f.kind == api::FieldKind::integer)
            help += ", " + std::to_string(f.min_int) + " to " +
                    std::to_string(f.limit == api::Limit::none ? f.max_int : int64_t(api::field_max(f, limits)));
        else if (f.kind == api::FieldKind::number)
            help += ", " + CLI::detail::to_string(f.min_num) + " to " + CLI::detail::to_string(api::field_max(f, limits));
        help += ", default " + std::string(f.default_json) + ")";
        Given& g = values_[std::string(f.name)];
        // The last of a repeated flag wins, as it always did.
        g.option = app.add_option(std::string(f.cli), g.value, help)->group(group)->take_last();
        switch (f.kind) {
            case api::FieldKind::integer: g.option->type_name("N"); break;
            case api::FieldKind::number: g.option->type_name("X"); break;
            case api::FieldKind::boolean: g.option->type_name("true|false"); break;
            case api::FieldKind::choice: {
                std::string choices;
                for (std::string_view c : f.choices) choices += (choices.empty() ? "" : "|") + std::string(c);
                g.option->type_name(choices);
                break;
            }
            default: g.option->type_name("TEXT"); break;
        }
    }
}

nlohmann::json JobFlags::given() const {
    nlohmann::json body = nlohmann::json::object();
    for (const api::Field<api::RenderJob>& f : api::render_job_fields()) {
        const auto it = values_.find(std::string(f.name));
        if (it == values_.end() || !it->second.option || it->second.option->count() == 0) continue;
        const std::string& v = it->second.value;
        const std::string flag = flag_name(f.cli);
        size_t used = 0;
        try {
            if (f.kind == api::FieldKind::integer) {
                const long long n = std::stoll(v, &used);
                if (used != v.size()) throw std::invalid_argument("");
                body[std::string(f.name)] = n;
            } else if (f.kind == api::FieldKind::number) {
                const double d = std::stod(v, &used);
                if (used != v.size()) throw std::invalid_argument("");
                body[std::string(f.name)] = d;
            } else if (f.name == "frames") {
                body["frames"] = frames_json(v);
            } else if (f.kind == api::FieldKind::boolean) {
                if (v != "true" && v != "false") throw std::invalid_argument(flag + " needs true or false, got '" + v + "'");
                body[std::string(f.name)] = v == "true";
            } else if (f.name == "passes") {
                nlohmann::json list = nlohmann::json::array();
                for (size_t at = 0; at <= v.size();) {
                    const size_t comma = std::min(v.find(',', at), v.size());
                    if (comma > at) list.push_back(v.substr(at, comma - at));
                    at = comma + 1;
                }
                body["passes"] = list;
            } else {
                body[std::string(f.name)] = v;
            }
        } catch (const std::invalid_argument& e) {
            if (f.name == "frames" || f.kind == api::FieldKind::boolean) throw;
            throw std::invalid_argument(flag + (f.kind == api::FieldKind::integer ? " needs a whole number" : " needs a number") +
                                        ", got '" + v + "'");
        } catch (const std::exception&) {
            throw std::invalid_argument(flag + (f.kind == api::FieldKind::integer ? " needs a whole number" : " needs a number") +
                                        ", got '" + v + "'");
        }
    }
    return body;
}

}  // namespace tessera::cli
