// `make bench`: forest-kernel and end-to-end speed of the runtime, SIMD beside the scalar
// reference in the same run, on the real Skeltrack frames with PCL's trees and on synthetic
// frames. Prints a table and writes build/bench/runtime.json (docs/runtime_speed.md).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "platform/arena_memory.h"
#include "runtime/cycle_counter.h"
#include "runtime/depthpose.h"
#include "runtime/fixed_point.h"
#include "runtime/kernels/forest_kernel.h"
#include "tests/node_layouts.h"
#include <cpuid.h>
#include "tools/common/body_model.h"
#include "tools/convert/pcl_import.h"
#include "tools/demo/fixtures.h"
#include "tools/synth/synth.h"

using namespace dp;

namespace {

// The CPU's brand string (CPUID 0x80000002..4): figures depend on the core, and the VMs these
// benchmarks run on have changed kind between sessions (AMD Zen 4, Intel Emerald Rapids).
std::string cpu_brand() {
  unsigned r[12] = {};
  for (unsigned i = 0; i < 3; ++i)
    if (!__get_cpuid(0x80000002u + i, &r[4 * i], &r[4 * i + 1], &r[4 * i + 2], &r[4 * i + 3])) return "unknown";
  std::string b(reinterpret_cast<const char*>(r), sizeof r);
  b = b.substr(0, b.find('\0'));
  while (!b.empty() && b.back() == ' ') b.pop_back();
  while (!b.empty() && b.front() == ' ') b.erase(b.begin());
  for (char& c : b)
    if (c == '"' || c == '\\') c = ' ';
  // VMs often hide the model in the brand string: add CPUID's family and model.
  unsigned a, bx, c, d;
  if (__get_cpuid(1, &a, &bx, &c, &d)) {
    const unsigned family = ((a >> 8) & 15) + (((a >> 8) & 15) == 15 ? (a >> 20) & 255 : 0);
    const unsigned model = ((a >> 4) & 15) | (((a >> 8) & 15) >= 6 ? ((a >> 16) & 15) << 4 : 0);
    b += " (family " + std::to_string(family) + ", model " + std::to_string(model) + ")";
  }
  return b;
}

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Frame {
  int width, height;
  std::vector<uint16_t> depth;
  CameraIntrinsics intrinsics;
  DepthFrame view() const { return DepthFrame{depth.data(), width, height, width, intrinsics, nullptr}; }
};

std::vector<Frame> skeltrack_frames(bool half) {
  const char* const names[] = {"1028894671", "1038901490", "1045879925", "1051883281", "1058893191", "1064898470",
                               "1070905432", "1078881076", "1166565565", "1234568668", "1399145206", "82823944"};
  std::vector<Frame> out;
  for (const char* name : names) {
    const std::string path = std::string("../shared/data/skeltrack-frames/depth-data-") + name + ".raw";
    std::ifstream in(path, std::ios::binary);
    std::vector<uint16_t> d(640 * 480);
    in.read(reinterpret_cast<char*>(d.data()), std::streamsize(d.size() * 2));
    if (!in) {
      std::fprintf(stderr, "bench: cannot read %s (run from the repo root; ../shared/data is required)\n", path.c_str());
      std::exit(1);
    }
    if (!half) {
      out.push_back(Frame{640, 480, d, tools::kinect_intrinsics(640, 480)});
    } else {
      std::vector<uint16_t> h(320 * 240);
      for (int v = 0; v < 240; ++v)
        for (int u = 0; u < 320; ++u) h[size_t(v) * 320 + u] = d[size_t(2 * v) * 640 + 2 * u];
      out.push_back(Frame{320, 240, h, tools::kinect_intrinsics(320, 240)});
    }
  }
  return out;
}

std::vector<Frame> synthetic_frames(bool half) {
  std::vector<Frame> out;
  const int w = half ? 320 : 640, h = half ? 240 : 480;
  for (int i = 0; i < 4; ++i) {
    tools::SyntheticFrame f = tools::make_disc_frame(w, h, w * (0.35f + 0.1f * i), h * 0.5f, h * 0.3f, uint16_t(1100 + 100 * i));
    // A tilted surface inside the disc, so features are not all zero.
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        uint16_t& z = f.depth_mm[size_t(v) * w + u];
        if (z) z = uint16_t(z + (u * 3 + v * 2) % 97);
      }
    out.push_back(Frame{w, h, f.depth_mm, f.intrinsics});
  }
  return out;
}

