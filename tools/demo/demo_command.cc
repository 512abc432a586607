// `depthpose demo`: the self-contained smoke run behind `make run` when no shipped model exists:
// builds a handcrafted blob, runs the runtime on a generated frame and prints the proposals.
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "platform/arena_memory.h"
#include "runtime/depthpose.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"
#include "tools/demo/fixtures.h"

namespace dp::tools {

static int run_demo(int argc, char** argv) {
  Args args(argc, argv,
            "usage: depthpose demo [--write-blobs DIR]\n  Runs a handcrafted BPC blob on a generated 320x240 frame of a disc\n"
            "  and prints one proposal per joint (expected: the disc centre, pushed back).\n"
            "  --write-blobs DIR  instead writes small valid BPC and OJR fixture blobs (fuzzing seeds)",
            {"--write-blobs"});
  if (args.help_requested()) {
    std::printf("%s\n", args.usage().c_str());
    return 0;
  }
  if (args.has("--write-blobs")) {
    const std::string dir = args.get("--write-blobs");
    blob::save_blob_file(dir + "/seed_bpc.blob", blob::write_blob(single_part_bpc(5, 3, 2, 40, 3, 2)));
    blob::save_blob_file(dir + "/seed_ojr.blob", blob::write_blob(single_vote_ojr(3, 10, -20, 30)));
    blob::save_blob_file(dir + "/seed_random.blob", blob::write_blob(random_bpc_forest(3, 2, 4, 6, 300, 200)));
    return 0;
  }
  const std::vector<uint8_t> bytes = blob::write_blob(single_part_bpc(4, 2, 2, 40));
  blob::LoadedBlob b;
  if (blob::load_blob(bytes.data(), bytes.size(), &b) != blob::BlobStatus::kOk) fail("demo blob did not load");
  const size_t need = required_arena_bytes(b, 320, 240);
  const platform::ArenaMemory arena(need);
  Pipeline p;
  if (Status s = p.init(b, 320, 240, arena.data(), need); s != Status::kOk) fail(status_message(s));
  SyntheticFrame f = make_disc_frame(320, 240, 200.0f, 100.0f, 10.0f, 2000);
  FrameResult r;
  if (Status s = p.process(f.view(), &r); s != Status::kOk) fail(status_message(s));
  std::printf("demo: %d foreground pixels, arena %zu bytes, kernel %s (forest %s)\n", r.foreground_pixels,
              p.arena_used_bytes(), kernel_isa_name(p.kernel()), kernel_isa_name(p.forest_kernel()));
  for (int j = 0; j < r.joint_count; ++j)
    for (int k = 0; k < r.proposal_count[j]; ++k)
      std::printf("  %s proposal %d: x %.3f y %.3f z %.3f m, confidence %.2f\n", b.meta->joint_names[j], k,
                  r.proposals[j][k].x_m, r.proposals[j][k].y_m, r.proposals[j][k].z_m, r.proposals[j][k].confidence);
  for (int s = 0; s < kStageCount; ++s)
    std::printf("  stage %-10s %10llu cycles\n", stage_name(s), (unsigned long long)r.stage_cycles[s]);
  return 0;
}

DP_REGISTER_COMMAND(demo, "demo", "run a handcrafted blob on a generated frame (smoke run)", run_demo);

}  // namespace dp::tools
