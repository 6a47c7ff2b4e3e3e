// The single translation unit that compiles tinygltf. It is built from source with the rest of
// the engine (not linked from Debian's libtinygltf.so) so that sanitizers and fuzzers instrument
// the parser too. Texture decoding and image files are switched off: the path tracer uses
// material factors only, so a broken or hostile image can never matter.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>
