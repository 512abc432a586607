// Lets `depthpose info` describe trained-forest files (tools/info/info.h describer hook).
#include <cstring>
#include <iostream>

#include "tools/info/info.h"
#include "tools/train/forest_file.h"

namespace dp::train {
namespace {

bool describe_trained_forest_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  if (bytes.size() < 4 || std::memcmp(bytes.data(), kForestMagic, 4) != 0) return false;
  describe_forest(parse_forest(bytes.data(), bytes.size(), path), std::cout);  // throws ToolError if bad
  std::cout.flush();
  return true;
}

const tools::InfoDescriberRegistrar registrar(describe_trained_forest_file);

}  // namespace
}  // namespace dp::train