// Rendered people, as the shipped models see them: the MakeHuman body posed by the test split's CMU
// clips (docs/results.md: seed 303, clips 01_13, 01_14, 02_02, 02_06, 03_04), sensor noise on, the
// body alone in view (the depth band is the foreground, as with a ground-truth mask).
std::vector<Frame> rendered_frames(int w, int h, int count) {
  synth::SynthConfig cfg;
  cfg.width = w;
  cfg.height = h;
  cfg.clips = {"01_13", "01_14", "02_02", "02_06", "03_04"};
  const synth::Synthesizer s("../shared/assets", cfg);
  std::vector<Frame> out;
  for (int i = 0; i < count; ++i) {
    synth::SynthFrame f = s.render(s.sample_frame_params(303, uint64_t(i)));
    const synth::Intrinsics& k = s.intrinsics();
    out.push_back(Frame{w, h, std::move(f.depth.pixels),
                        CameraIntrinsics{float(k.fx), float(k.fy), float(k.cx), float(k.cy)}});
  }
  return out;
}

// Forest-kernel inputs prepared the pipeline's way: padded probe image and all foreground pixels.
struct KernelInput {
  std::vector<uint16_t> probe;
  std::vector<EvaluatedPixel> pixels;
  int width, height;
  int32_t focal;
};

KernelInput kernel_input(const Frame& f, float reference_focal) {
  KernelInput k;
  k.width = f.width;
  k.height = f.height;
  k.focal = focal_factor_mm(f.intrinsics.fx, reference_focal);
  k.probe.assign(kernels::padded_probe_elements(f.width, f.height), kernels::probe_element(kBackgroundDepthMm));
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      const uint16_t z = f.depth[size_t(v) * f.width + u];
      if (!z) continue;
      k.probe[size_t(v + 1) * (f.width + 2) + u + 1] = kernels::probe_element(z);
      k.pixels.push_back(EvaluatedPixel{uint16_t(u), uint16_t(v), z, 0});
    }
  return k;
}

struct Variant {
  const char* name;
  KernelIsa isa;
  kernels::NodeLayout layout;  // kBlob10 or kSplit through forest_trees_kernel, unless `study`
  bool study;                  // through the ISA's evaluate_trees_study
};
using kernels::NodeLayout;
const Variant kVariants[] = {{"scalar ref", KernelIsa::kScalar, NodeLayout::kBlob10, false},
                             {"avx2 10B nodes", KernelIsa::kAvx2, NodeLayout::kBlob10, false},
                             {"avx2 split", KernelIsa::kAvx2, NodeLayout::kSplit, false},
                             {"avx512 10B nodes", KernelIsa::kAvx512, NodeLayout::kBlob10, false},
                             {"avx512 split", KernelIsa::kAvx512, NodeLayout::kSplit, false}};
constexpr int kVariantCount = sizeof kVariants / sizeof kVariants[0];
// The node layout study, each layout through the same kernel code (runtime/kernels/forest_kernel.h,
// NodeLayout): the blob's 10-byte nodes, packed 8-byte nodes, 16-byte nodes, split (structure of
// arrays: offsets and thresholds apart; what the pipeline evaluates).
const Variant kLayoutStudy[] = {{"avx2 10B", KernelIsa::kAvx2, NodeLayout::kBlob10, true},
                                {"avx2 8B packed", KernelIsa::kAvx2, NodeLayout::kPacked8, true},
                                {"avx2 16B", KernelIsa::kAvx2, NodeLayout::kWide16, true},
                                {"avx2 split", KernelIsa::kAvx2, NodeLayout::kSplit, true},
                                {"avx512 10B", KernelIsa::kAvx512, NodeLayout::kBlob10, true},
                                {"avx512 8B packed", KernelIsa::kAvx512, NodeLayout::kPacked8, true},
                                {"avx512 16B", KernelIsa::kAvx512, NodeLayout::kWide16, true},
                                {"avx512 split", KernelIsa::kAvx512, NodeLayout::kSplit, true}};

