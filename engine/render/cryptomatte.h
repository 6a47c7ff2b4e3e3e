#pragma once
// Cryptomatte ID mattes (Friedman and Jones, Psyop; the open specification, version 1.1.0):
// each pixel keeps the objects (or materials) its camera samples hit, ranked by the share of
// samples each covers, so a compositor pulls a matte of any of them with its anti-aliased edge,
// motion blur and depth of field included. Ids are the 32-bit MurmurHash3 of the names, stored
// as floats (the exponent held off NaN, infinity and denormals); the file's header names the
// layer, the hash and the conversion, and maps every name to its id (the manifest).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "engine/core/murmur3.h"

namespace tessera {

// Ranks kept per pixel: the specification's suggested default, three RGBA layers (00, 01, 02).
inline constexpr int kCryptoRanks = 6;

// A hash as the float a Cryptomatte pixel stores: its bits, the exponent held within [1, 254].
float crypto_id(uint32_t hash);
// The id's bits as eight lower-case hex digits: a manifest's value.
std::string crypto_hex(float id);
// The layer's metadata key: seven hex digits of its name's hash (the same in every file).
std::string crypto_key(std::string_view layer);

// A pixel's ranks while it renders: kCryptoRanks pairs (the hash, as a double; its samples).
// A sample adds one to its hash's pair, or takes the first empty pair; a pixel that has met
// more than kCryptoRanks objects drops the rest's samples (their share is left out of every
// coverage, as a renderer that keeps n ranks does). Samples that hit nothing add nothing.
void add_crypto_sample(double* ranks, uint32_t hash);
// The ranks as the file keeps them: (id, coverage) pairs, largest coverage first (ties by
// id), coverage the share of the pixel's `samples`; empty ranks are (0, 0).
void resolve_crypto(const double* ranks, double samples, float* out);

// The header attributes of one Cryptomatte layer (`cryptomatte/<key>/name` and so on), with
// the manifest of `names` (every name once, in JSON) when there are at most
// kCryptoManifestNames of them.
inline constexpr size_t kCryptoManifestNames = 20000;
std::vector<std::pair<std::string, std::string>> crypto_metadata(std::string_view layer, const std::vector<std::string>& names);

}  // namespace tessera
