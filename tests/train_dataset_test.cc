// Loading training data: pixel sampling, probe images, and clear errors (naming the file and the
// frame) for corrupt or inconsistent datasets; the `depthpose train` command end to end.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "tests/cli_test_support.h"
#include "runtime/fixed_point.h"
#include "tests/train_toy_data.h"
#include "tools/cli/command.h"
#include "tools/common/error.h"
#include "tools/train/forest_file.h"
#include "tools/train/forest_truncate.h"
#include "tools/train/training_set.h"

namespace dp::train {
using dp::testsupport::run_cli;

namespace {
using testing_toy::TempDir;
using testing_toy::write_toy_dataset;
namespace fs = std::filesystem;

std::string load_error(const std::string& dir, SamplingOptions so = {}) {
  so.threads = 2;
  try {
    load_training_set({dir}, so);
  } catch (const tools::ToolError& e) {
    return e.what();
  }
  return "";
}

TEST(TrainDataset, SamplesForegroundPixelsWithExactScale) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  SamplingOptions so;
  so.pixels_per_image = 100;
  so.trees = 3;
  so.images_per_tree = 4;
  so.seed = 5;
  so.reference_focal_px = 120;  // half the focal → focal_factor 500
  const TrainingSet set = load_training_set({tmp.path + "/toy"}, so);
  ASSERT_EQ(set.tree_pixels.size(), 3u);
  EXPECT_EQ(set.reference_focal_px, 120.0f);
  for (size_t t = 0; t < 3; ++t) {
    EXPECT_EQ(set.tree_pixels[t].size(), 400u);
    std::set<uint32_t> images;
    for (const TrainingPixel& p : set.tree_pixels[t]) {
      images.insert(p.image);
      const TrainingImage& im = set.images[p.image];
      EXPECT_EQ(im.focal_factor, 500);
      const uint16_t z = im.probe[size_t(p.v) * im.width + p.u];
      ASSERT_NE(z, kBackgroundDepthMm);
      EXPECT_EQ(p.depth_mm, z);
      EXPECT_EQ(p.scale_q13, scale_q13(500, z));
      EXPECT_EQ(p.label, z < 2000 ? 0 : 1);
    }
    EXPECT_EQ(images.size(), 4u);
  }
  EXPECT_NE(set.tree_pixels[0].front().u + 1000 * set.tree_pixels[0].front().v + set.tree_pixels[0].front().image,
            set.tree_pixels[1].front().u + 1000 * set.tree_pixels[1].front().v + set.tree_pixels[1].front().image + 0 * 1)
      << "trees should see different pixels or images";
  EXPECT_NE(set.datasets_json.find("fnv1a64"), std::string::npos);
}

TEST(TrainDataset, CroppedProbeImagesGiveTheFullFrameFeatures) {
  // The training image keeps only the foreground's bounding box; every feature at every foreground
  // pixel must equal the one computed on the full frame by the runtime rule.
  testing_toy::ToyFrame f = testing_toy::make_toy_frame({}, 3);
  const int w = f.depth.width, h = f.depth.height;
  const TrainingImage im = make_training_image(f.depth.pixels.data(), f.parts.pixels.data(), w, h,
                                               CameraIntrinsics{60, 60, 31.5, 23.5}, 45, {}, "toy");
  ASSERT_LT(im.width * im.height, w * h / 2);
  const std::vector<uint16_t> full = make_probe_image(f.depth.pixels.data(), f.parts.pixels.data(), w, h);
  Rng rng(3);
  size_t compared = 0;
  for (int k = 0; k < 200; ++k) {
    const int du1 = rng.range(-90, 90), dv1 = rng.range(-90, 90), du2 = rng.range(-90, 90), dv2 = rng.range(-90, 90);
    for (int v = 0; v < im.height; ++v)
      for (int u = 0; u < im.width; ++u) {
        const int32_t z = im.probe[size_t(v) * im.width + u];
        if (z == kBackgroundDepthMm) continue;
        const int U = u + im.origin_u, V = v + im.origin_v;
        ASSERT_EQ(full[size_t(V) * w + U], z);
        ASSERT_EQ(depth_feature(im.probe.data(), im.width, im.height, u, v, z, im.focal_factor, du1, dv1, du2, dv2),
                  depth_feature(full.data(), w, h, U, V, z, im.focal_factor, du1, dv1, du2, dv2));
        ++compared;
      }
  }
  EXPECT_GT(compared, 100000u);
}

TEST(TrainDataset, MissingPngNamesFileAndFrame) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  fs::remove(tmp.path + "/toy/depth/000003.png");
  const std::string e = load_error(tmp.path + "/toy");
  EXPECT_NE(e.find("000003"), std::string::npos) << e;
  EXPECT_NE(e.find("depth/000003.png"), std::string::npos) << e;
  EXPECT_NE(e.find("frame"), std::string::npos) << e;
}

