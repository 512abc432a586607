// Structural check and frame index of an OpenNI .oni recording. depthpose plays recordings from
// this index with its own decoders (platform/oni_codec.h, open_oni_source); where OpenNI2's file
// driver (libOniFile) still reads one (`record` verifying its output, open_openni_oni_source) the
// check comes first: libOniFile trusts the lengths it reads and crashes on a corrupt one (a
// property name length of 0x7fffffff, a record running past the end of the file).
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
// Everything is checked: every length against the bytes that remain, names NUL-terminated
// printable ASCII, node ids within the header's maximum, the depth resolution within
// blob::kMaxFrameDimension, the depth codec (NONE, 16zP, 16zT: platform/oni_codec.h) and pixel
// format (oniPixelFormat 100 = 1 mm or 101 = 100 µm), frame records against their node's frame
// count and kMaxOniFrames, each depth payload against the largest its codec can write for the
// declared resolution (exactly width·height·2 bytes uncompressed), seek table entries against the
// file, the end record present. After the end record comes either nothing, zeros (OpenNI2 2.2's
// recorder leaves the file at twice its length, the second half zeros: `record` trims it), or
// depthpose's integrity trailer (below); any other byte there is refused.
//
// The OpenNI format has no checksum: in a file written by another tool a flipped byte inside a
// compressed payload is found only when it breaks the code (platform/oni_codec.h: a code never
// written, a frame of the wrong pixel count), not when it changes a depth value. `depthpose
// record` therefore appends an integrity trailer after the end record (OpenNI2's player stops at
// the end record and ignores it; checked with libOniFile 2.2.0.33), all integers little endian:
//   trailer, 20 + 4·N bytes, starting right after the end record:
//     u8[8] "DPONICRC", u32 format version (1), u32 N = depth frame count,
//     N × u32 CRC-32 of each depth frame record's payload (the compressed bytes as stored, in
//     record order), u32 CRC-32 of the trailer's preceding 16 + 4·N bytes;
//   footer, 12 bytes, the file's last: u32 trailer length (20 + 4·N), u8[8] "DPONIEND".
// CRC-32 is forest_blob's (IEEE 802.3, reflected, as zlib's crc32). When the footer is present
// the trailer is validated at open (its CRC, version, length, N against the indexed frames);
// a file whose bytes after the end record begin with "DPONICRC" but lack the footer is refused
// as a truncated trailer. Each frame's payload CRC is checked when the frame is read.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace dp::platform {

// The most depth frames a recording may hold: 4·10⁶ (37 h at 30 frames/s; the frame index of
// OniFrameRecord costs 32 bytes a frame, 128 MB at the limit). A longer file is refused at open.
constexpr int64_t kMaxOniFrames = 4000000;

// OpenNI pixel formats of the depth node's oniPixelFormat property.
constexpr int kOniPixelFormatDepth1mm = 100;
constexpr int kOniPixelFormatDepth100um = 101;

// Where one depth frame lies in the file.
struct OniFrameRecord {
  uint64_t record_offset = 0;   // the new-data record's first byte (for messages)
  uint64_t payload_offset = 0;  // the compressed frame's first byte
  uint32_t payload_bytes = 0;
  uint32_t frame_id = 0;        // as recorded (1-based in OpenNI2 recordings)
  uint64_t timestamp_us = 0;
  uint32_t payload_crc32 = 0;   // from the integrity trailer (0 without one)
};

// The integrity trailer's fixed parts (layout above).
constexpr char kOniTrailerMagic[8] = {'D', 'P', 'O', 'N', 'I', 'C', 'R', 'C'};
constexpr char kOniFooterMagic[8] = {'D', 'P', 'O', 'N', 'I', 'E', 'N', 'D'};
constexpr uint32_t kOniTrailerVersion = 1;
constexpr size_t kOniTrailerFixedBytes = 20;  // magic, version, N, trailer CRC
constexpr size_t kOniFooterBytes = 12;

struct OniContainerSummary {
  int64_t depth_frames = 0;     // new-data records of the depth node
  int width = 0, height = 0;    // from the depth node's xnMapOutputMode property (0 if absent)
  uint32_t codec = 0;           // the depth node's codec FourCC (platform/oni_codec.h)
  int pixel_format = kOniPixelFormatDepth1mm;  // oniPixelFormat (1 mm when absent)
  bool has_fov = false;         // the depth node's xnFOV property: field of view in radians
  double horizontal_fov = 0, vertical_fov = 0;
  uint64_t file_bytes = 0;
  uint64_t records_end = 0;     // offset just past the end record (zeros or the trailer may follow)
  bool integrity_trailer = false;  // a valid trailer follows the end record (frames carry payload CRCs)
  uint64_t trailer_offset = 0;     // its first byte (== records_end) when present
};

// A recording mapped read-only (the whole file, for the object's lifetime): the walk touches only
// the record headers and a player only the frames it decodes, so a long recording costs the pages
// used, not its size. Throws ToolError "<label>: cannot open the file (...)" / "not a regular
// file" / "cannot map the file (...)". An empty file maps to data() == nullptr, size() == 0.
class MappedOniFile {
 public:
  MappedOniFile(const std::string& path, const std::string& label);
  ~MappedOniFile();
  MappedOniFile(const MappedOniFile&) = delete;
  MappedOniFile& operator=(const MappedOniFile&) = delete;
  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

// Maps `path` (a regular file; only the record headers are touched) and checks its structure.
// Throws ToolError "oni:<path>: not a readable OpenNI2 recording (truncated or corrupt: <what is
// wrong> at byte <offset>)" on the first problem.
OniContainerSummary check_oni_container(const std::string& path);

// The same on bytes in memory (`label` names them in messages); used by the fuzz target and the
// reader. With `frames`, the depth frames' records are appended to it in file order (with their
// payload CRCs when the trailer is present). A bad trailer throws "<label>: not a readable OpenNI2
// recording (corrupt integrity trailer: <field ...> at byte <offset>)".
OniContainerSummary check_oni_bytes(const uint8_t* data, size_t size, const std::string& label,
                                    std::vector<OniFrameRecord>* frames = nullptr);

// The integrity trailer and footer (layout above) for the depth frames `frames` of the recording
// `data` (as indexed by check_oni_bytes on a file without a trailer): the bytes to append after
// its end record.
std::vector<uint8_t> oni_integrity_trailer(const uint8_t* data, const std::vector<OniFrameRecord>& frames);

// The CRC-32 of one depth frame's stored payload, as the trailer records it.
uint32_t oni_payload_crc32(const uint8_t* data, const OniFrameRecord& frame);

// Empty when `summary` has no integrity trailer or frame `index` (`frame`, indexed from `data`)
// still has the payload CRC-32 the trailer records; else what differs: "payload CRC-32 0x… differs
// from the integrity trailer's 0x… at byte B: a payload byte within P..Q changed".
std::string oni_payload_crc_mismatch(const uint8_t* data, const OniContainerSummary& summary,
                                     const OniFrameRecord& frame, size_t index);

}  // namespace dp::platform