// The forest in every layout the kernels can read, and the arguments for one variant.
struct Layouts {
  const blob::LoadedBlob* blob;
  testing_support::TreeCopies copies;
  explicit Layouts(const blob::LoadedBlob& b) : blob(&b), copies(b) {}
  kernels::ForestKernelArgs args(int t, const Variant& v, const KernelInput& in, uint32_t* out) const {
    return copies.args(t, v.layout, in.probe.data(), in.width, in.height, in.focal, in.pixels.data(),
                       int32_t(in.pixels.size()), out);
  }
};

void run_variant(const Variant& v, const kernels::ForestKernelArgs* a, int trees) {
  if (!v.study) return kernels::forest_trees_kernel(v.isa)(a, trees);
  if (v.isa == KernelIsa::kAvx2) return kernels::avx2::evaluate_trees_study(a, trees, v.layout);
  return kernels::avx512::evaluate_trees_study(a, trees, v.layout);
}

// ns per node visit of each variant over all inputs. Each (input, variant) pair is timed `rounds`
// times, variants interleaved, and its fastest run kept: the machine is shared, so the minimum of
// short runs is the stable figure, and pairs are compared inside one run. Each timed run follows an
// untimed run of the same variant on the same input, so it is timed in the steady state of a stream
// of frames (the pipeline's case), not cold after another variant's node copy evicted its nodes from
// L2/L3 (that penalty, ~9 % for the split kernel on the PCL trees, is no property of the kernel). Every variant's leaves are
// checked against the first variant's (a layout that read wrongly would be timed for nothing).
// The figure of a variant this CPU cannot run (printed "n/a", null in the JSON).
constexpr double kNotRun = std::numeric_limits<double>::quiet_NaN();

std::vector<double> kernel_ns_per_visit(const Layouts& layouts, const std::vector<Variant>& variants,
                                        const std::vector<KernelInput>& inputs, int rounds) {
  const blob::LoadedBlob& b = *layouts.blob;
  std::vector<double> total(variants.size(), 0.0);
  std::vector<uint32_t> out, first_out;  // tree t's leaves at [t · max_pixels, ...)
  size_t max_pixels = 0, visits = 0;
  for (const auto& in : inputs) {
    max_pixels = std::max(max_pixels, in.pixels.size());
    visits += in.pixels.size() * size_t(b.tree_count()) * size_t(b.depth());
  }
  out.resize(max_pixels * size_t(b.tree_count()));
  for (const auto& in : inputs) {
    std::vector<double> best(variants.size(), 1e30);
    for (int r = 0; r < rounds; ++r)
      for (size_t v = 0; v < variants.size(); ++v) {
        if (!kernel_isa_supported(variants[v].isa)) continue;
        // All trees in one call, as the pipeline runs them.
        kernels::ForestKernelArgs a[blob::kMaxTrees];
        for (int t = 0; t < b.tree_count(); ++t) a[t] = layouts.args(t, variants[v], in, out.data() + size_t(t) * max_pixels);
        run_variant(variants[v], a, b.tree_count());  // untimed: the timed run starts warm (below)
        const double t0 = now_s();
        run_variant(variants[v], a, b.tree_count());
        best[v] = std::min(best[v], now_s() - t0);
        if (r == 0 && v == 0) first_out = out;
        if (r == 0 && v > 0 && out != first_out) {
          std::fprintf(stderr, "bench: %s gives other leaves than %s\n", variants[v].name, variants[0].name);
          std::exit(1);
        }
      }
    for (size_t v = 0; v < variants.size(); ++v) total[v] += best[v];
  }
  for (size_t v = 0; v < variants.size(); ++v)
    total[v] = kernel_isa_supported(variants[v].isa) ? total[v] * 1e9 / double(visits) : kNotRun;
  return total;
}

