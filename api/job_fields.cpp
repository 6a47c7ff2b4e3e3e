#include "api/job_fields.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <type_traits>

#include "api/json_text.h"
#include "engine/accel/embree_accel.h"

namespace tessera::api {
namespace {

using nlohmann::json;

// A member reached through a path of member pointers: at<&RenderJob::render, &RenderSettings::spp>(job).
template <auto... Path, class T>
decltype(auto) at(T& object) {
    return (object .* ... .* Path);
}

template <class Job, auto... Path>
void set_number(Job& j, const json& v, const ParseContext&) {
    auto& member = at<Path...>(j);
    using M = std::remove_reference_t<decltype(member)>;
    if constexpr (std::is_floating_point_v<M>) member = M(v.get<double>());
    else member = M(v.get<int64_t>());
}

template <class Job, auto... Path>
json get_member(const Job& j) {
    return at<Path...>(j);
}

// Enumerations by name: one list per enum gives the JSON names, the parser's check and the
// error message's list of choices.
template <class E>
struct Named {
    std::string_view name;
    E value;
};

constexpr Named<BvhType> kBvh[] = {
    {"none", BvhType::none}, {"midpoint", BvhType::midpoint}, {"median", BvhType::median}, {"sah", BvhType::sah},
    {"embree", BvhType::embree}};
constexpr Named<DirectLighting> kDirect[] = {
    {"hemisphere", DirectLighting::hemisphere}, {"importance", DirectLighting::importance}, {"mis", DirectLighting::mis}};
constexpr Named<BounceMode> kBounces[] = {{"accumulate", BounceMode::accumulate}, {"nth", BounceMode::nth}};
constexpr Named<LightingOutput> kLighting[] = {
    {"all", LightingOutput::all}, {"direct", LightingOutput::direct}, {"indirect", LightingOutput::indirect}};
constexpr Named<LightSelection> kSelection[] = {
    {"all", LightSelection::all}, {"power", LightSelection::power}, {"tree", LightSelection::tree},
    {"auto", LightSelection::automatic}};
constexpr Named<SamplerKind> kSampler[] = {{"sobol", SamplerKind::sobol}, {"independent", SamplerKind::independent}};
constexpr Named<Integrator> kIntegrator[] = {{"path", Integrator::path}, {"normals", Integrator::normals}};
constexpr Named<TriangleTest> kTriangle[] = {
    {"watertight", TriangleTest::watertight}, {"moller_trumbore", TriangleTest::moller_trumbore}};

template <auto& Table>
constexpr auto names_of() {
    std::array<std::string_view, std::size(Table)> names{};
    for (size_t i = 0; i < names.size(); ++i) names[i] = Table[i].name;
    return names;
}
template <auto& Table>
constexpr auto kNames = names_of<Table>();

template <class Job, auto& Table, auto... Path>
void set_choice(Job& j, const json& v, const ParseContext& ctx) {
    const std::string s = v.get<std::string>();
    for (const auto& [name, value] : Table)
        if (s == name) {
            if constexpr (std::is_same_v<decltype(value), const BvhType>) {
                if (value == BvhType::embree && !embree_available())
                    throw InvalidJob(ctx.pointer, ctx.pointer + " \"embree\" is not available: this build has no Embree "
                                                                "(install libembree-dev and rebuild)");
            }
            at<Path...>(j) = value;
            return;
        }
}

template <class Job, auto& Table, auto... Path>
json get_choice(const Job& j) {
    for (const auto& [name, value] : Table)
        if (at<Path...>(j) == value) return std::string(name);
    return "?";
}

template <class Job, auto... Path>
void set_text(Job& j, const json& v, const ParseContext&) {
    at<Path...>(j) = v.is_null() ? std::string() : v.get<std::string>();
}

template <class Job, auto... Path>
json get_nullable_text(const Job& j) {
    const std::string& s = at<Path...>(j);
    return s.empty() ? json(nullptr) : json(s);
}

// A row with its identity set and everything else at the struct's defaults.
template <class Job>
constexpr Field<Job> field(std::string_view name, FieldKind kind, std::string_view help, std::string_view def) {
    Field<Job> f;
    f.name = name;
    f.kind = kind;
    f.help = help;
    f.default_json = def;
    return f;
}

constexpr int64_t kInt64Max = std::numeric_limits<int64_t>::max();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Field constructors, so that each table row reads as one declaration.
template <class Job, auto... Path>
constexpr Field<Job> integer(std::string_view name, int64_t lo, int64_t hi, std::string_view def, std::string_view help,
                             std::string_view cli = {}, Limit limit = Limit::none) {
    Field<Job> f = field<Job>(name, FieldKind::integer, help, def);
    f.min_int = lo;
    f.max_int = hi;
    f.limit = limit;
    f.set = &set_number<Job, Path...>;
    f.get = &get_member<Job, Path...>;
    f.cli = cli;
    return f;
}

template <class Job, auto... Path>
constexpr Field<Job> number(std::string_view name, double lo, double hi, std::string_view def, std::string_view help,
                            std::string_view cli = {}, Limit limit = Limit::none, bool exclusive_min = false) {
    Field<Job> f = field<Job>(name, FieldKind::number, help, def);
    f.min_num = lo;
    f.max_num = hi;
    f.exclusive_min = exclusive_min;
    f.limit = limit;
    f.set = &set_number<Job, Path...>;
    f.get = &get_member<Job, Path...>;
    f.cli = cli;
    return f;
}

template <class Job, auto& Table, auto... Path>
constexpr Field<Job> choice(std::string_view name, std::string_view def, std::string_view help, std::string_view cli = {}) {
    Field<Job> f = field<Job>(name, FieldKind::choice, help, def);
    f.choices = kNames<Table>;
    f.set = &set_choice<Job, Table, Path...>;
    f.get = &get_choice<Job, Table, Path...>;
    f.cli = cli;
    return f;
}

template <class Job>
constexpr Field<Job> scene_field(std::string_view help) {
    Field<Job> f = field<Job>("scene", FieldKind::text, help, "");
    f.min_int = 1;
    f.max_int = 4096;
    f.set = &set_text<Job, &Job::scene>;
    f.get = &get_member<Job, &Job::scene>;
    f.per_config = false;
    return f;
}

template <class Job>
constexpr Field<Job> not_per_config(Field<Job> f) {
    f.per_config = false;
    return f;
}

// "adaptive": null, or an object of the adaptive table's fields.
void set_adaptive(RenderJob& j, const json& v, const ParseContext& ctx) {
    if (v.is_null()) {
        j.render.adaptive.reset();
        return;
    }
    if (!v.is_object()) throw InvalidJob(ctx.pointer, ctx.pointer + " must be an object {\"batch\", \"tolerance\"} or null");
    AdaptiveSettings a;
    apply_defaults(adaptive_fields(), a);
    parse_fields(v, adaptive_fields(), a, ctx.pointer, ctx.limits);
    j.render.adaptive = a;
}

json get_adaptive(const RenderJob& j) {
    return j.render.adaptive ? fields_to_json(adaptive_fields(), *j.render.adaptive) : json(nullptr);
}

// "frames": null (a still), {"start", "end", "step"} or a list of distinct frame numbers. A list
// is kept to kMaxFrameList: the job's settings (with the list) come back with every status and
// job listing, and a range says any longer shot in three numbers.
void set_frames(RenderJob& j, const json& v, const ParseContext& ctx) {
    constexpr int64_t kMaxFrame = 10'000'000;
    constexpr int64_t kMaxFrameList = 1000;
    const std::string& p = ctx.pointer;
    if (v.is_null()) {
        j.frames.reset();
        return;
    }
    auto frame_number = [&](const json& x, const std::string& at) {
        if (!x.is_number_integer() && !(x.is_number_float() && std::trunc(x.get<double>()) == x.get<double>()))
            throw InvalidJob(at, at + " must be an integer frame number");
        const double d = x.get<double>();
        if (!(d >= -double(kMaxFrame) && d <= double(kMaxFrame)))
            throw InvalidJob(at, at + " must lie within ±" + std::to_string(kMaxFrame));
        return int(d);
    };
    const int64_t max_frames = ctx.limits.max_frames;
    FrameSet f;
    if (v.is_array()) {
        if (v.empty()) throw InvalidJob(p, p + " must list at least one frame");
        const int64_t max_list = std::min(max_frames, kMaxFrameList);
        if (int64_t(v.size()) > max_list)
            throw InvalidJob(p, p + " lists " + std::to_string(v.size()) + " frames, over the limit of " + std::to_string(max_list) +
                                    (max_list == kMaxFrameList ? " for a list (give a range {start, end, step} for more)" : ""));
        for (size_t i = 0; i < v.size(); ++i) f.list.push_back(frame_number(v[i], p + "/" + std::to_string(i)));
        std::vector<int> sorted = f.list;
        std::sort(sorted.begin(), sorted.end());
        if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
            throw InvalidJob(p, p + " lists a frame twice");
    } else if (v.is_object()) {
        for (const auto& [key, value] : v.items())
            if (key != "start" && key != "end" && key != "step")
                throw InvalidJob(p + "/" + key, "unknown field '" + key + "' in " + p + " (expected start, end, step)");
        if (!v.contains("start") || !v.contains("end")) throw InvalidJob(p, p + " needs \"start\" and \"end\"");
        f.start = frame_number(v["start"], p + "/start");
        f.end = frame_number(v["end"], p + "/end");
        if (v.contains("step")) {
            const int step = frame_number(v["step"], p + "/step");
            if (step < 1) throw InvalidJob(p + "/step", p + "/step must be at least 1");
            f.step = step;
        }
        if (f.end < f.start) throw InvalidJob(p + "/end", p + "/end must not come before start");
        if (int64_t(f.count()) > max_frames)
            throw InvalidJob(p, p + " spans " + std::to_string(f.count()) + " frames, over the limit of " + std::to_string(max_frames));
    } else {
        throw InvalidJob(p, p + " must be {\"start\", \"end\", \"step\"}, a list of frame numbers, or null (a still)");
    }
    j.frames = std::move(f);
}

json get_frames(const RenderJob& j) {
    if (!j.frames) return nullptr;
    if (!j.frames->list.empty()) return j.frames->list;
    return {{"start", j.frames->start}, {"end", j.frames->end}, {"step", j.frames->step}};
}

// "passes": a list of distinct AOV names (engine/render/aov.h).
void set_passes(RenderJob& j, const json& v, const ParseContext& ctx) {
    const std::string& p = ctx.pointer;
    std::string names;
    for (const AovInfo& i : kAovInfo) names += (names.empty() ? "" : ", ") + std::string(i.name);
    if (!v.is_array()) throw InvalidJob(p, p + " must be a list of pass names (" + names + ")");
    if (v.size() > kAovInfo.size()) throw InvalidJob(p, p + " lists " + std::to_string(v.size()) + " passes; there are " + std::to_string(kAovInfo.size()));
    AovSet set = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        const std::string at = p + "/" + std::to_string(i);
        Aov a;
        if (!v[i].is_string() || !aov_named(v[i].get_ref<const std::string&>(), a))
            throw InvalidJob(at, at + " must be one of " + names + ", got " + json_excerpt(v[i]));
        if (has_aov(set, a)) throw InvalidJob(at, p + " lists " + json_text(v[i]) + " twice");
        set |= aov_bit(a);
    }
    j.render.aovs = set;
}

json get_passes(const RenderJob& j) { return aov_names(j.render.aovs); }

// "after": distinct job ids (that they exist is the queue's to check).
template <class Job>
void set_after(Job& j, const json& v, const ParseContext& ctx) {
    const std::string& p = ctx.pointer;
    if (!v.is_array()) throw InvalidJob(p, p + " must be a list of job ids");
    if (v.size() > kMaxAfter) throw InvalidJob(p, p + " lists " + std::to_string(v.size()) + " jobs; at most " + std::to_string(kMaxAfter));
    std::vector<std::string> ids;
    for (size_t i = 0; i < v.size(); ++i) {
        const std::string at = p + "/" + std::to_string(i);
        const bool hex = v[i].is_string() && v[i].get_ref<const std::string&>().size() == 16 &&
                         v[i].get_ref<const std::string&>().find_first_not_of("0123456789abcdef") == std::string::npos;
        if (!hex) throw InvalidJob(at, at + " must be a job id (16 lowercase hexadecimal digits), got " + json_excerpt(v[i]));
        if (std::find(ids.begin(), ids.end(), v[i].get<std::string>()) != ids.end())
            throw InvalidJob(at, p + " lists " + json_text(v[i]) + " twice");
        ids.push_back(v[i].get<std::string>());
    }
    j.after = std::move(ids);
}

template <class Job>
json get_after(const Job& j) { return j.after; }

// "notify": {"url": "http[s]://host[:port]/path", "frames": false} or null. Whether the server may
// call the URL is the queue's to check (its allow list).
template <class Job>
void set_notify(Job& j, const json& v, const ParseContext& ctx) {
    const std::string& p = ctx.pointer;
    if (v.is_null()) {
        j.notify.reset();
        return;
    }
    if (!v.is_object()) throw InvalidJob(p, p + " must be {\"url\": \"https://host[:port]/path\", \"frames\": false} or null");
    NotifySpec n;
    for (const auto& [k, x] : v.items()) {
        const std::string at = p + "/" + k;
        if (k == "url") {
            if (!x.is_string()) throw InvalidJob(at, at + " must be a string");
            n.url = x.template get<std::string>();
        } else if (k == "frames") {
            if (!x.is_boolean()) throw InvalidJob(at, at + " must be true or false");
            n.frames = x.template get<bool>();
        } else {
            throw InvalidJob(at, "unknown field " + at + " (expected url, frames)");
        }
    }
    const std::string at = p + "/url";
    if (n.url.empty()) throw InvalidJob(at, at + " is required");
    if (n.url.size() > 2048) throw InvalidJob(at, at + " is longer than 2048 characters");
    const bool https = n.url.rfind("https://", 0) == 0;
    if (!https && n.url.rfind("http://", 0) != 0) throw InvalidJob(at, at + " must be an http:// or https:// URL");
    for (unsigned char c : n.url)
        if (c <= 0x20 || c >= 0x7f) throw InvalidJob(at, at + " holds a space or a character outside printable ASCII");
    const std::string rest = n.url.substr(https ? 8 : 7);
    const std::string authority = rest.substr(0, rest.find('/'));
    if (authority.empty()) throw InvalidJob(at, at + " names no host");
    if (authority.find('@') != std::string::npos) throw InvalidJob(at, at + " must not carry a user or password");
    j.notify = std::move(n);
}

template <class Job>
json get_notify(const Job& j) {
    if (!j.notify) return nullptr;
    return {{"url", j.notify->url}, {"frames", j.notify->frames}};
}

template <class Job>
Field<Job> notify_field() {
    Field<Job> f = field<Job>("notify", FieldKind::object,
                              "{url, frames}: the job's status is POSTed to url when it ends (and after each frame of a shot, "
                              "with frames), signed with HMAC-SHA256 in X-Tessera-Signature; only URLs the server's --notify-allow "
                              "admits.",
                              "null");
    f.nullable = true;
    f.set = &set_notify<Job>;
    f.get = &get_notify<Job>;
    f.per_config = false;
    return f;
}

template <class Job>
Field<Job> after_field() {
    Field<Job> f = field<Job>("after", FieldKind::object,
                              "Ids of jobs this one runs after: it waits (state waiting) until every one has succeeded, and "
                              "fails (or is canceled) naming the one that failed (or was canceled).",
                              "[]");
    f.set = &set_after<Job>;
    f.get = &get_after<Job>;
    f.per_config = false;
    return f;
}

// "requires": node tags, distinct; kept sorted so that equal sets name one task lane.
template <class Job>
void set_requires(Job& j, const json& v, const ParseContext& ctx) {
    const std::string& p = ctx.pointer;
    if (!v.is_array()) throw InvalidJob(p, p + " must be a list of node tags");
    if (v.size() > kMaxRequires)
        throw InvalidJob(p, p + " lists " + std::to_string(v.size()) + " tags; at most " + std::to_string(kMaxRequires));
    std::vector<std::string> tags;
    for (size_t i = 0; i < v.size(); ++i) {
        const std::string at = p + "/" + std::to_string(i);
        if (!v[i].is_string() || !valid_node_tag(v[i].template get<std::string>()))
            throw InvalidJob(at, at + " must be a node tag (1 to 32 of a-z 0-9 _ . -, starting with a letter or digit), got " +
                                     json_excerpt(v[i]));
        if (std::find(tags.begin(), tags.end(), v[i].template get<std::string>()) != tags.end())
            throw InvalidJob(at, p + " lists " + json_text(v[i]) + " twice");
        tags.push_back(v[i].template get<std::string>());
    }
    std::sort(tags.begin(), tags.end());
    j.tasks.required_tags = std::move(tags);
}

template <class Job>
json get_requires(const Job& j) { return j.tasks.required_tags; }

// The farm's task policy: retries, blocklists and the tags a node needs.
template <class Job>
Field<Job> requires_field() {
    Field<Job> f = field<Job>("requires", FieldKind::object,
                              "Node tags a render node needs to take the job's tasks (tessera worker --tags); a job no live "
                              "node can take stays queued and says so in its status.",
                              "[]");
    f.set = &set_requires<Job>;
    f.get = &get_requires<Job>;
    f.per_config = false;
    return f;
}

template <class Job>
Field<Job> max_retries_field() {
    return not_per_config(integer<Job, &Job::tasks, &TaskPolicy::max_retries>(
        "max_retries", 0, 100, "3",
        "Times a failed task is tried again, on another node where there is one, before the job fails with every reason."));
}

template <class Job>
Field<Job> blocklist_after_field() {
    return not_per_config(integer<Job, &Job::tasks, &TaskPolicy::blocklist_after>(
        "blocklist_after", 1, 100, "3", "Failed tasks of this job after which a node takes no more of them."));
}

template <class Job, auto... Path>
void set_bool(Job& j, const json& v, const ParseContext&) {
    at<Path...>(j) = v.get<bool>();
}

}  // namespace

