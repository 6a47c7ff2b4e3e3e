#include "engine/io/gltf_animation_reader.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tessera::gltf {
namespace {

size_t morph_target_count(const tinygltf::Mesh& mesh) {
    size_t n = 0;
    for (const auto& prim : mesh.primitives) n = std::max(n, prim.targets.size());
    return n;
}

// Which animations `name` chooses: "" every one; else the one of that name, or of that index.
std::vector<size_t> choose_animations(const Ctx& c, const std::vector<Animation>& list, const std::string& name, bool by_index) {
    std::vector<size_t> chosen;
    if (name.empty()) {
        for (size_t i = 0; i < list.size(); ++i) chosen.push_back(i);
        return chosen;
    }
    if (const auto i = chosen_animation(list, name, by_index)) return {*i};
    std::string names;
    for (size_t i = 0; i < list.size() && i < 20; ++i) names += (i ? ", " : "") + (list[i].name.empty() ? "#" + str(i) : "'" + list[i].name + "'");
    fail(c, "/animations", "no animation '" + clip(name, 80) + "': the file has " +
                               (list.empty() ? std::string("none") : str(list.size()) + " (" + names + ")"));
}

}  // namespace

ReadAnimations read_animations(Ctx& c) {
    ReadAnimations r;
    constexpr auto kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT;
    uint64_t keys_left = c.limits.max_vertices;  // keys and values cost like vertices
    for (size_t ai = 0; ai < c.m.animations.size(); ++ai) {
        const tinygltf::Animation& a = c.m.animations[ai];
        const std::string ap = "/animations/" + str(ai);
        Animation out;
        out.name = clip(a.name, 200);
        std::string refusal;
        double start = std::numeric_limits<double>::infinity(), end = -start;
        for (size_t ci = 0; ci < a.channels.size(); ++ci) {
            const tinygltf::AnimationChannel& ch = a.channels[ci];
            const std::string cp = ap + "/channels/" + str(ci);
            AnimationChannel o;
            if (ch.target_path == "translation") o.property = AnimatedProperty::translation, o.width = 3;
            else if (ch.target_path == "rotation") o.property = AnimatedProperty::rotation, o.width = 4;
            else if (ch.target_path == "scale") o.property = AnimatedProperty::scale, o.width = 3;
            else if (ch.target_path == "weights") o.property = AnimatedProperty::weights;
            else {
                if (refusal.empty())
                    refusal = cp + "/target/path animates '" + clip(ch.target_path, 80) +
                              "'; Tessera plays node translation, rotation and scale and morph weights only";
                continue;
            }
            if (ch.target_node < 0 || static_cast<size_t>(ch.target_node) >= c.m.nodes.size())
                fail(c, cp + "/target/node", "refers to node " + std::to_string(ch.target_node) + ", but the file has " + str(c.m.nodes.size()));
            o.node = ch.target_node;
            const tinygltf::Node& node = c.m.nodes[static_cast<size_t>(o.node)];
            if (o.property != AnimatedProperty::weights && !node.matrix.empty())
                fail(c, cp + "/target", "animates node " + std::to_string(o.node) + ", which has a matrix (glTF allows only TRS nodes to be animated)");
            if (o.property == AnimatedProperty::weights) {
                const size_t targets = node.mesh >= 0 && static_cast<size_t>(node.mesh) < c.m.meshes.size()
                                           ? morph_target_count(c.m.meshes[static_cast<size_t>(node.mesh)])
                                           : 0;
                if (targets == 0) fail(c, cp + "/target", "animates the morph weights of node " + std::to_string(o.node) + ", which has no morph targets");
                o.width = static_cast<int>(targets);
            }
            if (ch.sampler < 0 || static_cast<size_t>(ch.sampler) >= a.samplers.size())
                fail(c, cp + "/sampler", "refers to sampler " + std::to_string(ch.sampler) + ", but the animation has " + str(a.samplers.size()));
            const tinygltf::AnimationSampler& sm = a.samplers[static_cast<size_t>(ch.sampler)];
            const std::string sp = ap + "/samplers/" + std::to_string(ch.sampler);
            if (sm.interpolation.empty() || sm.interpolation == "LINEAR") o.interpolation = Interpolation::linear;
            else if (sm.interpolation == "STEP") o.interpolation = Interpolation::step;
            else if (sm.interpolation == "CUBICSPLINE") o.interpolation = Interpolation::cubic_spline;
            else fail(c, sp + "/interpolation", "unknown interpolation '" + clip(sm.interpolation, 80) + "'");
            const AccessorView in = view_accessor(c, sm.input, sp + "/input", "animation input", TINYGLTF_TYPE_SCALAR, {kFloat},
                                                  keys_left, "keys left under LoadLimits::max_vertices");
            if (in.count == 0) fail(c, sp + "/input", "an animation sampler needs at least one key");
            o.times.resize(in.count);
            for (size_t k = 0; k < in.count; ++k) {
                o.times[k] = read_component(in, k, 0);
                if (!std::isfinite(o.times[k])) fail(c, "/accessors/" + std::to_string(sm.input), "key time " + str(k) + " is not finite");
                if (k > 0 && !(o.times[k] > o.times[k - 1]))
                    fail(c, "/accessors/" + std::to_string(sm.input), "key times must increase strictly (key " + str(k) + ")");
            }
            const size_t per_key = (o.interpolation == Interpolation::cubic_spline ? 3 : 1);
            const bool scalar = o.property == AnimatedProperty::weights;
            const int type = scalar ? TINYGLTF_TYPE_SCALAR : o.width == 3 ? TINYGLTF_TYPE_VEC3 : TINYGLTF_TYPE_VEC4;
            const uint64_t elements = uint64_t(in.count) * per_key * (scalar ? uint64_t(o.width) : 1);
            const uint64_t budget = left(keys_left, in.count);
            const char* budget_name = "keys left under LoadLimits::max_vertices";
            // Rotations and weights may be normalized integers; translations and scales are floats.
            const AccessorView outv =
                o.property == AnimatedProperty::translation || o.property == AnimatedProperty::scale
                    ? view_accessor(c, sm.output, sp + "/output", "animation output", type, {kFloat}, budget, budget_name)
                    : view_accessor(c, sm.output, sp + "/output", "animation output", type,
                                    {kFloat, TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                     TINYGLTF_COMPONENT_TYPE_SHORT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                                    budget, budget_name);
            if (outv.count != elements)
                fail(c, sp + "/output", "holds " + str(outv.count) + " values; " + str(in.count) + " keys of " +
                                            (o.interpolation == Interpolation::cubic_spline ? "CUBICSPLINE " : "") + "'" + ch.target_path +
                                            "' need " + str(elements));
            const int per_element = scalar ? 1 : o.width;
            o.values.resize(outv.count * size_t(per_element));
            for (size_t k = 0; k < outv.count; ++k)
                for (int j = 0; j < per_element; ++j) {
                    const float v = read_component(outv, k, j);
                    if (!std::isfinite(v)) fail(c, "/accessors/" + std::to_string(sm.output), "value " + str(k) + " is not finite");
                    o.values[k * size_t(per_element) + size_t(j)] = v;
                }
            // A key's rotation of zero length names no rotation (its tangents may be zero).
            if (o.property == AnimatedProperty::rotation)
                for (size_t k = 0; k < in.count; ++k) {
                    const float* q = &o.values[(k * per_key + (per_key == 3 ? 1 : 0)) * 4];
                    if (!(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3] > 1e-24))
                        fail(c, "/accessors/" + std::to_string(sm.output), "key " + str(k) + "'s rotation quaternion has zero length");
                }
            keys_left = left(keys_left, in.count + outv.count);
            start = std::min(start, double(o.times.front()));
            end = std::max(end, double(o.times.back()));
            out.channels.push_back(std::move(o));
        }
        out.start_s = out.channels.empty() ? 0.0 : start;
        out.end_s = out.channels.empty() ? 0.0 : end;
        r.list.push_back(std::move(out));
        r.refusal.push_back(refusal);
    }
    return r;
}