// One cell of a kernel table: ns per visit, or "n/a" for a kernel this CPU does not run.
void print_ns_cell(double ns) {
  if (std::isnan(ns)) std::printf(" %17s", "n/a");
  else std::printf(" %17.3f", ns);
}

struct Runner {
  std::vector<uint8_t> bytes;
  blob::LoadedBlob view{};
  platform::ArenaMemory arena;  // as the CLI allocates it (2 MiB pages advised)
  size_t arena_bytes = 0;
  Pipeline pipeline;
  Runner(std::vector<uint8_t> b, int w, int h) : bytes(std::move(b)) {
    if (blob::load_blob(bytes.data(), bytes.size(), &view) != blob::BlobStatus::kOk) std::abort();
    arena_bytes = required_arena_bytes(view, w, h);
    arena = platform::ArenaMemory(arena_bytes);
    if (pipeline.init(view, w, h, arena.data(), arena_bytes) != Status::kOk) std::abort();
  }
};

struct EndToEnd {
  double fps = 0;
  double stage_cycles[kStageCount] = {};
  double total_cycles = 0;
  double evaluated_pixels = 0;
};

EndToEnd end_to_end(Runner& r, KernelIsa isa, const std::vector<Frame>& frames, int rounds) {
  EndToEnd e;
  if (r.pipeline.set_kernel(isa) != Status::kOk) return e;
  FrameResult res;
  double best = 1e30;
  for (int round = 0; round < rounds; ++round) {
    EndToEnd acc;
    const double t0 = now_s();
    for (const Frame& f : frames) {
      r.pipeline.process(f.view(), &res);
      for (int s = 0; s < kStageCount; ++s) acc.stage_cycles[s] += double(res.stage_cycles[s]);
      acc.total_cycles += double(res.total_cycles);
      acc.evaluated_pixels += res.evaluated_pixels;
    }
    const double dt = now_s() - t0;
    if (dt < best) {
      best = dt;
      e = acc;
    }
  }
  const double n = double(frames.size());
  e.fps = n / best;
  for (double& c : e.stage_cycles) c /= n;
  e.total_cycles /= n;
  e.evaluated_pixels /= n;
  return e;
}

// OJR forest for speed only: PCL's tree structure (realistic paths) with random vote leaves.
blob::BlobContents ojr_on_pcl_nodes(const blob::BlobContents& pcl) {
  blob::BlobContents c;
  c.method = blob::Method::kOjr;
  c.depth = pcl.depth;
  c.reference_focal_px = pcl.reference_focal_px;
  for (const char* n : tools::kJointNames) c.joint_names.push_back(n);
  c.votes_per_joint = 2;
  c.tree_nodes = pcl.tree_nodes;
  c.tree_left_child = pcl.tree_left_child;
  std::mt19937 rng(5);
  const uint32_t leaves = 4096;
  for (size_t t = 0; t < pcl.tree_nodes.size(); ++t) {
    std::vector<uint32_t> index(pcl.tree_leaf_index[t].size(), 0);
    for (size_t m = 1; m <= index.size(); ++m)
      if (c.tree_left_child[t][m - 1] == m) index[m - 1] = rng() % leaves;  // leaf nodes only
    c.tree_leaf_index.push_back(std::move(index));
  }
  std::uniform_int_distribution<int> off(-300, 300), w(1, 1000);
  for (uint32_t l = 0; l < leaves * tools::kJointCount * 2; ++l)
    c.ojr_leaves.push_back(blob::OjrVote{int16_t(off(rng)), int16_t(off(rng)), int16_t(off(rng)), uint16_t(w(rng))});
  c.config = blob::default_runtime_config(tools::kJointCount);
  c.config.max_evaluated_pixels = 640 * 480;
  return c;
}

// Counter ticks per ns (the pipeline's stage costs are in runtime/cycle_counter.h's unit: TSC cycles
// on x86-64), measured against the steady clock.
double tsc_per_ns() {
  static const double rate = [] {
    const auto t0 = std::chrono::steady_clock::now();
    const uint64_t c0 = cycle_count();
    while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(100)) {
    }
    const uint64_t c1 = cycle_count();
    const double ns = double(std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count());
    return double(c1 - c0) / ns;
  }();
  return rate;
}

