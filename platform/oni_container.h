// Structural check of an OpenNI .oni recording, done by depthpose before OpenNI2's file driver
// (libOniFile) sees the file: libOniFile trusts the lengths it reads and crashes on a corrupt one
// (a property name length of 0x7fffffff, a record running past the end of the file).
//
// Container facts (the format OpenNI2 2.2 writes; all integers little endian):
//   file header, 24 bytes: "NI10", version {u8 major, u8 minor, u16 maintenance, u32 build},
//     u64 max timestamp, u32 max node id.
//   then records, each a 28-byte header {u32 magic "NIR\0", u32 type, u32 node id,
//     u32 fields size (including these 28 bytes), u32 payload size, u64 undo position}, then
//     (fields size − 28) bytes of fields, then payload size bytes of payload:
//     2/12/13 node added: u32 name length, name, u32 node type, u32 codec, u32 frame count,
//                         u64 min timestamp, u64 max timestamp[, u64 seek table position]
//     3/4/5/6 property:   u32 name length, name (NUL-terminated), u32 value size, value
//     7 node removed, 8 node data begin, 9 node state ready: fields only
//     10 new data:        u64 timestamp, u32 frame id; payload = one compressed frame
//     11 end              (the last record)
//     14 seek table:      payload = 20-byte entries {u64 timestamp, u32 config, u64 offset}
// The format has no checksum: a flipped byte inside a frame's compressed payload cannot be
// detected here (the decoded frame's size is still checked when it is read, and `record`
// compares its output with the source). Bytes after the end record must be zero (OpenNI2 2.2's
// recorder leaves the file at twice its length, the second half zeros: `record` trims it).
// Everything else is checked: every length against the
// bytes that remain, names NUL-terminated printable ASCII, node ids within the header's maximum,
// the depth resolution within blob::kMaxFrameDimension, frame records against their node's frame
// count, each frame payload no larger than an uncompressed frame (+ codec tables).
#pragma once
#include <cstdint>
#include <string>

namespace dp::platform {

struct OniContainerSummary {
  int64_t depth_frames = 0;     // new-data records of the depth node
  int width = 0, height = 0;    // from the depth node's xnMapOutputMode property (0 if absent)
  uint64_t file_bytes = 0;
  uint64_t records_end = 0;     // offset just past the end record (= file_bytes when it has none)
};

// Reads `path` (a regular file within tools::limits::kMaxInputFileBytes) and checks its structure.
// Throws ToolError "oni:<path>: not a readable OpenNI2 recording (truncated or corrupt: <what is
// wrong> at byte <offset>)" on the first problem.
OniContainerSummary check_oni_container(const std::string& path);

// The same on bytes in memory (`label` names them in messages); used by the fuzz target.
OniContainerSummary check_oni_bytes(const uint8_t* data, size_t size, const std::string& label);

}  // namespace dp::platform
