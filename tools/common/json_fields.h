// Checked reads of integer fields from nlohmann::json values.
//
// nlohmann's get<int>() converts a JSON float with a C++ cast: 3.8e26 becomes undefined behaviour,
// 2.5 silently becomes 2, and a uint64 beyond int's range wraps. Every integer field the tools read
// from a file (dataset meta.json, forest and checkpoint headers) goes through json_integer instead:
// the value must be a JSON integer (no fraction, no exponent form) within [lo, hi], or ToolError
// names the field, the value and the range.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "tools/common/error.h"

namespace dp::tools {

// `v` as an integer in [lo, hi]; `what` names the field in the error ("meta.json: width").
inline int64_t json_integer(const nlohmann::json& v, int64_t lo, int64_t hi, const std::string& what) {
  const std::string range = " (expected an integer in " + std::to_string(lo) + ".." + std::to_string(hi) + ")";
  if (v.is_number_unsigned()) {
    const uint64_t u = v.get<uint64_t>();
    if (hi < 0 || u > uint64_t(hi) || (lo > 0 && u < uint64_t(lo))) fail(what + " = " + std::to_string(u) + " is out of range" + range);
    return int64_t(u);
  }
  if (v.is_number_integer()) {
    const int64_t s = v.get<int64_t>();
    if (s < lo || s > hi) fail(what + " = " + std::to_string(s) + " is out of range" + range);
    return s;
  }
  fail(what + " is " + (v.is_number() ? "not a whole number: " + v.dump() : std::string(v.type_name())) + range);
}

// The integer field `key` of object `o`; missing fields are an error.
inline int64_t json_integer_field(const nlohmann::json& o, const char* key, int64_t lo, int64_t hi,
                                  const std::string& where) {
  if (!o.is_object() || !o.contains(key)) fail(where + ": missing field \"" + key + "\"");
  return json_integer(o.at(key), lo, hi, where + ": \"" + key + "\"");
}

}  // namespace dp::tools