// The forest stage of the pipeline (pixel setup, every tree's levels, the leaf lookups) per node
// visit (evaluated pixels × trees × depth), in ns.
double forest_ns_per_visit(const EndToEnd& e, const Runner& r) {
  const double visits = e.evaluated_pixels * r.view.tree_count() * r.view.depth();
  return visits > 0 ? e.stage_cycles[kStageForest] / visits / tsc_per_ns() : 0.0;
}

void print_end_to_end(const char* label, const Runner& r, const EndToEnd& scalar, const EndToEnd& best) {
  std::printf("  %-28s scalar %7.1f fps | best SIMD %7.1f fps (x%.2f) | %6.0f px/frame | forest ns/visit %.2f (scalar %.2f)"
              " | cycles/frame:", label, scalar.fps, best.fps, best.fps / scalar.fps, best.evaluated_pixels,
              forest_ns_per_visit(best, r), forest_ns_per_visit(scalar, r));
  for (int s = 0; s < kStageCount; ++s) std::printf(" %s %.0f", stage_name(s), best.stage_cycles[s]);
  std::printf(" (scalar forest %.0f)\n", scalar.stage_cycles[kStageForest]);
}

}  // namespace

int main(int argc, char** argv) {
  const bool kernels_only = argc > 1 && std::string(argv[1]) == "--kernels-only";
  const bool layouts_only = argc > 1 && std::string(argv[1]) == "--layouts";  // the node-layout study alone
  // --only=A,B: the end-to-end rows whose label contains A or B, nothing else, no json (quick A/B runs).
  const std::string only = argc > 1 && std::string(argv[1]).rfind("--only=", 0) == 0 ? std::string(argv[1]).substr(7) : "";
  // --rounds=N after --only=: N timed rounds of the SIMD path (default 5), e.g. to profile it.
  const int simd_rounds = argc > 2 && std::string(argv[2]).rfind("--rounds=", 0) == 0 ? std::atoi(argv[2] + 9) : 5;
  std::printf("runtime bench on %s\n", cpu_brand().c_str());
  std::printf("runtime bench: kernels %s/%s/%s available: %d/%d/%d\n", kernel_isa_name(KernelIsa::kScalar),
              kernel_isa_name(KernelIsa::kAvx2), kernel_isa_name(KernelIsa::kAvx512), 1,
              int(kernel_isa_supported(KernelIsa::kAvx2)), int(kernel_isa_supported(KernelIsa::kAvx512)));
  std::vector<tools::PclTree> trees;
  for (int i = 1; i <= 3; ++i)
    trees.push_back(tools::read_pcl_tree("../shared/data/pcl-people-trees/forest" + std::to_string(i) + "_tree_20.txt.bz2"));
  const blob::BlobContents pcl = tools::pcl_blob_contents(trees);
  trees.clear();
  const std::vector<uint8_t> pcl_bytes = blob::write_blob(pcl);
  blob::LoadedBlob pb;
  if (blob::load_blob(pcl_bytes.data(), pcl_bytes.size(), &pb) != blob::BlobStatus::kOk) return 1;
  const Layouts layouts(pb);

  const std::vector<Frame> real_vga = skeltrack_frames(false), real_qvga = skeltrack_frames(true);
  const std::vector<Frame> syn_vga = synthetic_frames(false), syn_qvga = synthetic_frames(true);

  // --- forest kernels alone -------------------------------------------------------------------
  std::printf("\nforest kernel, ns per node visit (pixel x tree x level), PCL 3 x depth-20 trees:\n");
  std::printf("  %-24s", "frames");
  for (const Variant& v : kVariants) std::printf(" %17s", v.name);
  std::printf("  best/scalar\n");
  struct Set { const char* name; const std::vector<Frame>* frames; };
  const Set sets[] = {{"skeltrack 640x480", &real_vga}, {"skeltrack 320x240", &real_qvga},
                      {"synthetic 640x480", &syn_vga}, {"synthetic 320x240", &syn_qvga}};
  std::vector<double> real_vga_ns;
  for (const Set& s : sets) {
    if (!only.empty() || layouts_only) break;
    std::vector<KernelInput> inputs;
    for (const Frame& f : *s.frames) inputs.push_back(kernel_input(f, pb.meta->reference_focal_px));
    const std::vector<double> ns = kernel_ns_per_visit(
        layouts, std::vector<Variant>(std::begin(kVariants), std::end(kVariants)), inputs, kernels_only ? 5 : 4);
    double best = 1e30;
    for (int v = 1; v < kVariantCount; ++v) best = std::min(best, ns[v]);
    std::printf("  %-24s", s.name);
    for (double x : ns) print_ns_cell(x);
    std::printf("  x%.2f\n", ns[0] / best);
    if (s.frames == &real_vga) real_vga_ns = ns;
    if (kernels_only) break;
  }
  // --- node layouts ------------------------------------------------------------------------------
  std::vector<double> layout_ns;
  if ((only.empty() && !kernels_only) || layouts_only) {
    std::printf("\nnode layouts, ns per node visit, skeltrack 640x480 (same kernel code per ISA, only the node reads differ):\n ");
    for (const Variant& v : kLayoutStudy) std::printf(" %17s", v.name);
    std::printf("\n ");
    std::vector<KernelInput> inputs;
    for (const Frame& f : real_vga) inputs.push_back(kernel_input(f, pb.meta->reference_focal_px));
    layout_ns = kernel_ns_per_visit(layouts, std::vector<Variant>(std::begin(kLayoutStudy), std::end(kLayoutStudy)),
                                    inputs, 4);
    for (double x : layout_ns) print_ns_cell(x);
    std::printf("\n");
  }
  if (kernels_only || layouts_only) return 0;
  int best_variant = 1;
  for (int v = 1; v < kVariantCount && only.empty(); ++v)
    if (real_vga_ns[v] < real_vga_ns[best_variant]) best_variant = v;

  // --- end to end -------------------------------------------------------------------------------
  std::printf("\nend to end (one core, Pipeline::process, best SIMD = %s):\n", kernel_isa_name(KernelIsa::kBest));
  Runner bpc_vga(pcl_bytes, 640, 480), bpc_qvga(pcl_bytes, 320, 240);
  const std::vector<uint8_t> ojr_bytes = blob::write_blob(ojr_on_pcl_nodes(pcl));
  Runner ojr_vga(ojr_bytes, 640, 480), ojr_qvga(ojr_bytes, 320, 240);
  // The models users run (make run): trained BPC depth 16 and OJR depth 13, 3 trees each.
  const std::vector<uint8_t> ship_bpc = blob::read_blob_file("models/bpc.blob");
  const std::vector<uint8_t> ship_ojr = blob::read_blob_file("models/ojr.blob");
  Runner ship_bpc_vga(ship_bpc, 640, 480), ship_bpc_qvga(ship_bpc, 320, 240);
  Runner ship_ojr_vga(ship_ojr, 640, 480), ship_ojr_qvga(ship_ojr, 320, 240);
  const std::vector<Frame> people_vga = rendered_frames(640, 480, 24), people_qvga = rendered_frames(320, 240, 24);
  struct E2E { const char* label; Runner* r; const std::vector<Frame>* frames; EndToEnd scalar, best; };
  E2E runs[] = {{"BPC skeltrack 640x480", &bpc_vga, &real_vga, {}, {}},
                {"BPC skeltrack 320x240", &bpc_qvga, &real_qvga, {}, {}},
                {"OJR skeltrack 640x480", &ojr_vga, &real_vga, {}, {}},
                {"OJR skeltrack 320x240", &ojr_qvga, &real_qvga, {}, {}},
                {"BPC synthetic 640x480", &bpc_vga, &syn_vga, {}, {}},
                {"BPC synthetic 320x240", &bpc_qvga, &syn_qvga, {}, {}},
                {"shipped BPC skeltrack 640x480", &ship_bpc_vga, &real_vga, {}, {}},
                {"shipped BPC skeltrack 320x240", &ship_bpc_qvga, &real_qvga, {}, {}},
                {"shipped OJR skeltrack 640x480", &ship_ojr_vga, &real_vga, {}, {}},
                {"shipped OJR skeltrack 320x240", &ship_ojr_qvga, &real_qvga, {}, {}},
                {"shipped BPC rendered 640x480", &ship_bpc_vga, &people_vga, {}, {}},
                {"shipped BPC rendered 320x240", &ship_bpc_qvga, &people_qvga, {}, {}},
                {"shipped OJR rendered 640x480", &ship_ojr_vga, &people_vga, {}, {}},
                {"shipped OJR rendered 320x240", &ship_ojr_qvga, &people_qvga, {}, {}}};
  // Another OJR or BPC blob (a previous model, one too large for the repository; docs/convert.md
  // "OJR leaf compaction" makes one) when DP_BENCH_OJR_BLOB / DP_BENCH_BPC_BLOB names it, measured
  // beside the shipped ones in the same run: its rows follow the others, outside the json.
  std::unique_ptr<Runner> deep_ojr_qvga, other_bpc_qvga;
  std::vector<E2E> deep_runs;
  if (const char* path = std::getenv("DP_BENCH_OJR_BLOB"); path && *path) {
    deep_ojr_qvga = std::make_unique<Runner>(blob::read_blob_file(path), 320, 240);
    deep_runs.push_back({"DP_BENCH_OJR_BLOB skeltrack 320x240", deep_ojr_qvga.get(), &real_qvga, {}, {}});
    deep_runs.push_back({"DP_BENCH_OJR_BLOB rendered 320x240", deep_ojr_qvga.get(), &people_qvga, {}, {}});
  }
  if (const char* path = std::getenv("DP_BENCH_BPC_BLOB"); path && *path) {
    other_bpc_qvga = std::make_unique<Runner>(blob::read_blob_file(path), 320, 240);
    deep_runs.push_back({"DP_BENCH_BPC_BLOB skeltrack 320x240", other_bpc_qvga.get(), &real_qvga, {}, {}});
    deep_runs.push_back({"DP_BENCH_BPC_BLOB rendered 320x240", other_bpc_qvga.get(), &people_qvga, {}, {}});
  }
  std::vector<E2E*> all_runs;
  for (E2E& e : runs) all_runs.push_back(&e);
  for (E2E& e : deep_runs) all_runs.push_back(&e);
  for (E2E* run : all_runs) {
    E2E& e = *run;
    if (!only.empty()) {  // comma-separated substrings
      bool match = false;
      for (size_t a = 0; a <= only.size();) {
        const size_t b = std::min(only.find(',', a), only.size());
        match = match || std::string(e.label).find(only.substr(a, b - a)) != std::string::npos;
        a = b + 1;
      }
      if (!match) continue;
    }
    e.scalar = end_to_end(*e.r, KernelIsa::kScalar, *e.frames, 2);
    e.best = end_to_end(*e.r, KernelIsa::kBest, *e.frames, simd_rounds);
    print_end_to_end(e.label, *e.r, e.scalar, e.best);
  }
  const size_t bpc_vga_minimum = minimum_arena_bytes(bpc_vga.view, 640, 480);
  std::printf("\narena bytes: BPC 640x480 %zu (%zu used; %zu at least), 320x240 %zu; OJR 640x480 %zu\n",
              bpc_vga.arena_bytes, bpc_vga.pipeline.arena_used_bytes(), bpc_vga_minimum, bpc_qvga.arena_bytes,
              ojr_vga.arena_bytes);

  if (!only.empty()) return 0;
  const double simd_ns = real_vga_ns[best_variant], scalar_ns = real_vga_ns[0];
  std::printf("\nheadline: %.3f ns/visit (%s) vs scalar %.3f: x%.2f; BPC 320x240 %.0f fps, 640x480 %.0f fps\n", simd_ns,
              kVariants[best_variant].name, scalar_ns, scalar_ns / simd_ns, runs[1].best.fps, runs[0].best.fps);
  std::string layout_json;
  for (size_t v = 0; v < layout_ns.size(); ++v)
    layout_json += std::string(v ? ", " : "") + "\"" + kLayoutStudy[v].name + "\": " + (std::isnan(layout_ns[v]) ? std::string("null") : std::to_string(layout_ns[v]));
  std::system("mkdir -p build/bench");
  FILE* j = std::fopen("build/bench/runtime.json", "w");
  if (!j) return 1;
  std::fprintf(j,
               "{\n  \"cpu\": \"%s\",\n  \"ns_per_node_visit\": %.4f,\n  \"ns_per_node_visit_variant\": \"%s\",\n"
               "  \"scalar_ns_per_node_visit\": %.4f,\n  \"simd_vs_scalar\": %.3f,\n"
               "  \"bpc_fps_320x240\": %.1f,\n  \"ojr_fps_320x240\": %.1f,\n  \"bpc_fps_640x480\": %.1f,\n"
               "  \"ojr_fps_640x480\": %.1f,\n  \"bpc_scalar_fps_320x240\": %.1f,\n  \"bpc_scalar_fps_640x480\": %.1f,\n"
               "  \"arena_bytes\": %zu,\n  \"arena_bytes_320x240\": %zu,\n  \"arena_bytes_minimum\": %zu,\n"
               "  \"forest_cycles_640x480\": %.0f,\n  \"mean_shift_cycles_640x480\": %.0f,\n"
               "  \"shipped_bpc_fps_320x240\": %.1f,\n  \"shipped_bpc_fps_640x480\": %.1f,\n"
               "  \"shipped_ojr_fps_320x240\": %.1f,\n  \"shipped_ojr_fps_640x480\": %.1f,\n"
               "  \"shipped_bpc_rendered_fps_320x240\": %.1f,\n  \"shipped_bpc_rendered_fps_640x480\": %.1f,\n"
               "  \"shipped_ojr_rendered_fps_320x240\": %.1f,\n  \"shipped_ojr_rendered_fps_640x480\": %.1f,\n"
               "  \"shipped_bpc_rendered_cycles_320x240\": {\"foreground\": %.0f, \"forest\": %.0f, \"votes\": %.0f, \"mean_shift\": %.0f},\n"
               "  \"node_layouts_ns_per_visit\": {%s},\n"
               "  \"pipeline_forest_ns_per_visit\": {\"bpc_640x480\": %.3f, \"bpc_320x240\": %.3f, \"ojr_640x480\": %.3f,"
               " \"ojr_320x240\": %.3f, \"tsc_ticks_per_ns\": %.4f},\n"
               "  \"counter_unit\": \"%s\",\n"
               "  \"frames\": \"skeltrack 12 real Kinect frames, PCL 3 x depth-20 trees (shipped_*: models/*.blob on the same frames;"
               " shipped_*_rendered_*: 24 rendered people, test-split clips, seed 303)\"\n}\n",
               cpu_brand().c_str(), simd_ns, kVariants[best_variant].name, scalar_ns, scalar_ns / simd_ns, runs[1].best.fps, runs[3].best.fps,
               runs[0].best.fps, runs[2].best.fps, runs[1].scalar.fps, runs[0].scalar.fps, bpc_vga.arena_bytes,
               bpc_qvga.arena_bytes, bpc_vga_minimum, runs[0].best.stage_cycles[kStageForest], runs[0].best.stage_cycles[kStageMeanShift],
               runs[7].best.fps, runs[6].best.fps, runs[9].best.fps, runs[8].best.fps, runs[11].best.fps, runs[10].best.fps,
               runs[13].best.fps, runs[12].best.fps, runs[11].best.stage_cycles[kStageForeground],
               runs[11].best.stage_cycles[kStageForest], runs[11].best.stage_cycles[kStageVotes],
               runs[11].best.stage_cycles[kStageMeanShift], layout_json.c_str(), forest_ns_per_visit(runs[0].best, bpc_vga),
               forest_ns_per_visit(runs[1].best, bpc_qvga), forest_ns_per_visit(runs[2].best, ojr_vga),
               forest_ns_per_visit(runs[3].best, ojr_qvga), tsc_per_ns(), cycle_counter_unit());
  std::fclose(j);
  std::printf("wrote build/bench/runtime.json\n");
  return 0;
}
