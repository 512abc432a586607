// build/bin/depthpose: dispatches to the registered subcommands and turns exceptions from the
// tools into one clear line on stderr and a non-zero exit.
#include <cstdio>
#include <cstring>

#include "tools/cli/command.h"

static void print_usage(FILE* out) {
  std::fprintf(out,
               "depthpose — 3D body joints from single depth frames (Shotton et al., PAMI 2012)\n\n"
               "usage: depthpose <command> [options]    (depthpose <command> --help for details)\n\n"
               "commands:\n");
  for (int i = 0; i < dp::cli::command_count(); ++i) {
    const auto& c = dp::cli::command_at(i);
    std::fprintf(out, "  %-10s %s\n", c.name, c.summary);
  }
}

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
      !std::strcmp(argv[1], "help")) {
    print_usage(argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  const dp::cli::Command* command = dp::cli::find_command(argv[1]);
  if (!command) {
    std::fprintf(stderr, "depthpose: unknown command '%s' (see depthpose --help)\n", argv[1]);
    return 2;
  }
  return dp::cli::run_command_reporting(*command, argc - 1, argv + 1, stderr);
}
