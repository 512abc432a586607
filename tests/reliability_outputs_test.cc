// Outputs are whole or absent and every write error is an error: atomic files (no temporary left
// behind on failure), standard output checked (`> /dev/full` exits 1), segeval's --json and
// --per-frame checked; no bare std::bad_alloc reaches a user; `run` on a source whose every frame
// is bad exits 1; `run --loop N` plays a file source N times.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <new>
#include <string>
#include <vector>

#include "forest_blob/blob_writer.h"
#include "platform/frame_source.h"
#include "platform/oni_container.h"
#include "platform/oni_recorder.h"
#include "tests/app_run_support.h"
#include "tests/app_test_support.h"
#include "tests/cli_test_support.h"
#include "tests/shared_data.h"
#include "tools/app/run.h"
#include "tools/cli/command.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/demo/fixtures.h"

using namespace dp;
using dp::apptest::TempDir;

namespace {

std::vector<std::string> directory_entries(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
  return names;
}

std::string captured_by(const std::function<void(std::FILE*)>& f) {
  std::FILE* out = std::tmpfile();
  f(out);
  return apptest::slurp_and_close(out);
}

void write_text_file(const std::string& path, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  std::fwrite(text.data(), 1, text.size(), f);
  std::fclose(f);
}

// In a child process: limits file sizes to 4 KiB, writes 1 MiB atomically over `path`; 7 when the
// write was refused and `dir` holds only the old file (no temporary left), else 1.
int write_past_file_size_limit(const std::string& path, const std::string& dir) {
  std::signal(SIGXFSZ, SIG_IGN);
  rlimit lim{};
  lim.rlim_cur = lim.rlim_max = 4096;
  setrlimit(RLIMIT_FSIZE, &lim);
  bool refused = false;
  try {
    tools::write_file_atomic(path, std::string(1 << 20, 'x'));
  } catch (const tools::ToolError&) {
    refused = true;
  }
  return refused && directory_entries(dir) == std::vector<std::string>{"out.json"} ? 7 : 1;
}

// In a child process: stdout to /dev/full, then the command through the CLI's reporting wrapper.
int run_into_full_device(const cli::Command& command, std::vector<std::string> words) {
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  if (!std::freopen("/dev/full", "w", stdout)) return 3;
  return cli::run_command_reporting(command, int(argv.size()), argv.data(), stderr);
}

int throws_bad_alloc(int, char**) { throw std::bad_alloc(); }
int prints_a_lot(int, char**) {
  for (int i = 0; i < 100000; ++i) std::printf("line %d of a report\n", i);
  return 0;
}

// A one-joint blob whose depth band takes the discs of apptest::moving_disc.
std::string write_test_blob(const TempDir& t) {
  blob::BlobContents c = tools::single_part_bpc(2, 1, 1, 40);
  c.max_width = 160;
  c.max_height = 120;
  const std::string path = t / "m.blob";
  blob::save_blob_file(path, blob::write_blob(c));
  return path;
}

}  // namespace

TEST(ReliabilityOutputs, AtomicWriteReplacesWholeOrLeavesTheOldFile) {
  TempDir t;
  const std::string path = t / "out.json";
  tools::write_file_atomic(path, std::string("old\n"));
  tools::write_file_atomic(path, std::string("new content\n"));
  EXPECT_EQ(directory_entries(t.path), std::vector<std::string>{"out.json"});
  // A directory that does not exist: an error naming the file, nothing created.
  const std::string m = [&] {
    try {
      tools::write_file_atomic(t / "missing/out.json", std::string("x"));
    } catch (const tools::ToolError& e) {
      return std::string(e.what());
    }
    return std::string();
  }();
  EXPECT_NE(m.find(t / "missing/out.json"), std::string::npos) << m;
  // A write that fails half way (file size limit): the old file stays, no temporary is left.
  EXPECT_EXIT(std::_Exit(write_past_file_size_limit(path, t.path)), testing::ExitedWithCode(7), "");
  // The same for a streamed output that is abandoned (an error before commit).
  {
    tools::AtomicOutputFile f(t / "frames.jsonl");
    f.write("{\"frame\":0}\n");
  }
  EXPECT_EQ(directory_entries(t.path), std::vector<std::string>{"out.json"});
  {
    tools::AtomicOutputFile f(t / "frames.jsonl");
    f.write("{\"frame\":0}\n");
    f.commit();
  }
  EXPECT_EQ(directory_entries(t.path).size(), 2u);
}

