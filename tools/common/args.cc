#include "tools/common/args.h"

#include <algorithm>
#include <cstdlib>

#include "tools/common/error.h"

namespace dp::tools {

Args::Args(int argc, char** argv, std::string usage, std::vector<std::string> options,
           std::vector<std::string> flags)
    : usage_(std::move(usage)) {
  auto contains = [](const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
  };
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      help_ = true;
      continue;
    }
    if (a.size() > 2 && a[0] == '-' && a[1] == '-') {
      std::string name = a, value;
      bool inline_value = false;
      if (auto eq = a.find('='); eq != std::string::npos) {
        name = a.substr(0, eq);
        value = a.substr(eq + 1);
        inline_value = true;
      }
      if (contains(flags, name)) {
        if (inline_value) fail("option " + name + " takes no value");
        values_[name] = "1";
      } else if (contains(options, name)) {
        if (!inline_value) {
          if (i + 1 >= argc) fail("option " + name + " needs a value");
          value = argv[++i];
        }
        values_[name] = value;
      } else {
        fail("unknown option " + name + "\n" + usage_);
      }
    } else {
      positional_.push_back(a);
    }
  }
}

std::string Args::get(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end()) fail("missing required option " + name + "\n" + usage_);
  return it->second;
}

std::string Args::get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

long long Args::get_int(const std::string& name, long long fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  long long v = std::strtoll(it->second.c_str(), &end, 10);
  if (it->second.empty() || *end) fail("option " + name + " wants an integer, got '" + it->second + "'");
  return v;
}

double Args::get_double(const std::string& name, double fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end) fail("option " + name + " wants a number, got '" + it->second + "'");
  return v;
}

std::vector<std::string> split_list(const std::string& text, char separator) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : text) {
    if (c == separator) {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

}  // namespace dp::tools