TEST(TrainDataset, WrongSizeNamesFileAndFrame) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  tools::ImageU8 small;
  small.width = 10;
  small.height = 10;
  small.pixels.assign(100, 255);
  tools::write_png_u8(tmp.path + "/toy/parts/000002.png", small);
  const std::string e = load_error(tmp.path + "/toy");
  EXPECT_NE(e.find("parts/000002.png"), std::string::npos) << e;
  EXPECT_NE(e.find("frame 000002"), std::string::npos) << e;
  EXPECT_NE(e.find("10x10"), std::string::npos) << e;
}

TEST(TrainDataset, CorruptPngNamesFileAndFrame) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  std::ofstream(tmp.path + "/toy/depth/000001.png") << "not a png";
  const std::string e = load_error(tmp.path + "/toy");
  EXPECT_NE(e.find("depth/000001.png"), std::string::npos) << e;
  EXPECT_NE(e.find("frame 000001"), std::string::npos) << e;
}

TEST(TrainDataset, BadJsonLineNamesTheLine) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  std::ofstream(tmp.path + "/toy/frames.jsonl", std::ios::app) << "{\"id\": \"000009\", \"joints\": [oops\n";
  const std::string e = load_error(tmp.path + "/toy");
  EXPECT_NE(e.find("frames.jsonl line 7"), std::string::npos) << e;
}

// meta.json integers must be JSON integers in range: a float such as 3.8e26 once reached
// nlohmann's unchecked float-to-int cast (undefined behaviour), and 64.5 silently became 64.
TEST(TrainDataset, MetaSizeMustBeAnIntegerInRange) {
  const struct {
    const char* width;
    const char* expect;
  } cases[] = {{"3.8e26", "not a whole number"}, {"64.5", "not a whole number"},
               {"18446744073709551615", "out of range"}, {"-5", "out of range"}, {"0", "out of range"},
               {"\"64\"", "string"}};
  for (const auto& c : cases) {
    TempDir tmp;
    write_toy_dataset(tmp.path + "/toy");
    const std::string meta_path = tmp.path + "/toy/meta.json";
    std::ifstream in(meta_path);
    std::stringstream text;
    text << in.rdbuf();
    std::string meta = text.str();
    const size_t at = meta.find("\"width\"");
    ASSERT_NE(at, std::string::npos) << meta;
    const size_t value = meta.find(':', at) + 1, end = meta.find_first_of(",}", value);
    meta = meta.substr(0, value) + c.width + meta.substr(end);
    std::ofstream(meta_path) << meta;
    const std::string e = load_error(tmp.path + "/toy");
    EXPECT_NE(e.find("\"width\""), std::string::npos) << c.width << ": " << e;
    EXPECT_NE(e.find(c.expect), std::string::npos) << c.width << ": " << e;
  }
}

TEST(TrainDataset, LabelOutsidePartListIsRefused) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  testing_toy::ToyFrame f = testing_toy::make_toy_frame({}, 4);
  f.parts.pixels[size_t(20) * 64 + 30] = 7;
  tools::write_png_u8(tmp.path + "/toy/parts/000004.png", f.parts);
  const std::string e = load_error(tmp.path + "/toy");
  EXPECT_NE(e.find("frame 000004"), std::string::npos) << e;
  EXPECT_NE(e.find("label 7"), std::string::npos) << e;
}

TEST(TrainDataset, MissingLabelsOrJointsWhenNeeded) {
  TempDir tmp;
  testing_toy::ToyOptions o;
  o.parts = false;
  write_toy_dataset(tmp.path + "/toy", o);
  EXPECT_NE(load_error(tmp.path + "/toy").find("no parts/"), std::string::npos);
  SamplingOptions so;
  so.need_labels = false;
  so.need_joints = true;
  EXPECT_EQ(load_error(tmp.path + "/toy", so), "");
  // Strip the joints from one line.
  std::ifstream in(tmp.path + "/toy/frames.jsonl");
  std::stringstream all;
  all << in.rdbuf();
  std::string text = all.str();
  const size_t second = text.find('\n') + 1;
  text.replace(second, text.find('\n', second) - second, "{\"id\":\"000001\"}");
  std::ofstream(tmp.path + "/toy/frames.jsonl") << text;
  const std::string e = load_error(tmp.path + "/toy", so);
  // The dataset reader refuses the line itself (file and line named), before sampling.
  EXPECT_NE(e.find("frames.jsonl line 2: no \"joints\""), std::string::npos) << e;
}