TEST(ReliabilityOutputs, WritesToAFullDeviceAreErrors) {
  // Atomic writers must write devices directly (never rename over /dev/full) and report ENOSPC.
  std::string m;
  try {
    tools::write_file_atomic("/dev/full", std::string(100, 'x'));
  } catch (const tools::ToolError& e) {
    m = e.what();
  }
  EXPECT_NE(m.find("cannot write /dev/full"), std::string::npos) << m;
  struct stat st {};
  ASSERT_EQ(::stat("/dev/full", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode)) << "/dev/full must still be the device";
  try {
    tools::AtomicOutputFile f("/dev/full");
    f.write(std::string(100000, 'x'));
    f.commit();
    m.clear();
  } catch (const tools::ToolError& e) {
    m = e.what();
  }
  EXPECT_NE(m.find("cannot write /dev/full"), std::string::npos) << m;
}

TEST(ReliabilityOutputs, StandardOutputToAFullDeviceExitsOne) {
  const cli::Command loud{"loud", "prints a report", prints_a_lot};
  EXPECT_EXIT(std::_Exit(run_into_full_device(loud, {"loud"})), testing::ExitedWithCode(1),
              "depthpose loud: error: cannot write to standard output: No space left on device");
  // eval's report and run --json through the real commands.
  TempDir t;
  const std::string blob = write_test_blob(t);
  apptest::write_disc_dataset(t / "ds", 3);
  const cli::Command* run = cli::find_command("run");
  ASSERT_NE(run, nullptr);
  const std::vector<std::string> words = {"run", "--blob", blob, "--source", "dataset:" + (t / "ds"), "--json"};
  EXPECT_EXIT(std::_Exit(run_into_full_device(*run, words)), testing::ExitedWithCode(1), "cannot write to standard output");
  const cli::Command* eval = cli::find_command("eval");
  ASSERT_NE(eval, nullptr);
  const std::vector<std::string> eval_words = {"eval", "--blob", blob, "--data", t / "ds"};
  EXPECT_EXIT(std::_Exit(run_into_full_device(*eval, eval_words)), testing::ExitedWithCode(1),
              "cannot write to standard output");
}

TEST(ReliabilityOutputs, OutOfMemoryIsASentenceNotStdBadAlloc) {
  const cli::Command hungry{"hungry", "allocates too much", throws_bad_alloc};
  int rc = 0;
  const std::string err = captured_by([&](std::FILE* f) { rc = cli::run_command_reporting(hungry, 1, nullptr, f); });
  EXPECT_EQ(rc, 1);
  EXPECT_EQ(err.find("std::bad_alloc"), std::string::npos) << err;
  EXPECT_NE(err.find("depthpose hungry: error: out of memory"), std::string::npos) << err;
  EXPECT_NE(err.find("docs/limits.md"), std::string::npos) << err;
}

TEST(ReliabilityOutputs, RunOnASourceWhoseEveryFrameIsBadFails) {
  TempDir t;
  const std::string blob = write_test_blob(t);
  apptest::write_disc_dataset(t / "ds", 3);
  for (int i = 0; i < 3; ++i) write_text_file(t / ("ds/depth/" + tools::frame_id(size_t(i)) + ".png"), "not a png");
  tools::RunOptions o;
  o.blob_path = blob;
  o.source_spec = "dataset:" + (t / "ds");
  o.json = true;
  const apptest::Captured c = apptest::run_captured(o);
  EXPECT_EQ(c.summary.frames_processed, 0);
  EXPECT_TRUE(c.summary.source_failed);
  EXPECT_NE(c.summary.source_error.find("none of its frames could be processed (3 corrupt"), std::string::npos)
      << c.summary.source_error;
  // Through the command: exit 1.
  testing::internal::CaptureStderr();
  EXPECT_EQ(testsupport::run_cli({"run", "--blob", blob, "--source", "dataset:" + (t / "ds"), "--quiet"}), 1);
  testing::internal::GetCapturedStderr();
}

