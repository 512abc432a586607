// The data-parallel trainer without MPI: N "ranks" are threads of this process joined by an
// in-process Communicator, each holding one image shard of a stick-body set as load_training_set
// gives it (SamplingOptions::shard). Rank 0's forest must serialize to the bytes of the
// one-process forest, for BPC and for OJR with both objectives, with histogram sums at every level,
// node-parallel deep levels and node-parallel levels throughout (TreeParams::node_parallel_pixels),
// and the data digest must not depend on the shards. (mk/mpi_tests.sh runs the same comparisons through mpirun.)
#include <gtest/gtest.h>

#include <condition_variable>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "tests/train_stick_bodies.h"
#include "tools/train/checkpoint.h"
#include "tools/train/forest_trainer.h"

namespace dp::train {
namespace {

// Shared state of the thread ranks: a reusable barrier and the buffers the collectives fill.
struct ThreadGroup {
  explicit ThreadGroup(int n) : size(n), gathered(n), outbox(n) {}
  void barrier() {
    std::unique_lock<std::mutex> lock(mutex);
    const uint64_t generation = generation_;
    if (++arrived == size) {
      arrived = 0;
      ++generation_;
      cv.notify_all();
    } else {
      cv.wait(lock, [&] { return generation_ != generation; });
    }
  }
  const int size;
  std::mutex mutex;
  std::condition_variable cv;
  int arrived = 0;
  uint64_t generation_ = 0;
  std::vector<int64_t> sums;
  std::vector<std::vector<uint8_t>> gathered;
  std::vector<std::vector<std::vector<uint8_t>>> outbox;  // [sender][receiver] of exchange()
};

class ThreadCommunicator final : public Communicator {
 public:
  ThreadCommunicator(ThreadGroup& group, int rank) : group_(group), rank_(rank) {}
  int rank() const override { return rank_; }
  int size() const override { return group_.size; }
  void sum(uint32_t* data, size_t count) override { add(data, count); }
  void sum(int64_t* data, size_t count) override { add(data, count); }
  std::vector<std::vector<uint8_t>> gather(const std::vector<uint8_t>& mine) override {
    group_.gathered[rank_] = mine;
    group_.barrier();
    std::vector<std::vector<uint8_t>> out;
    if (rank_ == 0) out = group_.gathered;
    group_.barrier();
    return out;
  }
  void broadcast(std::vector<uint8_t>& data) override {
    if (rank_ == 0) group_.gathered[0] = data;
    group_.barrier();
    if (rank_ != 0) data = group_.gathered[0];
    group_.barrier();
  }
  std::vector<std::vector<uint8_t>> exchange(const std::vector<std::vector<uint8_t>>& parts) override {
    if (parts.size() != size_t(group_.size)) throw std::runtime_error("exchange: one part per rank expected");
    for (int r = 0; r < group_.size; ++r)
      if (r != rank_) bytes_exchanged_ += parts[r].size();
    group_.outbox[rank_] = parts;
    group_.barrier();
    std::vector<std::vector<uint8_t>> out(group_.size);
    for (int r = 0; r < group_.size; ++r) out[r] = group_.outbox[r][rank_];
    group_.barrier();
    return out;
  }
  void barrier() override { group_.barrier(); }
  [[noreturn]] void abort(const std::string& message) override {
    throw std::runtime_error("rank " + std::to_string(rank_) + ": " + message);
  }