TEST(TrainCommand, TrainsBpcAndOjrForestFiles) {
  TempDir tmp;
  testing_toy::ToyOptions o;
  o.stripes = true;
  write_toy_dataset(tmp.path + "/a", o);
  o.near_mm = 1800;
  write_toy_dataset(tmp.path + "/b", o);
  const std::string data = tmp.path + "/a," + tmp.path + "/b";
  ASSERT_EQ(0, run_cli({"train", "--data", data, "--method", "bpc", "--trees", "2", "--depth", "6", "--offsets", "50",
                        "--thresholds", "10", "--pixels-per-image", "300", "--threads", "2", "--quiet", "--out",
                        tmp.path + "/bpc.forest"}));
  const TrainedForest bpc = read_forest(tmp.path + "/bpc.forest");
  EXPECT_EQ(bpc.method, "bpc");
  EXPECT_EQ(bpc.trees.size(), 2u);
  EXPECT_EQ(bpc.depth, 6);
  EXPECT_EQ(bpc.reference_focal_px, 60.0f);
  EXPECT_TRUE(bpc.has_part_distributions);
  EXPECT_NE(bpc.datasets_json.find(tmp.path + "/b"), std::string::npos);
  // Default max offset: round(129·60/525) = 15.
  EXPECT_NE(bpc.training_json.find("\"max_offset_pxm\":15"), std::string::npos) << bpc.training_json;

  ASSERT_EQ(0, run_cli({"train", "--data", data, "--method", "ojr", "--trees", "1", "--depth", "5", "--offsets", "30",
                        "--thresholds", "10", "--pixels-per-image", "200", "--nres", "20", "--votes-per-leaf", "1",
                        "--vote-length", "0.4", "--quiet", "--out", tmp.path + "/ojr.forest"}));
  const TrainedForest ojr = read_forest(tmp.path + "/ojr.forest");
  EXPECT_TRUE(ojr.has_votes);
  EXPECT_EQ(ojr.votes_per_joint, 1);
  EXPECT_EQ(ojr.trees[0].votes.size(), ojr.trees[0].leaf_count() * 2);
  EXPECT_NE(ojr.training_json.find("\"vote_length_m\":[0.4"), std::string::npos) << ojr.training_json;
  EXPECT_THROW(run_cli({"train", "--data", data, "--method", "ojr", "--vote-length", "0.1,0.2,0.3", "--quiet", "--out",
                        tmp.path + "/x.forest"}),
               tools::ToolError);

  // Retro-fit onto the BPC structure, and a mixture proposal from it.
  ASSERT_EQ(0, run_cli({"train", "--data", data, "--method", "ojr", "--structure", tmp.path + "/bpc.forest",
                        "--pixels-per-image", "300", "--quiet", "--out", tmp.path + "/refit.forest"}));
  const TrainedForest refit = read_forest(tmp.path + "/refit.forest");
  ASSERT_EQ(refit.trees.size(), 2u);
  EXPECT_EQ(refit.trees[1].nodes.size(), bpc.trees[1].nodes.size());
  // Retro-fit onto the structure pruned where it holds few pixels: the pruned structure's shape.
  const uint64_t min_pixels = 200;
  ASSERT_EQ(0, run_cli({"train", "--data", data, "--method", "ojr", "--structure", tmp.path + "/bpc.forest",
                        "--structure-min-pixels", std::to_string(min_pixels), "--pixels-per-image", "300", "--quiet",
                        "--out", tmp.path + "/pruned.forest"}));
  const TrainedForest pruned = read_forest(tmp.path + "/pruned.forest");
  const TrainedForest pruned_structure = prune_structure(bpc, min_pixels);
  ASSERT_EQ(pruned.trees.size(), 2u);
  for (size_t t = 0; t < 2; ++t) {
    EXPECT_LT(pruned.trees[t].leaf_count(), bpc.trees[t].leaf_count()) << "tree " << t;
    ASSERT_EQ(pruned.trees[t].nodes.size(), pruned_structure.trees[t].nodes.size());
    for (size_t i = 0; i < pruned.trees[t].nodes.size(); ++i)
      EXPECT_EQ(pruned.trees[t].nodes[i].heap_index, pruned_structure.trees[t].nodes[i].heap_index);
  }
  EXPECT_TRUE(pruned.has_votes);
  for (const char* bad : {"0", "-4", "many"})
    EXPECT_THROW(run_cli({"train", "--data", data, "--method", "ojr", "--structure", tmp.path + "/bpc.forest",
                          "--structure-min-pixels", bad, "--quiet", "--out", tmp.path + "/x.forest"}),
                 tools::ToolError)
        << bad;
  EXPECT_THROW(run_cli({"train", "--data", data, "--method", "ojr", "--structure-min-pixels", "10", "--quiet", "--out",
                        tmp.path + "/x.forest"}),
               tools::ToolError);
  ASSERT_EQ(0, run_cli({"train", "--data", data, "--method", "bpc", "--trees", "1", "--depth", "4", "--offsets", "20",
                        "--proposal", tmp.path + "/bpc.forest", "--quiet", "--out", tmp.path + "/mix.forest"}));
  EXPECT_NE(read_forest(tmp.path + "/mix.forest").training_json.find("mixture"), std::string::npos);

  EXPECT_THROW(run_cli({"train", "--data", data, "--method", "xyz", "--out", tmp.path + "/x.forest"}), tools::ToolError);
  EXPECT_THROW(run_cli({"train", "--data", tmp.path + "/none", "--method", "bpc", "--out", tmp.path + "/x.forest"}),
               tools::ToolError);
}

}  // namespace
}  // namespace dp::train