TEST(ReliabilityOutputs, LoopPlaysAFileSourceAgain) {
  TempDir t;
  const std::string blob = write_test_blob(t);
  apptest::write_disc_dataset(t / "ds", 4);
  tools::RunOptions o;
  o.blob_path = blob;
  o.source_spec = "dataset:" + (t / "ds");
  o.json = true;
  o.loop = 3;
  const apptest::Captured c = apptest::run_captured(o);
  ASSERT_FALSE(c.summary.source_failed) << c.summary.source_error;
  EXPECT_EQ(c.summary.frames_processed, 12);
  ASSERT_EQ(c.lines.size(), 12u);
  // The second pass sees the same frames as the first.
  EXPECT_EQ(c.lines[1]["source_index"], c.lines[5]["source_index"]);
  EXPECT_EQ(c.lines[1]["foreground_pixels"], c.lines[5]["foreground_pixels"]);
  // .oni recordings rewind too.
  const std::string demo = "models/demo.oni";
  ASSERT_TRUE(std::filesystem::exists(demo)) << demo << " is missing (make model builds it)";
  tools::RunOptions oni = o;
  oni.blob_path = "models/bpc.blob";
  oni.source_spec = "oni:" + demo;
  oni.loop = 2;
  oni.segment = tools::SegmentMode::kOff;
  const apptest::Captured r = apptest::run_captured(oni);
  ASSERT_FALSE(r.summary.source_failed) << r.summary.source_error;
  ASSERT_GT(r.summary.frames_processed, 0);
  EXPECT_EQ(r.summary.frames_processed % 2, 0);
  const size_t half = size_t(r.summary.frames_processed / 2);
  // OpenNI2 plays the file again (repeat, no seek, no reopen): pass 2 has pass 1's frames in order.
  for (size_t i = 0; i < half; ++i) {
    EXPECT_EQ(r.lines[i]["foreground_pixels"], r.lines[half + i]["foreground_pixels"]) << "frame " << i;
    EXPECT_EQ(r.lines[i]["source_index"], r.lines[half + i]["source_index"]) << "frame " << i;
  }
  o.loop = 0;
  EXPECT_THROW(tools::run_app(o, stdout, stderr), tools::ToolError);
}

TEST(ReliabilityOutputs, RecordWritesItsContentOnceAndLeavesNothingOnFailure) {
  TempDir t;
  apptest::write_disc_dataset(t / "ds", 4);
  const std::string spec = "dataset:" + (t / "ds");
  const std::string out = t / "x.oni";
  platform::RecordOptions o;
  const platform::RecordReport rep = platform::record_oni([&] { return platform::open_source(spec); }, true, out, o);
  EXPECT_EQ(rep.frames_recorded, 4);
  // OpenNI2's recorder leaves twice the content (the second half zeros); the file is trimmed to
  // its end record, then only the integrity trailer (20 + 4 per frame) and its 12-byte footer follow.
  const platform::OniContainerSummary s = platform::check_oni_container(out);
  EXPECT_TRUE(s.integrity_trailer);
  EXPECT_EQ(s.trailer_offset, s.records_end);
  EXPECT_EQ(s.file_bytes, s.records_end + 20 + 4 * 4 + 12);
  EXPECT_EQ(std::filesystem::file_size(out), s.file_bytes);
  EXPECT_EQ(s.depth_frames, 4);
  // A source that fails to open: no .partial file is left beside the output.
  EXPECT_THROW(platform::record_oni([&]() -> std::unique_ptr<platform::FrameSource> { tools::fail("source gone"); },
                                    true, t / "y.oni", o),
               tools::ToolError);
  for (const std::string& name : directory_entries(t.path))
    EXPECT_EQ(name.find(".partial"), std::string::npos) << name;
}

