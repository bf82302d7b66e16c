// Writing output files so that a reader never sees half of one.
#pragma once

#include <string>

namespace snowsim {

// Writes bytes to path.tmp and renames it over path. Throws InputError naming the path.
void writeFileAtomically(const std::string& path, const std::string& bytes);

// Creates the directory (and its parents) and checks that a file can be written in it.
// Throws InputError naming the directory when it cannot.
void prepareOutputDirectory(const std::string& dir);

}  // namespace snowsim
