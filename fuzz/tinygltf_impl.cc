// tinygltf's implementation, compiled into the fuzzer so that it is
// instrumented (coverage, AddressSanitizer) like our own code; these
// definitions take precedence over Debian's uninstrumented libtinygltf.so.
// Images are never decoded by tinygltf here (the loader installs its own
// image callback), and nothing is written.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>
