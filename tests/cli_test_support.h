// Runs a depthpose subcommand in-process, as `depthpose ARGS...` would (args[0] = the subcommand).
#pragma once
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tools/cli/command.h"

namespace dp::testsupport {

// The subcommand's exit status; -100 when no such subcommand is registered. ToolErrors propagate.
inline int run_cli(std::vector<std::string> args) {
  const cli::Command* cmd = args.empty() ? nullptr : cli::find_command(args[0].c_str());
  EXPECT_NE(cmd, nullptr) << (args.empty() ? "(no subcommand)" : args[0]);
  if (!cmd) return -100;
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  return cmd->run(static_cast<int>(argv.size()), argv.data());
}

}  // namespace dp::testsupport
