#pragma once
// Who may use the server: bearer tokens (RFC 6750) read from a file or the environment,
// checked in constant time, never logged. No tokens: anyone who reaches the port may, which
// `tessera serve` allows only on a loopback address unless told otherwise.
#include <string>
#include <string_view>
#include <vector>

namespace tessera::server {

class BearerAuth {
public:
    BearerAuth() = default;
    explicit BearerAuth(std::vector<std::string> tokens);

    // Tokens, one per line ('#' starts a comment; blank lines are skipped). Throws
    // std::runtime_error naming the file when it cannot be read, holds a token shorter than
    // 16 characters or one with a character outside printable ASCII.
    static std::vector<std::string> read_token_file(const std::string& path);
    // Tokens separated by commas or white space, as TESSERA_TOKENS holds them; same checks.
    static std::vector<std::string> parse_token_list(std::string_view text);

    bool enabled() const { return !tokens_.empty(); }
    size_t size() const { return tokens_.size(); }
    // Whether an Authorization header value ("Bearer <token>") carries one of the tokens. Every
    // token is compared over its whole length whatever matched, so the time taken says
    // nothing about how much of a guess was right.
    bool allows(std::string_view authorization) const;

private:
    std::vector<std::string> tokens_;
};

// Whether a listen address can be reached only from this machine (127.0.0.0/8, ::1, localhost).
bool is_loopback_host(const std::string& host);

}  // namespace tessera::server
