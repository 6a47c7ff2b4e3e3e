// `tessera generate`: writes our procedural scenes as glTF files (scenes/ is made with it).
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "engine/io/gltf_writer.h"
#include "engine/io/image_io.h"
#include "engine/scene/procedural.h"
#include "cli/command_line.h"
#include "cli/commands.h"

namespace tessera::cli {

using server::parse_args;

int generate_command(int argc, char** argv) {
    if (argc == 0) {  // CLI11 would name only the first missing argument
        std::fprintf(stderr, "usage: tessera generate cornell_box|cornell_spheres|cornell_glossy|lamp_room|displaced_sphere FILE.gltf [--triangles N]\n"
                             "       tessera generate sky_environment FILE.exr\n");
        return 2;
    }
    std::string name, path;
    uint64_t triangles = 1'000'000;
    CLI::App app{"Writes one of our procedural scenes as a glTF file (scenes/ is made with it).", "generate"};
    app.add_option("scene", name, "the built-in scene")
        ->required()
        ->check(CLI::IsMember({"cornell_box", "cornell_spheres", "cornell_glossy", "lamp_room", "displaced_sphere", "sky_environment"}));
    app.add_option("file", path, "the glTF file to write (an EXR for sky_environment)")->required()->type_name("FILE.gltf");
    app.add_option("--triangles", triangles, "triangles of displaced_sphere")
        ->capture_default_str()
        ->check(CLI::Range(uint64_t{8}, uint64_t{20'000'000}));
    if (const auto status = parse_args(app, argc, argv)) return *status;
    if (name == "sky_environment") {
        const int w = 256, h = 128;
        const std::vector<float> rgb = sky_environment(w, h);
        Image img(w, h);
        img.rgb = rgb;
        write_exr(path, img);
        std::printf("wrote %s\n", path.c_str());
        return 0;
    }
    SceneDescription scene;
    if (name == "cornell_box") scene = cornell_box();
    else if (name == "cornell_spheres") scene = cornell_spheres();
    else if (name == "cornell_glossy") scene = cornell_glossy();
    else if (name == "lamp_room") scene = lamp_room();
    else scene = displaced_sphere(triangles);
    write_gltf(path, scene);
    std::printf("wrote %s\n", path.c_str());
    return 0;
}

}  // namespace tessera::cli
