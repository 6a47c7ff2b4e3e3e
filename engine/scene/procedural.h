#pragma once
// Scenes made in code: our Cornell boxes, analytic test scenes, and large meshes for
// benchmarks (generated on demand rather than committed).
#include <cstdint>
#include <string>

#include "engine/scene/scene_description.h"

namespace tessera {

// The CS184 Cornell box geometry (x in [-1,1], floor y=0, ceiling y=1.5, back wall z=-1, open
// front) with a 0.8 × 0.6 ceiling lamp of radiance 10.
SceneDescription cornell_box();
// The same with two analytic spheres (radius 0.3 and 0.25) on the floor.
SceneDescription cornell_spheres();
// The same with a rough gold sphere (glTF metallic 1, roughness 0.3) and a glossy blue plastic
// one (metallic 0, roughness 0.15): the glossy scene class of the Cycles comparison.
SceneDescription cornell_glossy();
// The Cornell box with spheres lit by 1,000 small ceiling lamps (many_lights(1000)): the
// many-lamp room of the Cycles comparison.
SceneDescription lamp_room(int lamps = 1000);
// The Cornell box with spheres lit by `lamps` small ceiling lamps (8 cm, smaller where the grid
// is dense so that none overlap) whose radiance spans two
// orders of magnitude (for light selection by power).
SceneDescription many_lights(int lamps = 32);
// The Cornell box with spheres lit only by `lamps` small two-sided square lamps (3 cm) scattered
// through its volume at random places and orientations, radiance 1 to 100 (a light hierarchy's
// test: most lamps matter little at any one point).
SceneDescription scattered_lights(int lamps = 1000);
// `lamps` equal small lamps (radiance 300, 10 cm, both sides) hovering at random over a 40 × 40
// field among 144 blocks, seen from above one end: most lamps are far from, or hidden from, most
// points, which is what a light hierarchy is for (a street or a hall at night). Without
// `blocks`, the same lamps over an open field (what occlusion costs a light tree).
SceneDescription lamp_field(int lamps = 1000, bool blocks = true);
// A closed cube of half-size `half` centred at `center` whose walls all emit `emission` and
// reflect with `albedo` (white furnace); the camera looks from inside.
SceneDescription furnace_box(float albedo, float emission, float half = 1.f, glm::vec3 center = glm::vec3(0.f));
// The furnace as a closed geodesic sphere (8·frequency² faces, turned so that no face is aligned
// with the axes) of radius `radius` at `center`, the camera at its centre.
SceneDescription furnace_sphere(float albedo, float emission, float radius = 1.f, glm::vec3 center = glm::vec3(0.f), int frequency = 4);
// A noisy subdivided sphere with at least `min_triangles` triangles and a directional light.
SceneDescription displaced_sphere(uint64_t min_triangles, uint32_t seed = 1);
// `count` placements (instances) of one displaced sphere of at least `triangles_each`
// triangles on a grid over a ground plane, turned, scaled and some mirrored; a camera above one
// corner. The sphere is stored once (SceneDescription::prototypes).
SceneDescription instanced_field(uint32_t count, uint64_t triangles_each, uint32_t seed = 1);

// "builtin:cornell_box", "builtin:cornell_spheres", "builtin:cornell_glossy", "builtin:lamp_room", "builtin:furnace", "builtin:many_lights", "builtin:scattered_lights",
// "builtin:lamp_field",
// "builtin:displaced_sphere?triangles=N" (N ≤ 20 million),
// "builtin:instances?count=N&triangles=T" (N ≤ 1 million placements of T ≤ 20 million). Throws SceneError for other names.
SceneDescription builtin_scene(const std::string& name);
// Checks a built-in name and its parameters without building the scene; throws SceneError.
// Also refuses a displaced sphere of more than `max_triangles` triangles (a loader's bound).
void check_builtin_name(const std::string& name, uint64_t max_triangles = UINT64_MAX);

// A lat-long sky for the environment light (engine/scene/environment.h): a blue gradient over
// a grey ground and a sun of angular radius 2° at 35° elevation whose radiance is 10,000 times
// the sky's, so that sampling by luminance matters. width × height × 3 linear floats.
std::vector<float> sky_environment(int width = 256, int height = 128);

}  // namespace tessera
