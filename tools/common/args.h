// A small command-line parser shared by the subcommands: `--name value`, `--name=value` and
// boolean `--flag`. Unknown options are an error naming the option; `--help` prints the usage.
#pragma once
#include <map>
#include <string>
#include <vector>

namespace dp::tools {

class Args {
 public:
  // `usage` is printed by --help and after an error. `flags` lists options that take no value
  // (e.g. {"--json", "--floor"}); `options` lists options that take one value. Throws ToolError on
  // an unknown option or a missing value. Sets help_requested() when --help/-h was given.
  Args(int argc, char** argv, std::string usage, std::vector<std::string> options,
       std::vector<std::string> flags = {});

  bool help_requested() const { return help_; }
  const std::string& usage() const { return usage_; }

  bool has(const std::string& name) const { return values_.count(name) != 0; }
  // Throws ToolError("missing required option --x") when absent.
  std::string get(const std::string& name) const;
  std::string get(const std::string& name, const std::string& fallback) const;
  // Numeric getters throw ToolError naming the option when the value does not parse.
  long long get_int(const std::string& name, long long fallback) const;
  double get_double(const std::string& name, double fallback) const;
  bool flag(const std::string& name) const { return has(name); }
  const std::vector<std::string>& positional() const { return positional_; }

 private:
  std::string usage_;
  std::map<std::string, std::string> values_;
  std::vector<std::string> positional_;
  bool help_ = false;
};

// Splits "a,b,c" into {"a","b","c"} (empty pieces dropped).
std::vector<std::string> split_list(const std::string& text, char separator = ',');

}  // namespace dp::tools