std::vector<NodeState> pose_nodes(const Ctx& c, const ReadAnimations& anims, const ScenePose& pose) {
    std::vector<NodeState> state(c.m.nodes.size());
    if (!std::isfinite(pose.time_s)) fail(c, "", "the pose's time is not finite");
    std::vector<float> v;
    for (size_t ai : choose_animations(c, anims.list, pose.animation, pose.by_index)) {
        if (!anims.refusal[ai].empty()) fail(c, "/animations/" + str(ai), "cannot be played: " + anims.refusal[ai]);
        for (const AnimationChannel& ch : anims.list[ai].channels) {
            v.assign(size_t(ch.width), 0.f);
            sample(ch, pose.time_s, v.data());
            NodeState& s = state[size_t(ch.node)];
            switch (ch.property) {
                case AnimatedProperty::translation: s.has_t = true, s.t = {v[0], v[1], v[2]}; break;
                case AnimatedProperty::scale: s.has_s = true, s.s = {v[0], v[1], v[2]}; break;
                case AnimatedProperty::rotation: s.has_r = true, s.r = {v[0], v[1], v[2], v[3]}; break;
                case AnimatedProperty::weights: s.has_weights = true, s.weights.assign(v.begin(), v.end()); break;
            }
        }
    }
    return state;
}

}  // namespace tessera::gltf
