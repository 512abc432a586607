#include "platform/oni_container.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <vector>

#include "forest_blob/blob_format.h"
#include "forest_blob/blob_loader.h"
#include "platform/oni_codec.h"
#include "tools/common/error.h"

namespace dp::platform {

namespace {

constexpr uint32_t kRecordMagic = 0x0052494Eu;  // "NIR\0"
constexpr size_t kFileHeaderBytes = 24;
constexpr size_t kRecordHeaderBytes = 28;
constexpr uint32_t kMaxNodeId = 64;            // a recording holds a handful of streams
constexpr uint32_t kMaxNameBytes = 256;        // property and node names are short identifiers

enum RecordType : uint32_t {
  kNodeAdded_1_0_0_4 = 2, kIntProperty = 3, kRealProperty = 4, kStringProperty = 5, kGeneralProperty = 6,
  kNodeRemoved = 7, kNodeDataBegin = 8, kNodeStateReady = 9, kNewData = 10, kEnd = 11,
  kNodeAdded_1_0_0_5 = 12, kNodeAdded = 13, kSeekTable = 14,
};
constexpr uint32_t kNodeTypeDepth = 2;

struct Cursor {
  const uint8_t* data;
  size_t size;
  const std::string& label;
  [[noreturn]] void bad(const std::string& what, uint64_t at) const {
    tools::fail(label + ": not a readable OpenNI2 recording (truncated or corrupt: " + what + " at byte " +
                std::to_string(at) + ")");
  }
  [[noreturn]] void bad_trailer(const std::string& what, uint64_t at) const {
    tools::fail(label + ": not a readable OpenNI2 recording (corrupt integrity trailer: " + what + " at byte " +
                std::to_string(at) + ")");
  }
  uint32_t u32(uint64_t at) const {
    uint32_t v;
    std::memcpy(&v, data + at, 4);
    return v;
  }
  uint64_t u64(uint64_t at) const {
    uint64_t v;
    std::memcpy(&v, data + at, 8);
    return v;
  }
};

struct Node {
  bool added = false;
  uint32_t type = 0, codec = 0;
  int64_t declared_frames = 0, frames = 0;
};

// A u32-length-prefixed NUL-terminated printable name inside [at, end); returns the offset after it.
uint64_t check_name(const Cursor& c, uint64_t at, uint64_t end, std::string* name) {
  if (end - at < 4) c.bad("name length beyond its record", at);
  const uint32_t n = c.u32(at);
  if (n < 1 || n > kMaxNameBytes || n > end - at - 4)
    c.bad("name length " + std::to_string(n) + " (1.." + std::to_string(kMaxNameBytes) + " within the record)", at);
  const uint8_t* s = c.data + at + 4;
  if (s[n - 1] != 0) c.bad("name not NUL-terminated", at + 4);
  for (uint32_t k = 0; k + 1 < n; ++k)
    if (s[k] < 0x20 || s[k] > 0x7E) c.bad("name byte " + std::to_string(s[k]) + " not printable ASCII", at + 4 + k);
  name->assign(reinterpret_cast<const char*>(s), n - 1);
  return at + 4 + n;
}

std::string hex32(uint32_t v) {
  char text[11];
  std::snprintf(text, sizeof text, "0x%08x", v);
  return text;
}

// What follows the end record at `at`: nothing, zeros, or the integrity trailer and its footer
// (oni_container.h), which is validated and, with `frames`, gives the frames from `first_frame` on
// their payload CRCs.
void check_tail(const Cursor& c, uint64_t at, OniContainerSummary* out, std::vector<OniFrameRecord>* frames,
                size_t first_frame) {
  const uint64_t size = c.size, rest = size - at;
  const bool footer = rest >= kOniFooterBytes && std::memcmp(c.data + size - 8, kOniFooterMagic, 8) == 0;
  if (!footer) {
    if (rest > 0 && std::memcmp(c.data + at, kOniTrailerMagic, size_t(std::min<uint64_t>(rest, 8))) == 0)
      c.bad_trailer("footer \"DPONIEND\" missing (the trailer is truncated: the file ends " + std::to_string(rest) +
                        " bytes after the end record)",
                    size);
    for (uint64_t k = at; k < size; ++k)
      if (c.data[k] != 0) c.bad("data after the end record", k);
    return;
  }
  const uint64_t footer_at = size - kOniFooterBytes, between = footer_at - at;
  const uint32_t length = c.u32(footer_at);
  if (length != between)
    c.bad_trailer("trailer length " + std::to_string(length) + " in the footer disagrees with the " +
                      std::to_string(between) + " bytes between the end record and the footer",
                  footer_at);
  if (length < kOniTrailerFixedBytes || (length - kOniTrailerFixedBytes) % 4 != 0)
    c.bad_trailer("trailer length " + std::to_string(length) + " (20 + 4 per frame expected)", footer_at);
  if (std::memcmp(c.data + at, kOniTrailerMagic, 8) != 0) c.bad_trailer("magic is not \"DPONICRC\"", at);
  const uint64_t crc_at = at + length - 4;
  const uint32_t stored = c.u32(crc_at), computed = blob::crc32(c.data + at, length - 4);
  if (stored != computed)
    c.bad_trailer("trailer CRC-32 " + hex32(stored) + " but its " + std::to_string(length - 4) + " bytes give " +
                      hex32(computed),
                  crc_at);
  const uint32_t version = c.u32(at + 8);
  if (version != kOniTrailerVersion)
    c.bad_trailer("format version " + std::to_string(version) + " (this build reads " +
                      std::to_string(kOniTrailerVersion) + ")",
                  at + 8);
  const uint32_t count = c.u32(at + 12);
  if (uint64_t(count) != (length - kOniTrailerFixedBytes) / 4)
    c.bad_trailer("frame count " + std::to_string(count) + " disagrees with the trailer length " + std::to_string(length),
                  at + 12);
  if (int64_t(count) != out->depth_frames)
    c.bad_trailer("frame count " + std::to_string(count) + " but the file holds " + std::to_string(out->depth_frames) +
                      " depth frames",
                  at + 12);
  if (frames)
    for (uint32_t i = 0; i < count; ++i) (*frames)[first_frame + i].payload_crc32 = c.u32(at + 16 + 4 * uint64_t(i));
  out->integrity_trailer = true;
  out->trailer_offset = at;
}

}  // namespace

OniContainerSummary check_oni_bytes(const uint8_t* data, size_t size, const std::string& label,
                                    std::vector<OniFrameRecord>* frames) {
  const Cursor c{data, size, label};
  OniContainerSummary out;
  out.file_bytes = size;
  if (size < kFileHeaderBytes) c.bad("file shorter than the 24-byte header", 0);
  if (std::memcmp(data, "NI10", 4) != 0) c.bad("not an OpenNI recording (magic is not \"NI10\")", 0);
  if (data[4] != 1) c.bad("unsupported version " + std::to_string(data[4]) + " (this build reads 1)", 4);
  const uint32_t max_node = c.u32(20);
  if (max_node > kMaxNodeId) c.bad("max node id " + std::to_string(max_node) + " above " + std::to_string(kMaxNodeId), 20);
  std::vector<Node> nodes(max_node + 1);
  const size_t first_frame = frames ? frames->size() : 0;
  uint32_t depth_node = 0;
  bool ended = false;
  uint64_t at = kFileHeaderBytes;
  while (at < size && !ended) {
    if (size - at < kRecordHeaderBytes) c.bad("record header truncated", at);
    if (c.u32(at) != kRecordMagic) c.bad("record magic is not \"NIR\"", at);
    const uint32_t type = c.u32(at + 4), node_id = c.u32(at + 8), fields = c.u32(at + 12), payload = c.u32(at + 16);
    if (type < kNodeAdded_1_0_0_4 || type > kSeekTable) c.bad("unknown record type " + std::to_string(type), at + 4);
    if (node_id > max_node) c.bad("node id " + std::to_string(node_id) + " above the header's " + std::to_string(max_node), at + 8);
    if (fields < kRecordHeaderBytes || fields > size - at)
      c.bad("record fields size " + std::to_string(fields) + " beyond the file", at + 12);
    if (payload > size - at - fields) c.bad("record payload size " + std::to_string(payload) + " beyond the file", at + 16);
    if (c.u64(at + 20) > size) c.bad("undo position beyond the file", at + 20);
    const uint64_t body = at + kRecordHeaderBytes, body_end = at + fields;
    Node& node = nodes[node_id];
    std::string name;
    switch (type) {
      case kNodeAdded_1_0_0_4:
      case kNodeAdded_1_0_0_5:
      case kNodeAdded: {
        const uint64_t p = check_name(c, body, body_end, &name);
        const uint64_t need = type == kNodeAdded ? 36 : type == kNodeAdded_1_0_0_5 ? 28 : 12;
        if (body_end - p < need) c.bad("node record shorter than its fields", p);
        if (node.added) c.bad("node " + std::to_string(node_id) + " added twice", at);
        node.added = true;
        node.type = c.u32(p);
        node.codec = c.u32(p + 4);
        if (type != kNodeAdded_1_0_0_4) node.declared_frames = c.u32(p + 8);
        if (node.type == kNodeTypeDepth && !depth_node) {
          depth_node = node_id;
          if (!oni_codec_supported(node.codec))
            c.bad("depth codec '" + oni_codec_name(node.codec) + "' (this build reads NONE, 16zP and 16zT)", p + 4);
          if (node.declared_frames > kMaxOniFrames)
            c.bad("depth frame count " + std::to_string(node.declared_frames) + " above the limit " +
                      std::to_string(kMaxOniFrames),
                  p + 8);
          out.codec = node.codec;
        }
        break;
      }
      case kIntProperty:
      case kRealProperty:
      case kStringProperty:
      case kGeneralProperty: {
        uint64_t p = check_name(c, body, body_end, &name);
        if (body_end - p < 4) c.bad("property value size beyond its record", p);
        const uint32_t value = c.u32(p);
        if (value != body_end - p - 4)
          c.bad("property '" + name + "' value size " + std::to_string(value) + " disagrees with its record", p);
        if ((type == kIntProperty || type == kRealProperty) && value != 8)
          c.bad("numeric property '" + name + "' of " + std::to_string(value) + " bytes (8 expected)", p);
        if (name == "xnMapOutputMode" && node_id == depth_node && depth_node) {
          if (value < 8) c.bad("xnMapOutputMode shorter than width and height", p);
          const uint32_t w = c.u32(p + 4), h = c.u32(p + 8);
          if (w < 1 || h < 1 || w > uint32_t(blob::kMaxFrameDimension) || h > uint32_t(blob::kMaxFrameDimension))
            c.bad("depth resolution " + std::to_string(w) + "x" + std::to_string(h) + " outside 1.." +
                      std::to_string(blob::kMaxFrameDimension),
                  p + 4);
          if (out.depth_frames)
            c.bad("xnMapOutputMode changes the depth resolution after the first frame", p + 4);
          out.width = int(w);
          out.height = int(h);
        }
        if (node_id == depth_node && depth_node) {
          if (name == "oniPixelFormat") {
            if (value != 8) c.bad("oniPixelFormat of " + std::to_string(value) + " bytes (8 expected)", p);
            const uint64_t format = c.u64(p + 4);
            if (format != uint64_t(kOniPixelFormatDepth1mm) && format != uint64_t(kOniPixelFormatDepth100um))
              c.bad("depth pixel format " + std::to_string(format) +
                        " (100 = 1 mm or 101 = 100 µm; raw shift formats are not supported)",
                    p + 4);
            out.pixel_format = int(format);
          } else if (name == "xnFOV") {
            if (value != 16) c.bad("xnFOV of " + std::to_string(value) + " bytes (two doubles expected)", p);
            std::memcpy(&out.horizontal_fov, data + p + 4, 8);
            std::memcpy(&out.vertical_fov, data + p + 12, 8);
            out.has_fov = true;
          }
        }
        break;
      }
      case kNewData: {
        if (fields - kRecordHeaderBytes < 12) c.bad("frame record without timestamp and frame id", body);
        if (!node.added) c.bad("frame of node " + std::to_string(node_id) + " before the node was added", at);
        ++node.frames;
        if (node.declared_frames && node.frames > node.declared_frames)
          c.bad("more frames than node " + std::to_string(node_id) + " declares (" +
                    std::to_string(node.declared_frames) + ")",
                at);
        if (node_id == depth_node) {
          // The largest payload the codec writes for the declared resolution (the exact size for
          // NONE): a frame of another resolution is refused here or when it is decoded.
          const uint64_t pixels = uint64_t(out.width ? out.width : blob::kMaxFrameDimension) *
                                  uint64_t(out.height ? out.height : blob::kMaxFrameDimension);
          const uint64_t most = max_oni_payload_bytes(node.codec, pixels);
          const bool exact = node.codec == kOniCodecUncompressed && out.width;
          if (payload == 0 || payload > most || (exact && payload != most))
            c.bad("depth frame payload of " + std::to_string(payload) + " bytes for a " +
                      (out.width ? std::to_string(out.width) + "x" + std::to_string(out.height) : std::string("")) +
                      " " + oni_codec_name(node.codec) + " frame (" + (exact ? "exactly " : "at most ") +
                      std::to_string(most) + ")",
                  at + 16);
          if (out.depth_frames >= kMaxOniFrames)
            c.bad("more than " + std::to_string(kMaxOniFrames) + " depth frames (the limit)", at);
          ++out.depth_frames;
          if (frames)
            frames->push_back(OniFrameRecord{at, body_end, payload, c.u32(body + 8), c.u64(body)});
        }
        break;
      }
      case kSeekTable:
        if (payload % 20 != 0) c.bad("seek table size " + std::to_string(payload) + " not a multiple of 20", at + 16);
        for (uint64_t e = body_end; e + 20 <= body_end + payload; e += 20)
          if (c.u64(e + 12) >= size) c.bad("seek table entry points beyond the file", e + 12);
        break;
      case kEnd:
        ended = true;
        break;
      default:
        break;
    }
    at = body_end + payload;
  }
  if (!depth_node) c.bad("no depth stream", at);
  // OpenNI2's recorder always ends a file with an end record; without one the file was cut short.
  if (!ended) c.bad("no end record (the file ends after " + std::to_string(out.depth_frames) + " depth frames)", at);
  out.records_end = at;
  if (out.depth_frames == 0) c.bad("the depth stream holds no frame", at);
  const Node& d = nodes[depth_node];
  if (d.declared_frames && d.frames != d.declared_frames)
    c.bad("depth node declares " + std::to_string(d.declared_frames) + " frames but holds " + std::to_string(d.frames), at);
  check_tail(c, at, &out, frames, first_frame);
  return out;
}

uint32_t oni_payload_crc32(const uint8_t* data, const OniFrameRecord& frame) {
  return blob::crc32(data + frame.payload_offset, frame.payload_bytes);
}

std::string oni_payload_crc_mismatch(const uint8_t* data, const OniContainerSummary& summary,
                                     const OniFrameRecord& frame, size_t index) {
  if (!summary.integrity_trailer) return {};
  const uint32_t crc = oni_payload_crc32(data, frame);
  if (crc == frame.payload_crc32) return {};
  return "payload CRC-32 " + hex32(crc) + " differs from the integrity trailer's " + hex32(frame.payload_crc32) +
         " at byte " + std::to_string(summary.trailer_offset + 16 + 4 * uint64_t(index)) +
         ": a payload byte within " + std::to_string(frame.payload_offset) + ".." +
         std::to_string(frame.payload_offset + frame.payload_bytes - 1) + " changed";
}

std::vector<uint8_t> oni_integrity_trailer(const uint8_t* data, const std::vector<OniFrameRecord>& frames) {
  std::vector<uint8_t> out(kOniTrailerMagic, kOniTrailerMagic + 8);
  auto u32 = [&](uint32_t v) {
    for (int k = 0; k < 4; ++k) out.push_back(uint8_t(v >> (8 * k)));
  };
  u32(kOniTrailerVersion);
  u32(uint32_t(frames.size()));  // at most kMaxOniFrames: the walk refuses more
  for (const OniFrameRecord& f : frames) u32(oni_payload_crc32(data, f));
  u32(blob::crc32(out.data(), out.size()));
  const uint32_t length = uint32_t(out.size());
  u32(length);
  out.insert(out.end(), kOniFooterMagic, kOniFooterMagic + 8);
  return out;
}

MappedOniFile::MappedOniFile(const std::string& path, const std::string& label) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) tools::fail(label + ": cannot open the file (" + std::strerror(errno) + ")");
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    tools::fail(label + ": not a regular file");
  }
  size_ = size_t(st.st_size);
  if (size_ > 0) {
    void* map = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (map == MAP_FAILED) {
      ::close(fd);
      tools::fail(label + ": cannot map the file (" + std::strerror(errno) + ")");
    }
    data_ = static_cast<const uint8_t*>(map);
  }
  ::close(fd);
}

MappedOniFile::~MappedOniFile() {
  if (data_) ::munmap(const_cast<uint8_t*>(data_), size_);
}

OniContainerSummary check_oni_container(const std::string& path) {
  const MappedOniFile file(path, "oni:" + path);
  return check_oni_bytes(file.data(), file.size(), "oni:" + path);  // an empty file: shorter than the header
}

}  // namespace dp::platform
