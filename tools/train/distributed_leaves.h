// Leaf models when the tree's pixels are spread over the ranks of a Communicator (distributed
// training): the same models as fit_part_distributions / fit_votes (leaf_models.h) on the union
// of the ranks' pixels, bit for bit. Every rank calls these (collective); `ranges` are this rank's
// leaf ranges into its `pixels`, and the tree structure is the same on every rank.
#pragma once
#include <vector>

#include "tools/train/communicator.h"
#include "tools/train/leaf_models.h"

namespace dp::train {

// Sums tree.leaf_pixel_counts (this rank's counts on entry) over the ranks.
void sum_leaf_pixel_counts(TrainedTree& tree, Communicator& comm);

// Part distributions from the label counts summed over the ranks (integers: exact). Needs the
// summed tree.leaf_pixel_counts. Every rank receives the distributions.
void fit_part_distributions_distributed(const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges,
                                        int part_count, TrainedTree& tree, Communicator& comm);

// OJR votes: the reservoir of (leaf, joint) sees the leaf's pixels in global order (ranks in
// order) with the same keyed random stream as fit_votes. Each rank advances the stream past the
// earlier ranks' pixels of the leaf (one draw per pixel beyond the capacity, no data), offers its
// own pixels and sends the slots it wrote last; rank 0 lays the ranks' writes over each other in
// rank order, which is the reservoir a single process would hold, and runs mean shift. Only rank 0
// receives tree.votes (the others get zero votes of the right size: they do not write the forest).
// Traffic: at most leaves × joints × N_res × 16 bytes per rank, independent of the data size.
// first_leaf and leaves_done as in fit_votes, on rank 0 (the others ignore them; every rank passes
// the same first_leaf).
void fit_votes_distributed(const TrainingSet& set, const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges,
                           const LeafParams& params, int tree_index, TrainedTree& tree, Communicator& comm,
                           size_t first_leaf = 0, const LeavesDoneFn& leaves_done = {});

}  // namespace dp::train
