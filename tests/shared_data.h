// Where the tests find the shared inputs (MakeHuman assets and CMU mocap, PCL's trees, the
// Skeltrack frames): one setting, the environment variable DEPTHPOSE_SHARED (the Makefile sets it
// from `make test SHARED=DIR`, default ../shared beside the repository). Tests that read it carry
// "SharedData" in their suite name, so `--gtest_filter=-*SharedData*` runs the others.
#pragma once

#include <cstdlib>
#include <string>

namespace dp::test {

// The shared folder, without a trailing slash.
inline std::string shared_dir() {
  const char* dir = std::getenv("DEPTHPOSE_SHARED");
  return (dir != nullptr && dir[0] != '\0') ? std::string(dir) : std::string("../shared");
}

// A path under the shared folder, e.g. shared_path("data/skeltrack-frames").
inline std::string shared_path(const std::string& relative) { return shared_dir() + "/" + relative; }

}  // namespace dp::test
