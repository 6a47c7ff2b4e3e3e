#include "engine/render/cryptomatte.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>

#include <nlohmann/json.hpp>

namespace tessera {

float crypto_id(uint32_t hash) {
    const uint32_t exponent = std::clamp<uint32_t>((hash >> 23) & 0xffu, 1u, 254u);
    const uint32_t bits = (hash & 0x80000000u) | (exponent << 23) | (hash & 0x7fffffu);
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
}

std::string crypto_hex(float id) {
    uint32_t bits;
    std::memcpy(&bits, &id, 4);
    char hex[9];
    std::snprintf(hex, sizeof hex, "%08x", bits);
    return hex;
}

std::string crypto_key(std::string_view layer) {
    char hex[9];
    std::snprintf(hex, sizeof hex, "%08x", murmur3_32(layer));
    return std::string(hex, 7);
}

void add_crypto_sample(double* ranks, uint32_t hash) {
    const double id = double(hash);
    for (int r = 0; r < kCryptoRanks; ++r) {
        double* pair = ranks + 2 * r;
        if (pair[1] == 0.0) {  // the first empty pair: this hash is new here
            pair[0] = id;
            pair[1] = 1.0;
            return;
        }
        if (pair[0] == id) {
            pair[1] += 1.0;
            return;
        }
    }
}

void resolve_crypto(const double* ranks, double samples, float* out) {
    std::array<std::pair<double, double>, kCryptoRanks> r;  // (samples, hash)
    for (int i = 0; i < kCryptoRanks; ++i) r[size_t(i)] = {ranks[2 * i + 1], ranks[2 * i]};
    std::sort(r.begin(), r.end(), [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
    for (int i = 0; i < kCryptoRanks; ++i) {
        const auto& [n, hash] = r[size_t(i)];
        const bool kept = n > 0.0 && samples > 0.0;
        out[2 * i] = kept ? crypto_id(uint32_t(hash)) : 0.f;
        out[2 * i + 1] = kept ? float(n / samples) : 0.f;
    }
}

std::vector<std::pair<std::string, std::string>> crypto_metadata(std::string_view layer, const std::vector<std::string>& names) {
    const std::string prefix = "cryptomatte/" + crypto_key(layer) + "/";
    std::vector<std::pair<std::string, std::string>> meta = {
        {prefix + "name", std::string(layer)}, {prefix + "hash", "MurmurHash3_32"}, {prefix + "conversion", "uint32_to_float32"}};
    // The manifest is optional (decoders pull mattes by id without it): a scene of more names
    // than this goes without, rather than put megabytes into every file's header.
    if (names.size() > kCryptoManifestNames) return meta;
    nlohmann::json manifest = nlohmann::json::object();
    for (const std::string& n : names) manifest[n] = crypto_hex(crypto_id(murmur3_32(n)));
    // A name that is not UTF-8 (a hostile or careless file) is written with U+FFFD in its place;
    // its id stays the hash of its bytes.
    meta.emplace_back(prefix + "manifest", manifest.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
    return meta;
}

}  // namespace tessera
