// Subcommands of build/bin/depthpose register themselves with a static DP_REGISTER_COMMAND in
// their own .cc file; tools/cli/main.cc dispatches by name. No central table to edit.
#pragma once

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

}  // namespace dp::cli

#define DP_REGISTER_COMMAND(ident, name, summary, fn) \
  static ::dp::cli::CommandRegistrar dp_command_registrar_##ident({name, summary, fn})