json animation_json(const RenderJob& j) {
    if (j.animation.empty()) return nullptr;
    return j.animation_index ? json(std::stoll(j.animation)) : json(j.animation);
}

namespace {

// "animation": a name (or, where no animation has that name, the index its digits spell), an
// index given as a number (never a name: a file may name an animation "1"), or null for every
// animation at once.
void set_animation(RenderJob& j, const json& v, const ParseContext& ctx) {
    j.animation_index = false;
    if (v.is_null()) j.animation.clear();
    else if (v.is_number_integer() && v.get<int64_t>() >= 0 && v.get<int64_t>() < 1'000'000) j.animation = std::to_string(v.get<int64_t>()), j.animation_index = true;
    else if (v.is_string() && !v.get<std::string>().empty() && v.get<std::string>().size() <= 256) j.animation = v.get<std::string>();
    else throw InvalidJob(ctx.pointer, ctx.pointer + " must be an animation's name (1 to 256 characters), its index, or null (every animation)");
}

json get_animation(const RenderJob& j) { return animation_json(j); }

// "shutter": null (none) or {"open", "close"} in frames around each frame, -1 <= open < close <= 1.
void set_shutter(RenderJob& j, const json& v, const ParseContext& ctx) {
    const std::string& p = ctx.pointer;
    if (v.is_null()) {
        j.shutter.reset();
        return;
    }
    if (!v.is_object()) throw InvalidJob(p, p + " must be {\"open\": O, \"close\": C} in frames, or null (no motion blur)");
    for (const auto& [key, value] : v.items())
        if (key != "open" && key != "close") throw InvalidJob(p + "/" + key, "unknown field '" + key + "' (open, close)");
    auto read = [&](const char* key) {
        const auto it = v.find(key);
        if (it == v.end() || !it->is_number()) throw InvalidJob(p + "/" + key, p + "/" + key + " must be a number of frames");
        const double x = it->get<double>();
        if (!std::isfinite(x) || x < -1.0 || x > 1.0) throw InvalidJob(p + "/" + key, p + "/" + key + " must lie in [-1, 1] frames");
        return x;
    };
    const double open = read("open"), close = read("close");
    if (!(open < close)) throw InvalidJob(p + "/close", "the shutter must close after it opens (open < close)");
    j.shutter = std::make_pair(open, close);
}

json get_shutter(const RenderJob& j) {
    if (!j.shutter) return nullptr;
    return {{"open", j.shutter->first}, {"close", j.shutter->second}};
}

const Field<AdaptiveSettings> kAdaptiveFields[] = {
    integer<AdaptiveSettings, &AdaptiveSettings::batch>("batch", 1, 1 << 16, "32", "Samples between convergence checks.",
                                                        {}, Limit::spp),
    number<AdaptiveSettings, &AdaptiveSettings::tolerance>("tolerance", 0, 1e6, "0.05",
                                                           "Stop a pixel when 1.96·σ/√n ≤ tolerance·μ."),
};

const Field<RenderJob> kRenderFields[] = {
    scene_field<RenderJob>("A scene name from GET /v1/scenes, or (CLI) a .dae/.gltf/.glb file or builtin:NAME."),
    not_per_config(integer<RenderJob, &RenderJob::render, &RenderSettings::width>(
        "width", 1, 16384, "800", "Image width in pixels.", "--width", Limit::dimension)),
    not_per_config(integer<RenderJob, &RenderJob::render, &RenderSettings::height>(
        "height", 1, 16384, "600", "Image height in pixels.", "--height", Limit::dimension)),
    not_per_config(integer<RenderJob, &RenderJob::render, &RenderSettings::spp>(
        "spp", 1, 1 << 16, "1", "Samples per pixel (the maximum, with adaptive sampling).", "-s,--spp", Limit::spp)),
    integer<RenderJob, &RenderJob::render, &RenderSettings::light_rays>(
        "light_rays", 1, 1024, "1", "Samples per area light per shading point.", "-l,--light-rays", Limit::light_rays),
    integer<RenderJob, &RenderJob::render, &RenderSettings::max_depth>(
        "max_depth", 0, 1000, "1", "Max ray depth: 0 emitted light, 1 direct, n bounces.", "-m,--max-depth", Limit::depth),
    choice<RenderJob, kBvh, &RenderJob::scene_options, &RenderSceneOptions::bvh, &BvhBuildOptions::type>(
        "bvh", "\"sah\"", "Triangle BVH (embree: Intel Embree 3, for comparison).", "--bvh"),
    integer<RenderJob, &RenderJob::scene_options, &RenderSceneOptions::bvh, &BvhBuildOptions::max_leaf_size>(
        "max_leaf_size", 1, 255, "8", "Largest BVH leaf, in triangles.", "--max-leaf"),
    choice<RenderJob, kTriangle, &RenderJob::scene_options, &RenderSceneOptions::triangle_test>(
        "triangle_test", "\"watertight\"", "Ray-triangle test.", "--triangle-test"),
    choice<RenderJob, kDirect, &RenderJob::render, &RenderSettings::direct>(
        "direct", "\"mis\"",
        "Direct lighting for the diffuse part: hemisphere, light (importance) sampling, or MIS of both; glossy lobes always by MIS, "
        "smooth ones from the BSDF.", "--direct"),
    choice<RenderJob, kIntegrator, &RenderJob::render, &RenderSettings::integrator>(
        "integrator", "\"path\"", "Path tracing, or the surface normals as colours.", "--integrator"),
    number<RenderJob, &RenderJob::render, &RenderSettings::russian_roulette>(
        "russian_roulette", 0, 1, "0", "Russian roulette continuation probability; 0 turns it off.", "--rr"),
    choice<RenderJob, kBounces, &RenderJob::render, &RenderSettings::bounces>(
        "bounces", "\"accumulate\"", "accumulate every bounce, or keep only bounce max_depth (nth).", "--bounces"),
    choice<RenderJob, kLighting, &RenderJob::render, &RenderSettings::output>(
        "lighting", "\"all\"", "all light, direct (bounces 0-1) or indirect (bounces 2 and up).", "--lighting"),
    choice<RenderJob, kSelection, &RenderJob::render, &RenderSettings::light_selection>(
        "light_selection", "\"auto\"", "Every area light light_rays times (all), light_rays in all by power, light_rays in all by a light tree (tree: by estimated contribution at each point), or auto: the tree above 256 area lights, all otherwise (the report says which).",
        "--light-selection"),
    choice<RenderJob, kSampler, &RenderJob::render, &RenderSettings::sampler>(
        "sampler", "\"sobol\"", "Owen-scrambled Sobol points (stratified: less error per sample), or independent random numbers.",
        "--sampler"),
    [] {
        Field<RenderJob> f = field<RenderJob>("adaptive", FieldKind::object, "Adaptive sampling {batch, tolerance}, or null (off).", "null");
        f.nullable = true;
        f.set = &set_adaptive;
        f.get = &get_adaptive;
        return f;
    }(),
    number<RenderJob, &RenderJob::render, &RenderSettings::lens_radius>(
        "lens_radius", 0, 1e6, "0", "Thin-lens radius in scene units (CS184 -b); 0: a pinhole.", "-b,--lens-radius"),
    number<RenderJob, &RenderJob::render, &RenderSettings::focal_distance>(
        "focal_distance", 0, 1e9, "0", "Distance of the plane in focus along the view (CS184 -d); 0: the camera's look-at point.",
        "-d,--focal-distance"),
    [] {
        Field<RenderJob> f = field<RenderJob>(
            "environment", FieldKind::text,
            "A latitude-longitude environment map (.exr or .hdr) lighting the scene from infinity (CS184 -e): a name "
            "from the server's scene folders, or (CLI) a file; null: none.",
            "null");
        f.cli = "-e,--environment";
        f.nullable = true;
        f.min_int = 1;
        f.max_int = 4096;
        f.set = &set_text<RenderJob, &RenderJob::environment>;
        f.get = &get_nullable_text<RenderJob, &RenderJob::environment>;
        f.per_config = false;
        return f;
    }(),
    integer<RenderJob, &RenderJob::render, &RenderSettings::tile_size>("tile_size", 1, 4096, "32", "Tile edge in pixels.",
                                                                      "--tile"),
    not_per_config(integer<RenderJob, &RenderJob::render, &RenderSettings::seed>(
        "seed", 0, kInt64Max, "0", "Seed of every pixel's random streams.", "--seed")),
    not_per_config(integer<RenderJob, &RenderJob::priority>("priority", -1000, 1000, "0",
                                                            "Queue priority: higher runs first.")),
    not_per_config(number<RenderJob, &RenderJob::render, &RenderSettings::time_limit_s>(
        "time_limit_s", 0, 7 * 24 * 3600.0, "0", "Wall-clock limit in seconds from the job's start; 0: none.",
        "--time-limit", Limit::time_limit)),
    not_per_config(number<RenderJob, &RenderJob::render, &RenderSettings::target_error>(
        "target_error", 0, 1e6, "0", "Stop at this relative MSE; 0: none.", "--target-error")),
    [] {
        Field<RenderJob> f = field<RenderJob>(
            "passes", FieldKind::object,
            "Render passes (AOVs) for compositing, written beside the image as one multilayer OpenEXR (passes.exr) and each "
            "alone: albedo, normal, depth, position, object_id, material_id, the light split emission, environment, "
            "diffuse_direct, diffuse_indirect, glossy_direct, glossy_indirect (which sum to the image), variance, and the "
            "Cryptomatte mattes crypto_object and crypto_material.",
            "[]");
        f.cli = "--passes";
        f.set = &set_passes;
        f.get = &get_passes;
        f.per_config = false;
        return f;
    }(),
    [] {
        Field<RenderJob> f = field<RenderJob>(
            "denoise", FieldKind::boolean,
            "Denoise after every pass from 4 spp on and the last (denoised.exr and denoised.png beside the image) and "
            "report the denoised image's estimated error; target_error then applies to the denoised image. Needs spp 2 "
            "or more (the denoiser compares each pixel's two halves).",
            "false");
        f.cli = "--denoise";
        f.set = &set_bool<RenderJob, &RenderJob::render, &RenderSettings::denoise>;
        f.get = &get_member<RenderJob, &RenderJob::render, &RenderSettings::denoise>;
        f.per_config = false;
        return f;
    }(),
    [] {
        Field<RenderJob> f = field<RenderJob>(
            "guided_sampling", FieldKind::boolean,
            "With denoise: after the uniform passes up to 8 spp, each pass spends its samples where the denoised image's "
            "estimated error is (silhouettes, lamp rims, detail), spp being the mean; false samples every pixel alike. "
            "No effect without denoise.",
            "true");
        f.cli = "--guided-sampling";
        f.set = &set_bool<RenderJob, &RenderJob::render, &RenderSettings::guided>;
        f.get = &get_member<RenderJob, &RenderJob::render, &RenderSettings::guided>;
        f.per_config = false;
        return f;
    }(),
    after_field<RenderJob>(),
    notify_field<RenderJob>(),
    requires_field<RenderJob>(),
    max_retries_field<RenderJob>(),
    blocklist_after_field<RenderJob>(),
    [] {
        Field<RenderJob> f = field<RenderJob>("reference", FieldKind::job_id, "A finished job whose image the error is measured against.",
                           "null");
        f.nullable = true;
        f.set = &set_text<RenderJob, &RenderJob::reference>;
        f.get = &get_nullable_text<RenderJob, &RenderJob::reference>;
        f.per_config = false;
        return f;
    }(),
    [] {
        Field<RenderJob> f = field<RenderJob>(
            "frames", FieldKind::object,
            "A shot: the frames of the scene's animation to render, {start, end, step} or a list; frame n is the scene at "
            "n / fps seconds. null: a still at rest.",
            "null");
        f.cli = "--frames";
        f.nullable = true;
        f.set = &set_frames;
        f.get = &get_frames;
        f.per_config = false;
        return f;
    }(),
    not_per_config(number<RenderJob, &RenderJob::fps>("fps", 0, 1000, "24",
                                                      "A shot's frames per second (glTF files carry none); every frame's time, n / fps "
                                                      "with its shutter, within 1e9 s.",
                                                      "--fps", Limit::none, true)),
    not_per_config(integer<RenderJob, &RenderJob::chunk>(
        "chunk", 0, 100'000, "0",
        "A shot on a render farm: frames per task (a node opens the scene once per shot and keeps it across its chunks); 0: chosen from the first frame's "
        "measured open and render times.")),
    [] {
        Field<RenderJob> f = field<RenderJob>(
            "animation", FieldKind::object,
            "Which of the file's animations a shot plays: a name, or an index (a JSON number is an index only; digits in a string "
            "are an index where no animation has that name); null: every animation at once, as viewers play them.",
            "null");
        f.cli = "--animation";
        f.nullable = true;
        f.set = &set_animation;
        f.get = &get_animation;
        f.per_config = false;
        return f;
    }(),
    [] {
        Field<RenderJob> f = field<RenderJob>(
            "shutter", FieldKind::object,
            "A shot's motion blur: {open, close} in frames around each frame (e.g. -0.25 and 0.25, a 180° shutter); the camera, "
            "moving placements and deforming meshes move within it. null: none.",
            "null");
        f.nullable = true;
        f.set = &set_shutter;
        f.get = &get_shutter;
        f.per_config = false;
        return f;
    }(),
};

// "configs": "standard", or 1 to 32 objects with a label and render fields.
void set_configs(ComparisonJob& j, const json& v, const ParseContext& ctx) {
    j.configs.clear();
    j.standard_configs = v.is_string() && v == "standard";
    if (j.standard_configs) return;
    if (!v.is_array() || v.empty() || v.size() > 32)
        throw InvalidJob(ctx.pointer, ctx.pointer + " must be \"standard\" or an array of 1 to 32 configurations");
    for (size_t i = 0; i < v.size(); ++i) {
        const std::string p = ctx.pointer + "/" + std::to_string(i);
        if (!v[i].is_object() || !v[i].contains("label") || !v[i]["label"].is_string())
            throw InvalidJob(p, p + " needs a \"label\"");
        json fields = v[i];
        fields.erase("label");
        ComparisonConfigJob c{v[i]["label"].get<std::string>(), default_render_job(), v[i]};
        parse_fields(fields, render_job_fields(), c.job, p, ctx.limits, true);
        j.configs.push_back(std::move(c));
    }
}

json get_configs(const ComparisonJob& j) {
    if (j.standard_configs) return "standard";
    json list = json::array();
    for (const ComparisonConfigJob& c : j.configs) list.push_back(c.given);
    return list;
}

const Field<ComparisonJob> kComparisonFields[] = {
    scene_field<ComparisonJob>("A scene name from GET /v1/scenes."),
    integer<ComparisonJob, &ComparisonJob::width>("width", 8, 1024, "160", "Image width of every run."),
    integer<ComparisonJob, &ComparisonJob::height>("height", 8, 1024, "120", "Image height of every run."),
    integer<ComparisonJob, &ComparisonJob::max_depth>("max_depth", 0, 1000, "5", "Max ray depth of every run.", {},
                                                      Limit::depth),
    number<ComparisonJob, &ComparisonJob::seconds>("seconds", 0, 600, "2", "Render time of each run.", {}, Limit::none,
                                                   true),
    integer<ComparisonJob, &ComparisonJob::reps>("reps", 1, 20, "3", "Runs per configuration."),
    integer<ComparisonJob, &ComparisonJob::reference_spp>("reference_spp", 1, 1 << 16, "1024",
                                                          "Samples per pixel of the reference (MIS).", {}, Limit::spp),
    number<ComparisonJob, &ComparisonJob::target_error>("target_error", 0, kInf, "0.01",
                                                        "The relative MSE whose time to reach is reported.", {},
                                                        Limit::none, true),
    integer<ComparisonJob, &ComparisonJob::priority>("priority", -1000, 1000, "0", "Queue priority: higher runs first."),
    [] {
        Field<ComparisonJob> f = field<ComparisonJob>("configs", FieldKind::object,
                               "\"standard\", or a list of {label, render fields except scene, width, height, spp, seed, "
                               "priority, time_limit_s, target_error, reference}.",
                               "\"standard\"");
        f.set = &set_configs;
        f.get = &get_configs;
        return f;
    }(),
    after_field<ComparisonJob>(),
    notify_field<ComparisonJob>(),
    requires_field<ComparisonJob>(),
    max_retries_field<ComparisonJob>(),
    blocklist_after_field<ComparisonJob>(),
};

}  // namespace

std::span<const Field<RenderJob>> render_job_fields() { return kRenderFields; }
std::span<const Field<AdaptiveSettings>> adaptive_fields() { return kAdaptiveFields; }
std::span<const Field<ComparisonJob>> comparison_job_fields() { return kComparisonFields; }

}  // namespace tessera::api
