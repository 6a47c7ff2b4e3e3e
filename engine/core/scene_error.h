#pragma once
// Errors raised while reading input, with the place they come from.
#include <stdexcept>
#include <string>

namespace tessera {

// Where an item of a scene came from: a file and either a line (XML) or a JSON pointer (glTF).
struct SourceLocation {
    std::string file;
    int line = 0;             // 1-based; 0 when unknown
    std::string pointer;      // JSON pointer such as "/meshes/0/primitives/1"

    std::string str() const {
        std::string s = file.empty() ? std::string("<memory>") : file;
        // append() rather than operator+: GCC 12 warns falsely (-Wrestrict) on the latter.
        if (line > 0) s.append(":").append(std::to_string(line));
        if (!pointer.empty()) s.append("#").append(pointer);
        return s;
    }
};

// Thrown by loaders and validation: the message already names the location.
class SceneError : public std::runtime_error {
public:
    SceneError(const SourceLocation& where, const std::string& what)
        : std::runtime_error(where.str() + ": " + what), where_(where), detail_(what) {}
    const SourceLocation& where() const { return where_; }
    const std::string& detail() const { return detail_; }

private:
    SourceLocation where_;
    std::string detail_;
};

}  // namespace tessera
