#include "tools/segeval/segmenter_config_text.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "tools/common/error.h"

namespace dp::tools {

namespace {

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string default_text(const SegmenterConfigField& f) {
  if (f.type == kConfigBool) return f.default_value != 0.0 ? "true" : "false";
  if (f.type == kConfigFloat) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", float(f.default_value));
    return buf;
  }
  return number_text(f.default_value);
}

const char* type_text(SegmenterConfigType t) {
  switch (t) {
    case kConfigBool: return "bool";
    case kConfigUint16: return "uint16";
    case kConfigInt32: return "int32";
    case kConfigFloat: return "float";
  }
  return "?";
}

const char* relation_text(SegmenterConfigRelation r) {
  switch (r) {
    case kRelationGreater: return ">";
    case kRelationGreaterEqual: return ">=";
    case kRelationLessEqual: return "<=";
  }
  return "?";
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

[[noreturn]] void bad_value(const std::string& where, const std::string& key, const std::string& value, int index,
                            const std::string& problem) {
  fail(where + ": " + key + " = '" + value + "': " + problem + " (" + type_text(kSegmenterConfigFields[index].type) +
       " in " + segmenter_config_range_text(index) + ")");
}

}  // namespace

int segmenter_config_field_index(const std::string& key) {
  for (int i = 0; i < kSegmenterConfigFieldCount; ++i)
    if (key == kSegmenterConfigFields[i].name) return i;
  return -1;
}

std::string segmenter_config_range_text(int index) {
  const SegmenterConfigField& f = kSegmenterConfigFields[index];
  if (f.type == kConfigBool) return "true or false";
  const bool open_min = f.range == kRangeOpenMin || f.range == kRangeOpen, open_max = f.range == kRangeOpenMax || f.range == kRangeOpen;
  const bool unbounded = (f.type == kConfigFloat && f.max == kConfigUnbounded) || (f.type != kConfigFloat && f.max == kConfigIntUnbounded);
  if (unbounded) return std::string(open_min ? "> " : ">= ") + number_text(f.min);
  return std::string(open_min ? "(" : "[") + number_text(f.min) + ", " + number_text(f.max) + (open_max ? ")" : "]");
}

void set_segmenter_config_field(SegmenterConfig* config, const std::string& key, const std::string& raw,
                                const std::string& where) {
  const int index = segmenter_config_field_index(key);
  if (index < 0) fail(where + ": unknown key '" + key + "' (docs/segmentation.md lists the keys)");
  const std::string value = trim(raw);
  const SegmenterConfigField& f = kSegmenterConfigFields[index];
  double v = 0.0;
  if (f.type == kConfigBool) {
    if (value == "true" || value == "1") v = 1.0;
    else if (value == "false" || value == "0") v = 0.0;
    else bad_value(where, key, value, index, "not a bool");
  } else if (f.type == kConfigFloat) {
    if (value.empty()) bad_value(where, key, value, index, "no value");
    char* end = nullptr;
    errno = 0;
    const double d = std::strtod(value.c_str(), &end);
    if (end == value.c_str() || *end != '\0') bad_value(where, key, value, index, "not a number");
    if (!std::isfinite(d) || errno == ERANGE) bad_value(where, key, value, index, "not a finite number");
    const float as_float = float(d);  // the value the segmenter will see
    if (!std::isfinite(as_float)) bad_value(where, key, value, index, "out of range");
    v = double(as_float);
  } else {
    if (value.empty()) bad_value(where, key, value, index, "no value");
    char* end = nullptr;
    errno = 0;
    const long long n = std::strtoll(value.c_str(), &end, 10);
    if (end == value.c_str() || *end != '\0') bad_value(where, key, value, index, "not an integer");
    if (errno == ERANGE) bad_value(where, key, value, index, "out of range");
    v = double(n);
  }
  if (!segmenter_config_in_range(index, v)) bad_value(where, key, value, index, "out of range");
  switch (index) {
#define DP_SEGMENTER_CONFIG_SET(type, name, def, lo, hi, range, unit, meaning) \
  case segmenter_config_detail::k_##name:                                       \
    config->name = static_cast<type>(v);                                        \
    break;
    DP_SEGMENTER_CONFIG_FIELDS(DP_SEGMENTER_CONFIG_SET)
#undef DP_SEGMENTER_CONFIG_SET
  }
}

void check_segmenter_config_constraints(const SegmenterConfig& config, const std::string& where) {
  for (int k = 0; k < kSegmenterConfigConstraintCount; ++k) {
    if (segmenter_config_constraint_holds(config, k)) continue;
    const SegmenterConfigConstraint& c = kSegmenterConfigConstraints[k];
    const SegmenterConfigField& a = kSegmenterConfigFields[c.field];
    const SegmenterConfigField& b = kSegmenterConfigFields[c.other];
    fail(where + ": " + a.name + " = " + number_text(segmenter_config_value(config, c.field)) + " must be " +
         relation_text(c.relation) + " " + b.name + " = " + number_text(segmenter_config_value(config, c.other)));
  }
  int32_t bad = 0;
  if (!segmenter_config_check(config, &bad)) {  // a field out of range that no setter above wrote
    if (bad >= 0)
      fail(where + ": " + kSegmenterConfigFields[bad].name + " = " + number_text(segmenter_config_value(config, bad)) +
           ": out of range (" + segmenter_config_range_text(bad) + ")");
    fail(where + ": invalid segmenter config");
  }
}

SegmenterConfig parse_segmenter_config(const std::string& text, const SegmenterConfig& base, const std::string& source) {
  SegmenterConfig config = base;
  std::set<std::string> seen;
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::parse_error& e) {
      fail(source + ": not valid JSON: " + e.what());
    }
    if (!j.is_object()) fail(source + ": a JSON config must be one object {\"key\": value, ...}");
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& key = it.key();
      const nlohmann::json& v = it.value();
      std::string value;
      if (v.is_boolean()) value = v.get<bool>() ? "true" : "false";
      else if (v.is_number()) value = v.dump();
      else fail(source + ": " + key + " = " + v.dump() + ": not a number or bool");
      set_segmenter_config_field(&config, key, value, source);
    }
  } else {
    std::istringstream in(text);
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
      const std::string where = source + ":" + std::to_string(number);
      const size_t hash = line.find('#');
      if (hash != std::string::npos) line.resize(hash);
      line = trim(line);
      if (line.empty()) continue;
      const size_t eq = line.find('=');
      if (eq == std::string::npos) fail(where + ": expected 'key = value', got '" + line + "'");
      const std::string key = trim(line.substr(0, eq));
      if (!seen.insert(key).second) fail(where + ": " + key + " set twice");
      set_segmenter_config_field(&config, key, line.substr(eq + 1), where);
    }
  }
  check_segmenter_config_constraints(config, source);
  return config;
}

SegmenterConfig load_segmenter_config_file(const std::string& path, const SegmenterConfig& base) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path + ": cannot read the segmenter config");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_segmenter_config(text.str(), base, path);
}

std::string segmenter_config_table_markdown() {
  std::string out = "| key | type | default | range | unit | meaning |\n|---|---|---|---|---|---|\n";
  for (int i = 0; i < kSegmenterConfigFieldCount; ++i) {
    const SegmenterConfigField& f = kSegmenterConfigFields[i];
    out += std::string("| `") + f.name + "` | " + type_text(f.type) + " | " + default_text(f) + " | " +
           segmenter_config_range_text(i) + " | " + f.unit + " | " + f.meaning + " |\n";
  }
  out += "\nConstraints between keys:";
  for (int k = 0; k < kSegmenterConfigConstraintCount; ++k) {
    const SegmenterConfigConstraint& c = kSegmenterConfigConstraints[k];
    out += std::string(k ? "," : "") + " `" + kSegmenterConfigFields[c.field].name + "` " + relation_text(c.relation) +
           " `" + kSegmenterConfigFields[c.other].name + "`";
  }
  out += ".\n";
  return out;
}

}  // namespace dp::tools
