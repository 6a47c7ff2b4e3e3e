#include "server/http/bearer_auth.h"

#include <arpa/inet.h>

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace tessera::server {

namespace {

void check_token(const std::string& token, const std::string& where) {
    if (token.size() < 16)
        throw std::runtime_error(where + ": a token must have at least 16 characters (e.g. `openssl rand -hex 32`)");
    // A compose file or shell that did not expand a variable hands over "${TOKENS}" itself.
    if (token.find("${") != std::string::npos || token.find("$(") != std::string::npos)
        throw std::runtime_error(where + ": a token holds \"${\" or \"$(\": a variable or command that was not expanded?");
    for (char c : token)
        if (static_cast<unsigned char>(c) <= 0x20 || static_cast<unsigned char>(c) >= 0x7f)
            throw std::runtime_error(where + ": a token may hold only printable ASCII without spaces");
}

// Equal strings in time that depends on neither's content nor on where they first differ.
bool same_bytes(std::string_view presented, std::string_view token) {
    volatile unsigned char diff = presented.size() != token.size() ? 1 : 0;
    for (size_t i = 0; i < token.size(); ++i) {
        const unsigned char p = i < presented.size() ? static_cast<unsigned char>(presented[i]) : 0;
        diff = static_cast<unsigned char>(diff | (p ^ static_cast<unsigned char>(token[i])));
    }
    return diff == 0;
}

}  // namespace

BearerAuth::BearerAuth(std::vector<std::string> tokens) : tokens_(std::move(tokens)) {}

std::vector<std::string> BearerAuth::read_token_file(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("token file " + path + " cannot be read");
    std::vector<std::string> tokens;
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
        const size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        const size_t a = line.find_first_not_of(" \t\r");
        if (a == std::string::npos) continue;
        const size_t b = line.find_last_not_of(" \t\r");
        const std::string token = line.substr(a, b - a + 1);
        check_token(token, "token file " + path + " line " + std::to_string(n));
        tokens.push_back(token);
    }
    if (tokens.empty()) throw std::runtime_error("token file " + path + " holds no token");
    return tokens;
}

std::vector<std::string> BearerAuth::parse_token_list(std::string_view text) {
    std::vector<std::string> tokens;
    std::string token;
    auto flush = [&] {
        if (token.empty()) return;
        check_token(token, "TESSERA_TOKENS");
        tokens.push_back(token);
        token.clear();
    };
    for (char c : text) {
        if (c == ',' || c == ' ' || c == '\t' || c == '\n' || c == '\r') flush();
        else token += c;
    }
    flush();
    return tokens;
}

bool BearerAuth::allows(std::string_view authorization) const {
    // RFC 9110: the scheme is case-insensitive; one or more spaces follow it.
    if (authorization.size() < 7) return false;
    const std::string_view scheme = authorization.substr(0, 6);
    bool bearer = true;
    for (size_t i = 0; i < 6; ++i) bearer = bearer && std::tolower(static_cast<unsigned char>(scheme[i])) == "bearer"[i];
    if (!bearer || authorization[6] != ' ') return false;
    std::string_view presented = authorization.substr(7);
    while (!presented.empty() && presented.front() == ' ') presented.remove_prefix(1);
    while (!presented.empty() && presented.back() == ' ') presented.remove_suffix(1);
    bool any = false;
    for (const std::string& token : tokens_) any = same_bytes(presented, token) | any;
    return any;
}

bool is_loopback_host(const std::string& host) {
    if (host == "localhost") return true;
    in_addr v4{};
    if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
    in6_addr v6{};
    if (inet_pton(AF_INET6, host.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6);
    return false;
}

}  // namespace tessera::server
