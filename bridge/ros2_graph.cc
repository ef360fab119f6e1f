#include "bridge/ros2_graph.h"

#include <cctype>
#include <cstring>

#include "core/base/error.h"

namespace dygslam::ros2 {

RosDistro ParseRosDistro(const std::string& text, const std::string& option) {
  if (text == "humble") return RosDistro::kHumble;
  if (text == "jazzy" || text == "iron" || text == "kilted" || text == "rolling") {
    return RosDistro::kJazzy;
  }
  throw InvalidOptions("invalid option " + option + ": '" + text +
                       "' (humble | jazzy; iron, kilted and rolling as jazzy)");
}

const char* RosDistroName(RosDistro distro) {
  return distro == RosDistro::kHumble ? "humble" : "jazzy";
}

size_t GidSize(RosDistro distro) { return distro == RosDistro::kHumble ? 24 : 16; }

namespace {

bool IsTokenChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// The bound of string<=256 in NodeEntitiesInfo.
constexpr size_t kMaxNameLength = 256;

// Little-endian CDR writer; alignment relative to the body (after the encapsulation header).
class CdrWriter {
 public:
  CdrWriter() { bytes_ = {0x00, 0x01, 0x00, 0x00}; }  // CDR_LE, options 0
  void U32(uint32_t v) {
    Align(4);
    for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<uint8_t>(v >> (8 * i)));
  }
  void String(const std::string& s) {
    U32(static_cast<uint32_t>(s.size() + 1));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
    bytes_.push_back(0);
  }
  void Gid(const Guid& guid, size_t size) {
    // char[N]: no alignment, N bytes; the GUID first, zero padding after.
    for (size_t i = 0; i < size; ++i) bytes_.push_back(i < guid.size() ? guid[i] : 0);
  }
  std::vector<uint8_t> Take() { return std::move(bytes_); }

 private:
  void Align(size_t n) {
    while ((bytes_.size() - 4) % n != 0) bytes_.push_back(0);
  }
  std::vector<uint8_t> bytes_;
};

}  // namespace

void CheckNodeName(const std::string& name, const std::string& option) {
  bool ok = !name.empty() && name.size() < kMaxNameLength &&
            !std::isdigit(static_cast<unsigned char>(name[0]));
  for (char c : name) ok = ok && IsTokenChar(c);
  if (!ok) {
    throw InvalidOptions("invalid option " + option + ": '" + name +
                         "' (a ROS 2 node name: letters, digits and '_', not starting with a "
                         "digit, at most 255 characters)");
  }
}

void CheckNodeNamespace(const std::string& ns, const std::string& option) {
  bool ok = !ns.empty() && ns[0] == '/' && ns.size() <= kMaxNameLength &&
            (ns.size() == 1 || ns.back() != '/');
  for (size_t i = 1; ok && i < ns.size(); ++i) {
    const char c = ns[i];
    if (c == '/') {
      ok = ns[i - 1] != '/';
    } else {
      ok = IsTokenChar(c) && !(ns[i - 1] == '/' && std::isdigit(static_cast<unsigned char>(c)));
    }
  }
  if (!ok) {
    throw InvalidOptions("invalid option " + option + ": '" + ns +
                         "' (a ROS 2 namespace: '/' or '/a/b', tokens of letters, digits and "
                         "'_' not starting with a digit)");
  }
}

std::vector<uint8_t> EncodeParticipantEntitiesInfo(const RosParticipantEntities& info,
                                                   RosDistro distro) {
  const size_t gid = GidSize(distro);
  CdrWriter w;
  w.Gid(info.participant, gid);
  w.U32(static_cast<uint32_t>(info.nodes.size()));
  for (const RosNodeEntities& node : info.nodes) {
    w.String(node.node_namespace);
    w.String(node.node_name);
    w.U32(static_cast<uint32_t>(node.readers.size()));
    for (const Guid& g : node.readers) w.Gid(g, gid);
    w.U32(static_cast<uint32_t>(node.writers.size()));
    for (const Guid& g : node.writers) w.Gid(g, gid);
  }
  return w.Take();
}

}  // namespace dygslam::ros2
