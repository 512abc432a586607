// `depthpose info`: describes a good blob (exit 0) and names the problem of a bad one (exit 1).
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "forest_blob/blob_writer.h"
#include "tools/cli/command.h"
#include "tools/demo/fixtures.h"

namespace {

int run_info(const std::string& path, std::string* err) {
  const dp::cli::Command* c = dp::cli::find_command("info");
  EXPECT_NE(c, nullptr);
  std::string a0 = "info", a1 = path;
  char* argv[] = {a0.data(), a1.data(), nullptr};
  testing::internal::CaptureStderr();
  testing::internal::CaptureStdout();
  const int rc = c->run(2, argv);
  testing::internal::GetCapturedStdout();
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
