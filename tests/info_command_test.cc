// `depthpose info`: describes a good blob (exit 0) and names the problem of a bad one (exit 1).
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "runtime/depthpose.h"
#include "tools/cli/command.h"
#include "tools/demo/fixtures.h"

namespace {

int run_info(const std::string& path, std::string* err, std::string* out = nullptr) {
  const dp::cli::Command* c = dp::cli::find_command("info");
  EXPECT_NE(c, nullptr);
  std::string a0 = "info", a1 = path;
  char* argv[] = {a0.data(), a1.data(), nullptr};
  testing::internal::CaptureStderr();
  testing::internal::CaptureStdout();
  const int rc = c->run(2, argv);
  const std::string printed = testing::internal::GetCapturedStdout();
  if (out) *out = printed;
  *err = testing::internal::GetCapturedStderr();
  return rc;
}

}  // namespace

TEST(InfoCommand, DescribesGoodBlobAndNamesProblemOfBadOne) {
  const std::string dir = testing::TempDir();
  const std::string good = dir + "/info_good.blob", bad = dir + "/info_bad.blob";
  std::vector<uint8_t> bytes = dp::blob::write_blob(dp::tools::single_part_bpc(5, 3, 2, 40, 3, 2));
  dp::blob::save_blob_file(good, bytes);
  bytes[bytes.size() / 2] ^= 0x10;
  dp::blob::save_blob_file(bad, bytes);
  std::string err;
  EXPECT_EQ(run_info(good, &err), 0);
  EXPECT_EQ(run_info(bad, &err), 1);
  EXPECT_NE(err.find("payload checksum mismatch"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "one line: " << err;
  bytes.resize(40);
  dp::blob::save_blob_file(bad, bytes);
  EXPECT_EQ(run_info(bad, &err), 1);
  EXPECT_NE(err.find("truncated"), std::string::npos) << err;
  std::remove(good.c_str());
  std::remove(bad.c_str());
}

// Users size their arena from `info`: it must print what this runtime's init requires, even for a
// blob whose recorded figure came from an older runtime.
TEST(InfoCommand, PrintsTheArenaThisRuntimeRequires) {
  const std::string path = testing::TempDir() + "/info_arena.blob";
  const std::vector<uint8_t> bytes = dp::blob::write_blob(dp::tools::single_part_bpc(5, 3, 2, 40, 3, 2));
  dp::blob::save_blob_file(path, bytes);
  dp::blob::LoadedBlob b;
  ASSERT_EQ(dp::blob::load_blob(bytes.data(), bytes.size(), &b), dp::blob::BlobStatus::kOk);
  const size_t need = dp::required_arena_bytes(b, int32_t(b.meta->max_width), int32_t(b.meta->max_height));
  std::string err, out;
  ASSERT_EQ(run_info(path, &err, &out), 0) << err;
  EXPECT_NE(out.find(": " + std::to_string(need) + " bytes with this runtime"), std::string::npos) << out;
  std::remove(path.c_str());
}
