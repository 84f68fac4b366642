// Meshes made in code for tests.
#pragma once
#include "engine/primitives.h"

namespace crumple::test {
using crumple::torusMesh;
}  // namespace crumple::test
