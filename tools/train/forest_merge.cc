// Merging trained forests (forest_merge.h).
#include "tools/train/forest_merge.h"

#include <nlohmann/json.hpp>

#include "tools/common/error.h"

namespace dp::train {
namespace {

using nlohmann::json;
using tools::fail;

json merge_config_object(const std::string& text, const std::string& what, const char* field) {
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) fail(what + ": its " + field + " is not a JSON object");
  return j;
}

// The options that must agree: the configuration without what differs between runs of one recipe.
json options_that_must_agree(json cfg) {
  for (const char* key : {"seed", "tree_keys", "trees", "training_pixels"}) cfg.erase(key);
  return cfg;
}

std::string first_option_difference(const json& a, const json& b) {
  for (const auto& [key, value] : a.items()) {
    if (!b.contains(key)) return "'" + key + "' is " + value.dump() + " in one and absent in the other";
    if (b[key] != value) return "'" + key + "': " + value.dump() + " against " + b[key].dump();
  }
  for (const auto& [key, value] : b.items())
    if (!a.contains(key)) return "'" + key + "' is absent in one and " + value.dump() + " in the other";
  return "(no difference)";
}

}  // namespace

std::vector<TreeKey> tree_keys(const TrainedForest& forest, const std::string& what) {
  const json cfg = merge_config_object(forest.training_json, what, "training configuration");
  std::vector<TreeKey> keys;
  if (cfg.contains("tree_keys")) {
    const json& list = cfg["tree_keys"];
    if (!list.is_array()) fail(what + ": its training configuration's tree_keys is not an array");
    for (const json& k : list) {
      if (!k.is_object() || !k.contains("seed") || !k.contains("tree") || !k["seed"].is_number_unsigned() ||
          !k["tree"].is_number_unsigned())
        fail(what + ": a tree key is not {\"seed\": S, \"tree\": T}: " + k.dump());
      keys.push_back({k["seed"].get<uint64_t>(), k["tree"].get<uint64_t>()});
    }
  } else if (cfg.contains("seed") && cfg["seed"].is_number_unsigned()) {
    const uint64_t seed = cfg["seed"].get<uint64_t>();
    for (size_t t = 0; t < forest.trees.size(); ++t) keys.push_back({seed, t});
  } else {
    fail(what + ": its training configuration names no seed (not a forest of depthpose train)");
  }
  if (keys.size() != forest.trees.size())
    fail(what + ": its training configuration keys " + std::to_string(keys.size()) + " trees, the file holds " +
         std::to_string(forest.trees.size()));
  return keys;
}

TrainedForest merge_forests(const std::vector<TrainedForest>& inputs, const std::vector<std::string>& names) {
  if (inputs.size() < 2) fail("merging needs at least two forests, got " + std::to_string(inputs.size()));
  if (names.size() != inputs.size()) fail("merging: one name per forest expected");
  const TrainedForest& first = inputs[0];
  const json first_cfg = merge_config_object(first.training_json, names[0], "training configuration");
  const json first_options = options_that_must_agree(first_cfg);

  TrainedForest merged;
  merged.method = first.method;
  merged.reference_focal_px = first.reference_focal_px;
  merged.depth = first.depth;
  merged.part_names = first.part_names;
  merged.joint_names = first.joint_names;
  merged.votes_per_joint = first.votes_per_joint;
  merged.has_part_distributions = first.has_part_distributions;
  merged.has_votes = first.has_votes;
  merged.datasets_json = first.datasets_json;

  std::vector<TreeKey> keys;
  std::vector<std::string> key_owner;
  uint64_t training_pixels = 0;
  json timings = json::object();
  for (size_t i = 0; i < inputs.size(); ++i) {
    const TrainedForest& f = inputs[i];
    const std::string pair = names[0] + " and " + names[i];
    auto differs = [&](const std::string& what) { fail("cannot merge " + pair + ": they differ in " + what); };
    if (f.method != first.method) differs("method (" + first.method + " against " + f.method + ")");
    if (f.reference_focal_px != first.reference_focal_px)
      differs("reference focal length (" + std::to_string(first.reference_focal_px) + " against " +
              std::to_string(f.reference_focal_px) + " px)");
    if (f.depth != first.depth)
      differs("requested depth (" + std::to_string(first.depth) + " against " + std::to_string(f.depth) + ")");
    if (f.part_names != first.part_names) differs("part names");
    if (f.joint_names != first.joint_names) differs("joint names");
    if (f.has_part_distributions != first.has_part_distributions || f.has_votes != first.has_votes ||
        f.votes_per_joint != first.votes_per_joint)
      differs("leaf data (part distributions, votes per joint)");
    if (f.datasets_json != first.datasets_json) differs("training data (the datasets' identity)");
    const std::vector<TreeKey> keys_of_input = tree_keys(f, names[i]);
    const json cfg = merge_config_object(f.training_json, names[i], "training configuration");
    const json options = options_that_must_agree(cfg);
    if (options != first_options) differs("training options: " + first_option_difference(first_options, options));
    for (const TreeKey& k : keys_of_input) {
      for (size_t j = 0; j < keys.size(); ++j)
        if (keys[j] == k)
          fail("cannot merge " + key_owner[j] + " and " + names[i] + ": both hold the tree of seed " +
               std::to_string(k.seed) + ", index " + std::to_string(k.tree) +
               " (the same tree twice: train the other run with another --seed)");
      keys.push_back(k);
      key_owner.push_back(names[i]);
    }
    if (cfg.contains("training_pixels") && cfg["training_pixels"].is_number_unsigned())
      training_pixels += cfg["training_pixels"].get<uint64_t>();
    const json t = json::parse(f.timings_json, nullptr, false);
    if (t.is_object())
      for (const auto& [key, value] : t.items()) {
        if (!value.is_number()) continue;
        const double v = value.get<double>();
        const double old = timings.contains(key) ? timings[key].get<double>() : 0.0;
        timings[key] = key == "bytes_per_training_pixel" ? std::max(old, v) : old + v;
      }
    for (const TrainedTree& tree : f.trees) merged.trees.push_back(tree);
  }

  json cfg = first_cfg;
  cfg.erase("seed");
  cfg["trees"] = merged.trees.size();
  cfg["training_pixels"] = training_pixels;
  json key_list = json::array();
  for (const TreeKey& k : keys) key_list.push_back({{"seed", k.seed}, {"tree", k.tree}});
  cfg["tree_keys"] = key_list;
  merged.training_json = cfg.dump();
  merged.timings_json = timings.empty() ? std::string("{}") : timings.dump();
  link_and_validate(merged, "merged forest");
  return merged;
}

}  // namespace dp::train
