// depthpose synth --tall-clutter: room objects as tall as people (chairs, shelves, coat stands,
// doors) drawn after everything else, so datasets made without the option stay byte-identical.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "tools/synth/synth.h"
#include "tests/synth_room_scene.h"

using namespace dp::synth;

namespace {

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
  auto synth = dp::test::make_room_synth(2, 4);
  const uint64_t expected[2] = {0xd871695c9d903271ull, 0xff1f4d803e2be879ull};
  for (uint64_t i = 0; i < 2; ++i) {
    const uint64_t got = frame_digest(synth->render_frame(7, i));
    EXPECT_EQ(got, expected[i]) << "frame " << i << std::hex << ": digest 0x" << got;
  }
}

// Tall pieces follow the short ones, each of its kind's size, clear of every body, named in
// frames.jsonl; they are background (label 255, no body id) nearer than what they hide.
TEST(SynthTallClutterSharedData, TallPiecesFollowTheShortOnesAndAreBackground) {
  auto synth = dp::test::make_room_synth(2, 3, 8);
  int kinds[6] = {};
  for (uint64_t frame = 0; frame < 3; ++frame) {
    SCOPED_TRACE(frame);
    const FrameParams p = synth->sample_frame_params(11, frame);
    size_t short_count = 0;
    while (short_count < p.clutter.size() && p.clutter[short_count].kind <= ClutterKind::kCylinder) ++short_count;
    EXPECT_LE(short_count, 3u);
    EXPECT_GE(p.clutter.size() - short_count, 5u) << "placement failed for most tall pieces";
    for (size_t i = 0; i < p.clutter.size(); ++i) {
      const ClutterItem& c = p.clutter[i];
      kinds[int(c.kind)]++;
      if (i < short_count) {
        EXPECT_LE(c.height, 0.8);
        continue;
      }
      ASSERT_GE(c.kind, ClutterKind::kChair) << "a short piece after a tall one";
      const double lo[6] = {0, 0, 0.8, 1.2, 1.6, 1.95}, hi[6] = {0, 0, 1.1, 2.0, 1.9, 2.1};
      EXPECT_GE(c.height, lo[int(c.kind)]) << clutter_kind_name(c.kind);
      EXPECT_LE(c.height, hi[int(c.kind)]) << clutter_kind_name(c.kind);
    }
    // Clear of body 0 (placed at distance_m along the ray through image_x).
    const dp::synth::Intrinsics& k = synth->intrinsics();
    const double body_x = -p.distance_m * (p.image_x * k.width - k.cx) / k.fx, body_z = p.distance_m;
    for (const ClutterItem& c : p.clutter)
      EXPECT_GE(std::hypot(c.x - body_x, c.z - body_z), 0.55 + 0.5 * std::hypot(c.width, c.depth));

    const SynthFrame with = synth->render(p);
    FrameParams without_tall = p;
    without_tall.clutter.resize(short_count);
    const SynthFrame without = synth->render(without_tall);
    const nlohmann::json extra = nlohmann::json::parse(with.extra_json);
    ASSERT_EQ(extra["clutter"].size(), p.clutter.size());
    EXPECT_EQ(extra["clutter"][p.clutter.size() - 1]["shape"], clutter_kind_name(p.clutter.back().kind));
    int nearer_background = 0;
    for (size_t i = 0; i < with.clean.depth.size(); ++i) {
      ASSERT_EQ(with.parts.pixels[i] != dp::tools::kNotBodyLabel, with.people.pixels[i] != 0) << "pixel " << i;
      nearer_background += with.parts.pixels[i] == dp::tools::kNotBodyLabel && with.clean.depth[i] > 0 &&
                           (without.clean.depth[i] == 0 || with.clean.depth[i] < without.clean.depth[i] - 0.05f);
    }
    EXPECT_GT(nearer_background, 300);
  }
  for (int kind = int(ClutterKind::kChair); kind <= int(ClutterKind::kDoor); ++kind)
    EXPECT_GT(kinds[kind], 0) << "no " << clutter_kind_name(ClutterKind(kind)) << " in 3 frames";
}

TEST(SynthTallClutter, CountOutOfRangeIsRefused) {
  SynthConfig c;
  c.tall_clutter = 17;
  try {
    Synthesizer synth("/nonexistent", c);
    FAIL() << "--tall-clutter 17 accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("--tall-clutter must be 0..16"), std::string::npos) << e.what();
  }
}
