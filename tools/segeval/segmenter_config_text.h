// Reading and printing dp::SegmenterConfig in the tools (`depthpose run --segment-config`,
// `depthpose segeval --segment-config / --set / --print-config-table`), driven by the field table
// of runtime/segmentation/segmenter_config.h. Strict: an unknown key, a value that is not a
// number of the field's type (parsed with strtod/strtoll, the whole text consumed), a non-finite
// or out-of-range value, a repeated key or a broken constraint throws ToolError naming the key,
// the value and the allowed range, prefixed by where it came from (FILE:LINE, FILE, --set).
#pragma once
#include <string>

#include "runtime/segmentation/segmenter_config.h"

namespace dp::tools {

// Index of field `key` in kSegmenterConfigFields, −1 when there is none.
int segmenter_config_field_index(const std::string& key);
// The allowed values of field `index`, e.g. "[0, 0.5)", "> 0", ">= 0", "true or false".
std::string segmenter_config_range_text(int index);

// Sets field `key` of *config from the text `value` (numbers in C syntax; bools true/false/1/0).
void set_segmenter_config_field(SegmenterConfig* config, const std::string& key, const std::string& value,
                                const std::string& where);
// Throws naming the first constraint between fields (DP_SEGMENTER_CONFIG_RELATIONS) that fails.
void check_segmenter_config_constraints(const SegmenterConfig& config, const std::string& where);

// `base` with the settings of `text` applied, then the constraints checked. Two formats:
//   - a JSON object {"key": value, ...} (when the first non-blank character is '{');
//   - lines `key = value`; blank lines and comments from '#' to the end of a line are ignored.
// `source` names the text in error messages (a file path).
SegmenterConfig parse_segmenter_config(const std::string& text, const SegmenterConfig& base, const std::string& source);
// parse_segmenter_config over the contents of `path` (an unreadable file is an error).
SegmenterConfig load_segmenter_config_file(const std::string& path, const SegmenterConfig& base);

// The Markdown table of every field (name, type, default, range, unit, meaning) followed by the
// constraints: what docs/segmentation.md holds between its config-table markers.
std::string segmenter_config_table_markdown();

}  // namespace dp::tools
