// libFuzzer target: the mhclo garment reader (tools/synth/garment.h) refuses malformed input with
// a ToolError, never crashes or hangs. The input is the mhclo text, a NUL byte, then the .obj text
// (without a NUL, the whole input is the mhclo and the .obj is empty). Accepted garments must
// satisfy the header's promises: indices in range, one binding per .obj vertex.
#include <cstdint>
#include <string>

#include "tools/common/error.h"
#include "tools/synth/garment.h"

namespace {
constexpr size_t kBaseVertices = 19158;  // hm08
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t nul = input.find('\0');
  const std::string mhclo = input.substr(0, nul);
  const std::string obj = nul == std::string::npos ? std::string() : input.substr(nul + 1);
  try {
    dp::synth::Garment g = dp::synth::parse_mhclo(mhclo, "fuzz.mhclo", kBaseVertices);
    for (const auto& b : g.bindings)
      for (uint32_t v : b.vertices)
        if (v >= kBaseVertices) __builtin_trap();
    for (uint32_t v : g.delete_vertices)
      if (v >= kBaseVertices) __builtin_trap();
    dp::synth::parse_garment_obj(obj, "fuzz.obj", g);
    if (g.obj_vertex_count != g.bindings.size()) __builtin_trap();
    for (const auto& t : g.triangles)
      for (uint32_t v : t)
        if (v >= g.bindings.size()) __builtin_trap();
  } catch (const dp::tools::ToolError&) {
  }
  return 0;
}
