// Training checkpoints (`depthpose train --checkpoint FILE --resume`): what a forest's growth has
// decided so far, so that a killed run continues to the byte-identical forest.
//
// A checkpoint holds, per tree begun, its GrowthState (tree_trainer.h): the split or leaf decision
// of every node at the levels finished. Nothing else is needed: the training pixels are a function
// of the data, options and seed, the pixel order of a level is recomputed by replaying the
// recorded splits (one feature per pixel and level, cheap next to the split search), and leaf
// models are fitted after the structure. It also records the options that determine the forest
// and a digest of the training data; resuming with other options or data is refused.
//
// A retro-fit (OJR votes onto a given structure) checkpoints its votes instead: per tree begun, the
// votes of the leaves fitted so far (leaf_models.h fits them in blocks of leaves, each leaf from
// its own pixels only, so a resumed fit continues at the next leaf and gives the same votes).
//
// File layout (little-endian):
//   "DPTRCKPT"            8 bytes magic
//   uint32 version        2 (version 1, written before retro-fit checkpoints, is read too)
//   uint32 header_bytes   length of the JSON header that follows
//   JSON header           {"options":{...},"data_digest":"<16 hex>","trees":[{"levels_done":L,
//                          "complete":bool,"feature_evaluations":N,"nodes":count},...],
//                          "retrofit":[{"leaves_done":n,"complete":bool,"votes":count},...]}
//                          ("retrofit" absent in version 1)
//   per tree, its nodes   count × 7 int32: heap, leaf (0/1), du1, dv1, du2, dv2, threshold
//   per retrofit tree     count × 4 float32: dx, dy, dz (metres), weight
//   uint32 crc32          zlib CRC-32 of every byte before it
// Written to FILE.tmp, flushed and fsync'ed, then renamed over FILE, so FILE is always either the
// previous complete checkpoint or the new one.
#pragma once
#include <string>
#include <vector>

#include "tools/train/communicator.h"
#include "tools/train/training_set.h"
#include "tools/train/tree_trainer.h"

namespace dp::train {

// A retro-fit's progress on one tree.
struct RetrofitState {
  size_t leaves_done = 0;             // leaves [0, leaves_done) have their final votes
  bool complete = false;              // every leaf of the tree
  std::vector<LeafVote> votes;        // leaves_done × joints × K
};

struct TrainingCheckpoint {
  std::string options_json = "{}";    // the forest-determining options (JSON object text)
  std::string data_digest;            // training_data_digest() of the set
  std::vector<GrowthState> trees;     // trees begun, in order; all but the last are complete
  std::vector<RetrofitState> retrofit;  // retro-fits: trees begun, in order; all but the last complete
};

// 64-bit digest (16 hex digits) of everything in the set that the forest depends on: image crops,
// cameras, joints, part/joint names and every tree's sampled pixels. Dataset paths are not part of
// it (a moved dataset still matches). With `comm`, every rank passes its share of the images (a
// collective call) and all receive the digest of the whole set, the same for any rank count and
// equal to the one-process digest.
std::string training_data_digest(const TrainingSet& set, Communicator* comm = nullptr);

// Atomic write (temp file + fsync + rename). Throws ToolError naming the file on I/O errors.
void write_checkpoint(const std::string& path, const TrainingCheckpoint& checkpoint);
// Throws ToolError naming the file and the problem (missing, truncated, bad magic/version/CRC).
TrainingCheckpoint read_checkpoint(const std::string& path);

// Throws ToolError when `checkpoint` was written with other options or data than the current
// run's, naming each differing option with both values.
void check_checkpoint_matches(const TrainingCheckpoint& checkpoint, const std::string& options_json,
                              const std::string& data_digest, const std::string& path);

}  // namespace dp::train
