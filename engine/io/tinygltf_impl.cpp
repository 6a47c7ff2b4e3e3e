// The single translation unit that compiles tinygltf. It is built from source with the rest of
// the engine (not linked from Debian's libtinygltf.so) so that sanitizers and fuzzers instrument
// the parser too. Images are decoded by our own loader callback (engine/io/texture_decode.h),
// and image files are read through the loader's confined file callbacks like buffers.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>
