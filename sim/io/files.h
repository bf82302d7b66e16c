// Writing output files so that a reader never sees half of one.
#pragma once

#include <string>

namespace snowsim {

// Writes bytes to path.tmp and renames it over path. Throws InputError naming the path.
void writeFileAtomically(const std::string& path, const std::string& bytes);

// Syncs a file written by other means (a library's writer) to disk before it is renamed over
// `path`, as writeFileAtomically does. Throws InputError naming `path`.
void syncFile(const std::string& written, const std::string& path);

// A file being written, as long as this lives: removeUnfinishedFiles() removes it. For temporaries,
// a video's .part and a run directory's lock, which a stop at once must not leave behind.
class UnfinishedFile {
 public:
  explicit UnfinishedFile(const std::string& path);
  ~UnfinishedFile();
  UnfinishedFile(const UnfinishedFile&) = delete;
  UnfinishedFile& operator=(const UnfinishedFile&) = delete;

 private:
  int slot_;  // -1: more files at once than are kept track of
};

// Removes every file an UnfinishedFile names now. Async-signal-safe: for a signal handler that
// ends the process at once.
void removeUnfinishedFiles();

// Creates the directory (and its parents) and checks that a file can be written in it.
// Throws InputError naming the directory when it cannot.
void prepareOutputDirectory(const std::string& dir);

}  // namespace snowsim
