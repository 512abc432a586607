// Runs run_app (tools/app/run.h) with its output and log captured, for the app tests.
#pragma once
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tools/app/run.h"

namespace dp::apptest {

struct Captured {
  tools::RunSummary summary;
  std::vector<nlohmann::json> lines;  // with --json
  std::vector<std::string> text;      // without
  std::string log;
};

inline std::string slurp_and_close(FILE* f) {
  std::string s;
  std::rewind(f);
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
  std::fclose(f);
  return s;
}

inline Captured run_captured(const tools::RunOptions& o) {
  Captured c;
  FILE* out = std::tmpfile();
  FILE* log = std::tmpfile();
  c.summary = tools::run_app(o, out, log);
  std::istringstream lines(slurp_and_close(out));
  c.log = slurp_and_close(log);
  for (std::string line; std::getline(lines, line);) {
    if (o.json) c.lines.push_back(nlohmann::json::parse(line));
    else c.text.push_back(line);
  }
  return c;
}

}  // namespace dp::apptest
