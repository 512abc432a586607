// A Synthesizer for room scenes (one clip, 02_01; a floor; people and clutter) for the tests of
// synth --people, --clutter and --tall-clutter. Fails the calling test with a message naming the
// shared folder when the MakeHuman assets are missing (the constructor then throws too).
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>

#include "tools/synth/synth.h"
#include "tests/shared_data.h"

namespace dp::test {

inline std::unique_ptr<dp::synth::Synthesizer> make_room_synth(int people, int clutter, int tall_clutter = 0) {
  const std::string assets = shared_path("assets");
  EXPECT_TRUE(std::filesystem::exists(assets + "/makehuman/3dobjs/base.obj"))
      << "shared assets missing: expected " << assets << " (set DEPTHPOSE_SHARED or make test SHARED=DIR)";
  dp::synth::SynthConfig c;
  c.clips = {"02_01"};
  c.floor = true;
  c.people = people;
  c.clutter = clutter;
  c.tall_clutter = tall_clutter;
  return std::make_unique<dp::synth::Synthesizer>(assets, c);
}

}  // namespace dp::test
