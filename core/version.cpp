#include <crumple/core/version.h>

namespace crumple {

const char* versionString() { return CRUMPLE_VERSION_STRING; }
int version() { return CRUMPLE_VERSION; }

}  // namespace crumple
