// Subcommands of build/bin/depthpose register themselves with a static DP_REGISTER_COMMAND in
// their own .cc file; tools/cli/main.cc dispatches by name. No central table to edit.
#pragma once
#include <cstdio>

namespace dp::cli {

// Runs one subcommand. argv[0] is the subcommand name. Returns the process exit code.
// May throw dp::tools::ToolError (or any std::exception); main prints it as one clear line.
using CommandFn = int (*)(int argc, char** argv);

struct Command {
  const char* name;     // e.g. "synth"
  const char* summary;  // one line for `depthpose --help`
  CommandFn run;
};

struct CommandRegistrar {
  explicit CommandRegistrar(const Command& command);
};

// Lookup for main and tests. Returns nullptr when no such subcommand is linked in.
const Command* find_command(const char* name);
// Number of registered commands and access in name order.
int command_count();
const Command& command_at(int index);

// Runs `command` and turns anything it throws into one line on `err` ("depthpose NAME: error:
// ...") and exit code 1: a ToolError's message as is, running out of memory as a sentence naming
// the limits (never a bare "std::bad_alloc"). Then checks that standard output was written
// completely (a full disk or /dev/full is an error, exit 1). main() uses it; tests call it.
int run_command_reporting(const Command& command, int argc, char** argv, std::FILE* err);

}  // namespace dp::cli

#define DP_REGISTER_COMMAND(ident, name, summary, fn) \
  static ::dp::cli::CommandRegistrar dp_command_registrar_##ident({name, summary, fn})
