// A test that runs snowsim's code on more than one thread. tests/CMakeLists.txt reads these
// declarations from the sources, one a line, and gives their tests the ctest label "threaded",
// which `scripts/sanitize.sh thread` runs under ThreadSanitizer.
#pragma once

#include <gtest/gtest.h>

#define THREADED_TEST(suite, name) TEST(suite, name)