 private:
  // Wrapping integer sums, as MPI_SUM on the unsigned/int64 types.
  template <class T>
  void add(T* data, size_t count) {
    bytes_reduced_ += count * sizeof(T);
    group_.barrier();
    if (rank_ == 0) group_.sums.assign(count, 0);
    group_.barrier();
    {
      std::lock_guard<std::mutex> lock(group_.mutex);
      for (size_t i = 0; i < count; ++i)
        group_.sums[i] = static_cast<int64_t>(static_cast<uint64_t>(group_.sums[i]) + static_cast<uint64_t>(data[i]));
    }
    group_.barrier();
    for (size_t i = 0; i < count; ++i) data[i] = static_cast<T>(group_.sums[i]);
    group_.barrier();
  }
  ThreadGroup& group_;
  int rank_;
};

// What load_training_set gives rank `rank` of `ranks`: only its images' crops and pixels.
TrainingSet shard_of(const TrainingSet& all, int rank, int ranks) {
  TrainingSet s = all;
  const auto [first, last] = rank_share(all.images.size(), rank, ranks);
  for (size_t i = 0; i < s.images.size(); ++i)
    if (i < first || i >= last) s.images[i] = TrainingImage{};
  for (auto& pixels : s.tree_pixels) {
    std::vector<TrainingPixel> kept;
    for (const TrainingPixel& p : pixels)
      if (p.image >= first && p.image < last) kept.push_back(p);
    pixels.swap(kept);
  }
  return s;
}

std::vector<uint8_t> forest_bytes(TrainedForest forest) {
  forest.timings_json = "{}";
  return serialize_forest(forest);
}

ForestOptions small_options(const std::string& method, Objective objective, int threads) {
  ForestOptions fo;
  fo.method = method;
  fo.tree.max_depth = 6;
  fo.tree.offset_candidates = 24;
  fo.tree.threshold_candidates = 12;
  fo.tree.max_offset_pxm = 65;
  fo.tree.min_samples = 8;
  fo.tree.objective = objective;
  fo.tree.rho_m = 0.5f;
  fo.tree.seed = 9;
  fo.tree.threads = threads;
  fo.leaf.reservoir = 6;  // fewer than most leaves' pixels: the reservoirs of several ranks merge
  fo.leaf.seed = 9;
  return fo;
}

// Trains on `ranks` thread ranks (2 threads each) and returns rank 0's forest bytes; `levels`
// receives rank 0's level reports.
std::vector<uint8_t> distributed_forest(const TrainingSet& all, const ForestOptions& options, int ranks,
                                        std::vector<LevelReport>* levels = nullptr) {
  ThreadGroup group(ranks);
  std::vector<std::vector<uint8_t>> bytes(ranks);
  std::vector<std::string> errors(ranks);
  std::vector<std::thread> pool;
  for (int r = 0; r < ranks; ++r)
    pool.emplace_back([&, r] {
      try {
        ThreadCommunicator comm(group, r);
        const TrainingSet shard = shard_of(all, r, ranks);
        ForestOptions o = options;
        o.tree.comm = &comm;
        o.tree.threads = 2;
        ProgressFn progress;
        if (r == 0 && levels)
          progress = [&](const LevelReport& report) {
            if (!report.partial) levels->push_back(report);
          };
        bytes[r] = forest_bytes(train_forest(shard, o, progress));
      } catch (const std::exception& e) {
        errors[r] = e.what();
      }
    });
  for (auto& t : pool) t.join();
  for (int r = 0; r < ranks; ++r) EXPECT_EQ(errors[r], "") << "rank " << r;
  return bytes[0];
}

TEST(TrainDistributed, ThreadRanksGrowTheOneProcessForest) {
  const TrainingSet set = testing_bodies::stick_body_set(8, 120, 2, 4);
  struct Case {
    const char* name;
    std::string method;
    Objective objective;
  } cases[] = {{"bpc", "bpc", Objective::kClassification},
               {"ojr classification", "ojr", Objective::kClassification},
               {"ojr regression", "ojr", Objective::kRegression}};
  // 960 pixels per tree: histogram sums at every level (0), at the root and level 1 then
  // node-parallel (300), node-parallel from the root (the default, above the root's pixels).
  for (const Case& c : cases) {
    const std::vector<uint8_t> one = forest_bytes(train_forest(set, small_options(c.method, c.objective, 1), {}));
    const std::pair<uint32_t, int> runs[] = {{0, 2}, {300, 2}, {300, 3}, {kDefaultNodeParallelPixels, 3}};
    for (const auto& [below, ranks] : runs) {
      ForestOptions o = small_options(c.method, c.objective, 1);
      o.tree.node_parallel_pixels = below;
      std::vector<LevelReport> levels;
      const std::vector<uint8_t> many = distributed_forest(set, o, ranks, &levels);
      EXPECT_TRUE(one == many) << c.name << ", --node-parallel-below " << below << ": " << ranks
                               << " ranks wrote another forest (" << many.size() << " bytes against " << one.size()
                               << ")";
      // The regimes the switch asks for were taken: count the levels of each.
      ASSERT_FALSE(levels.empty());
      const bool root_summed = levels[0].active_pixels >= below;
      int summed = 0, node_parallel = 0;
      uint64_t exchanged = 0;  // rank 0's features sent to the other ranks' nodes
      for (const LevelReport& l : levels) {
        if (l.split_nodes == 0) continue;
        summed += l.node_parallel_nodes == 0;
        node_parallel += l.node_parallel_nodes > 0;
        exchanged += l.bytes_exchanged;
      }
      EXPECT_EQ(summed > 0, root_summed) << c.name << ", below " << below;
      EXPECT_EQ(node_parallel > 0, below > 0) << c.name << ", below " << below;
      EXPECT_EQ(exchanged > 0, below > 0) << c.name << ", below " << below;
    }
  }
}

TEST(TrainDistributed, DataDigestDoesNotDependOnTheShards) {
  const TrainingSet set = testing_bodies::stick_body_set(7, 100, 2, 6);
  const std::string one = training_data_digest(set);
  for (int ranks : {2, 3}) {
    ThreadGroup group(ranks);
    std::vector<std::string> digests(ranks);
    std::vector<std::thread> pool;
    for (int r = 0; r < ranks; ++r)
      pool.emplace_back([&, r] {
        ThreadCommunicator comm(group, r);
        digests[r] = training_data_digest(shard_of(set, r, ranks), &comm);
      });
    for (auto& t : pool) t.join();
    for (int r = 0; r < ranks; ++r) EXPECT_EQ(digests[r], one) << ranks << " ranks, rank " << r;
  }
  TrainingSet other = set;
  other.tree_pixels[1][3].u ^= 1;
  EXPECT_NE(training_data_digest(other), one) << "the digest must see every pixel record";
}

TEST(TrainDistributed, RankSharesAreContiguousAndBalanced) {
  for (size_t count : {0, 1, 5, 7, 300001})
    for (int ranks : {1, 2, 3, 16}) {
      size_t next = 0;
      for (int r = 0; r < ranks; ++r) {
        const auto [first, last] = rank_share(count, r, ranks);
        EXPECT_EQ(first, next) << count << " items, rank " << r << " of " << ranks;
        EXPECT_LE(last - first, count / ranks + 1);
        EXPECT_GE(last - first, count / ranks);
        next = last;
      }
      EXPECT_EQ(next, count);
    }
}

}  // namespace
}  // namespace dp::train
