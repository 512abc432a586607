#include "tools/cli/command.h"

#include <algorithm>
#include <cstring>
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

int command_count() { return static_cast<int>(registry().size()); }
const Command& command_at(int index) { return registry()[static_cast<size_t>(index)]; }

}  // namespace dp::cli
