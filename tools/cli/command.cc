#include "tools/cli/command.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <exception>
#include <new>
#include <stdexcept>
#include <vector>

namespace dp::cli {
namespace {
// Function-local static: registrars run during static initialisation in unspecified order.
std::vector<Command>& registry() {
  static std::vector<Command> commands;
  return commands;
}
}  // namespace

CommandRegistrar::CommandRegistrar(const Command& command) {
  auto& commands = registry();
  commands.push_back(command);
  std::sort(commands.begin(), commands.end(),
            [](const Command& a, const Command& b) { return std::strcmp(a.name, b.name) < 0; });
}

const Command* find_command(const char* name) {
  for (const Command& c : registry())
    if (std::strcmp(c.name, name) == 0) return &c;
  return nullptr;
}

int run_command_reporting(const Command& command, int argc, char** argv, std::FILE* err) {
  int rc = 1;
  try {
    rc = command.run(argc, argv);
  } catch (const std::bad_alloc&) {
    // Declared sizes are checked against tools/common/limits.h before allocating; what is left is
    // the machine running out of memory for a large but legal input.
    std::fprintf(err,
                 "depthpose %s: error: out of memory (an input is larger than this machine can hold; "
                 "the size limits are in docs/limits.md)\n",
                 command.name);
    return 1;
  } catch (const std::length_error& e) {
    std::fprintf(err, "depthpose %s: error: a size is too large to allocate (%s)\n", command.name, e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(err, "depthpose %s: error: %s\n", command.name, e.what());
    return 1;
  }
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::fprintf(err, "depthpose %s: error: cannot write to standard output: %s\n", command.name,
                 std::strerror(errno ? errno : EIO));
    std::clearerr(stdout);
    return 1;
  }
  return rc;
}

int command_count() { return static_cast<int>(registry().size()); }
const Command& command_at(int index) { return registry()[static_cast<size_t>(index)]; }

}  // namespace dp::cli