namespace {

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}
bool has_meta_json(const std::string& path) { return std::filesystem::exists(path + "/meta.json"); }

}  // namespace

TEST(ReliabilityOutputs, AtomicDirectoryIsSwappedInWholeOrLeftAsItWas) {
  TempDir t;
  const std::string out = t / "dataset";
  {
    tools::AtomicOutputDirectory d(out, has_meta_json, "dataset");
    write_text_file(d.path() + "/meta.json", "{}\n");
    write_text_file(d.path() + "/a", "first\n");
    EXPECT_FALSE(std::filesystem::exists(out)) << "nothing appears before commit";
    d.commit();
  }
  EXPECT_EQ(read_text(out + "/a"), "first\n");
  {  // abandoned (an error on the way): the old folder stays, no temporary is left
    tools::AtomicOutputDirectory d(out, has_meta_json, "dataset");
    write_text_file(d.path() + "/meta.json", "{}\n");
    write_text_file(d.path() + "/b", "second\n");
  }
  EXPECT_EQ(read_text(out + "/a"), "first\n");
  EXPECT_FALSE(std::filesystem::exists(out + "/b"));
  EXPECT_EQ(directory_entries(t.path), std::vector<std::string>{"dataset"});
  {  // committed over the old one: only the new files remain
    tools::AtomicOutputDirectory d(out, has_meta_json, "dataset");
    write_text_file(d.path() + "/meta.json", "{}\n");
    write_text_file(d.path() + "/b", "second\n");
    d.commit();
  }
  EXPECT_FALSE(std::filesystem::exists(out + "/a"));
  EXPECT_EQ(read_text(out + "/b"), "second\n");
  EXPECT_EQ(directory_entries(t.path), std::vector<std::string>{"dataset"});
  // A non-empty folder that is not a dataset is refused, named, and left alone.
  const std::string other = t / "notes";
  std::filesystem::create_directories(other);
  write_text_file(other + "/keep.txt", "mine\n");
  try {
    tools::AtomicOutputDirectory d(other, has_meta_json, "dataset");
    ADD_FAILURE() << "a non-dataset folder was accepted";
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find(other), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_text(other + "/keep.txt"), "mine\n");
}

TEST(ReliabilityOutputsSharedData, SynthOverAnExistingDatasetLeavesNoFramesOfTheOldOne) {
  TempDir t;
  const std::string out = t / "data", assets = dp::test::shared_path("assets");
  const auto synth = [&](const std::string& frames) {
    return dp::testsupport::run_cli({"synth", "--assets", assets, "--out", out, "--frames", frames, "--seed", "5",
                                     "--clips", "02_01", "--width", "80", "--height", "60", "--threads", "1"});
  };
  ASSERT_EQ(synth("4"), 0);
  ASSERT_EQ(synth("2"), 0);
  size_t depth_files = 0;
  for (const auto& e : std::filesystem::directory_iterator(out + "/depth")) depth_files += e.is_regular_file();
  EXPECT_EQ(depth_files, 2u) << "frames of the earlier dataset were left beside the new frames.jsonl";
  const std::string jsonl = read_text(out + "/frames.jsonl");
  EXPECT_EQ(std::count(jsonl.begin(), jsonl.end(), '\n'), 2);
  EXPECT_EQ(directory_entries(t.path), std::vector<std::string>{"data"});
  // A folder that is not a dataset is refused and left as it was.
  const std::string mine = t / "mine";
  std::filesystem::create_directories(mine);
  write_text_file(mine + "/keep.txt", "mine\n");
  EXPECT_THROW(dp::testsupport::run_cli({"synth", "--assets", assets, "--out", mine, "--frames", "1", "--clips",
                                         "02_01", "--width", "80", "--height", "60"}),
               tools::ToolError);
  EXPECT_EQ(directory_entries(mine), std::vector<std::string>{"keep.txt"});
}
