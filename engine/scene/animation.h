#pragma once
// Keyframed animation as glTF 2.0 defines it, as plain data: channels of keys that move a node's
// translation, rotation or scale, or its mesh's morph weights, sampled at any time. Loaders
// check the keys (finite, strictly increasing times, whole values); sample() trusts them.
#include <cstdint>
#include <string>
#include <vector>

namespace tessera {

enum class Interpolation : uint8_t { step, linear, cubic_spline };
enum class AnimatedProperty : uint8_t { translation, rotation, scale, weights };

struct AnimationChannel {
    int node = -1;                  // the loader's node index
    AnimatedProperty property = AnimatedProperty::translation;
    Interpolation interpolation = Interpolation::linear;
    int width = 0;                  // floats per value: 3, 4 (a rotation: x y z w) or the morph target count
    std::vector<float> times;       // seconds, finite and strictly increasing
    // `width` floats per key; cubic_spline keys hold three values each: in-tangent, value,
    // out-tangent (glTF's layout).
    std::vector<float> values;
};

struct Animation {
    std::string name;               // as authored; may be empty
    std::vector<AnimationChannel> channels;
    double start_s = 0, end_s = 0;  // the first and last key of any channel
};

// The channel's value at `time_s` into out[0..width). Before the first key it holds the first
// value and after the last key the last (glTF's clamping). Rotations come out unit length:
// LINEAR rotations are slerped along the shorter arc, CUBICSPLINE ones normalised.
void sample(const AnimationChannel& channel, double time_s, float* out);

}  // namespace tessera
