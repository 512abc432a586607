// depthpose synth --tall-clutter: room objects as tall as people (chairs, shelves, coat stands,
// doors) drawn after everything else, so datasets made without the option stay byte-identical.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "tools/synth/synth.h"
#include "tests/shared_data.h"

using namespace dp::synth;

namespace {

std::unique_ptr<Synthesizer> make(int people, int clutter, int tall, bool sequence) {
  const std::string assets = dp::test::shared_path("assets");
  EXPECT_TRUE(std::filesystem::exists(assets + "/makehuman/3dobjs/base.obj"))
      << "shared assets missing: expected " << assets << " (set DEPTHPOSE_SHARED or make test SHARED=DIR)";
  SynthConfig c;
  c.clips = {"02_01"};
  c.floor = true;
  c.people = people;
  c.clutter = clutter;
  c.tall_clutter = tall;
  c.sequence = sequence;
  return std::make_unique<Synthesizer>(assets, c);
}

// FNV-1a over everything a dataset stores for a frame: depth, parts, people ids, frames.jsonl extra.
uint64_t frame_digest(const SynthFrame& f) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* data, size_t n) {
    const auto* b = static_cast<const uint8_t*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  mix(f.depth.pixels.data(), f.depth.pixels.size() * sizeof(uint16_t));
  mix(f.parts.pixels.data(), f.parts.pixels.size());
  mix(f.people.pixels.data(), f.people.pixels.size());
  mix(f.extra_json.data(), f.extra_json.size());
  return h;
}

}  // namespace

// Digests of frames 0 and 1 of seed 7 (2 people, 4 short pieces, floor) rendered by the
// synthesizer before tall clutter existed (a --sequence scene is drawn by the same code).
TEST(SynthTallClutterSharedData, DatasetsWithoutTheOptionAreUnchanged) {
  auto synth = make(2, 4, 0, false);
  const uint64_t expected[2] = {0xd871695c9d903271ull, 0xff1f4d803e2be879ull};
  for (uint64_t i = 0; i < 2; ++i) {
    const uint64_t got = frame_digest(synth->render_frame(7, i));
    EXPECT_EQ(got, expected[i]) << "frame " << i << std::hex << ": digest 0x" << got;
  }
}
