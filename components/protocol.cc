#include "components/protocol.h"

#include <signal.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <sstream>

#include "core/base/error.h"

namespace dygslam {

namespace {

// The names on the wire (StreamStatus.source, the "writers" detail) and in logs.
template <class Enum>
struct Name {
  Enum value;
  const char* name;
};
constexpr Name<ComponentKind> kKindNames[] = {
    {ComponentKind::kPlayer, "player"},     {ComponentKind::kDetector, "detector"},
    {ComponentKind::kSlam, "slam"},         {ComponentKind::kMapper, "mapper"},
    {ComponentKind::kRecorder, "recorder"}, {ComponentKind::kRos2Bridge, "ros2_bridge"}};
constexpr Name<StreamEvent> kEventNames[] = {{StreamEvent::kStarted, "STARTED"},
                                             {StreamEvent::kEndOfStream, "END_OF_STREAM"},
                                             {StreamEvent::kComponentDone, "COMPONENT_DONE"},
                                             {StreamEvent::kMapLoaded, "MAP_LOADED"},
                                             {StreamEvent::kReady, "READY"},
                                             {StreamEvent::kFailed, "FAILED"}};
constexpr Name<DataTopic> kTopicNames[] = {
    {DataTopic::kFrames, "frames"},          {DataTopic::kDetections, "detections"},
    {DataTopic::kCameraPose, "camera_pose"}, {DataTopic::kKeyframe, "keyframe"},
    {DataTopic::kTrajectory, "trajectory"},  {DataTopic::kGroundTruth, "ground_truth"},
    {DataTopic::kMapUpdate, "map_update"}};

template <class Enum, size_t N>
const char* NameOf(const Name<Enum> (&names)[N], Enum value) {
  for (const Name<Enum>& n : names) {
    if (n.value == value) return n.name;
  }
  return "?";
}

template <class Enum, size_t N>
std::optional<Enum> ValueOf(const Name<Enum> (&names)[N], const std::string& name) {
  for (const Name<Enum>& n : names) {
    if (name == n.name) return n.value;
  }
  return std::nullopt;
}
constexpr const char* kWritersTag = "writers";
constexpr const char* kMapTag = "map";
// Longest text echoed from a message into an error.
constexpr size_t kMaxEcho = 80;

std::string Echo(const std::string& text) {
  return text.size() <= kMaxEcho ? text : text.substr(0, kMaxEcho) + "...";
}

std::optional<DataTopic> DataTopicFromName(const std::string& name) {
  return ValueOf(kTopicNames, name);
}

}  // namespace

std::string ToHex(const WriterGuid& guid) {
  static const char* kDigits = "0123456789abcdef";
  std::string out;
  out.reserve(32);
  for (uint8_t b : guid) {
    out.push_back(kDigits[b >> 4]);
    out.push_back(kDigits[b & 15]);
  }
  return out;
}

std::optional<WriterGuid> WriterGuidFromHex(const std::string& hex) {
  if (hex.size() != 32) return std::nullopt;
  auto digit = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  WriterGuid guid{};
  for (size_t i = 0; i < guid.size(); ++i) {
    const int hi = digit(hex[2 * i]), lo = digit(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) return std::nullopt;
    guid[i] = static_cast<uint8_t>(hi * 16 + lo);
  }
  return guid;
}

const char* ToString(ComponentKind kind) { return NameOf(kKindNames, kind); }

std::optional<ComponentKind> ComponentKindFromName(const std::string& name) {
  return ValueOf(kKindNames, name);
}

std::string PipelineComponentNames() { return "player | detector | slam | mapper | recorder"; }

bool FailureStopsPipeline(ComponentKind kind) {
  return IsFrameSource(kind) || kind == ComponentKind::kSlam;
}

bool FailureFailsRun(ComponentKind kind) { return kind != ComponentKind::kDetector; }

bool WritesOutputs(ComponentKind kind) {
  return kind == ComponentKind::kRecorder || kind == ComponentKind::kMapper;
}

bool IsFrameSource(ComponentKind kind) {
  return kind == ComponentKind::kPlayer || kind == ComponentKind::kRos2Bridge;
}

const char* ToString(StreamEvent event) { return NameOf(kEventNames, event); }

const char* ToString(DataTopic topic) { return NameOf(kTopicNames, topic); }

ComponentStatus ComponentStatus::Started(ComponentKind source,
                                         std::map<DataTopic, WriterGuid> writers,
                                         uint64_t num_frames) {
  ComponentStatus s;
  s.event = StreamEvent::kStarted;
  s.source = source;
  s.writers = std::move(writers);
  s.num_frames = num_frames;
  return s;
}

ComponentStatus ComponentStatus::Ready(ComponentKind source) {
  ComponentStatus s;
  s.event = StreamEvent::kReady;
  s.source = source;
  return s;
}

ComponentStatus ComponentStatus::EndOfStream(ComponentKind source, uint64_t num_frames,
                                             uint64_t last_seq) {
  ComponentStatus s;
  s.event = StreamEvent::kEndOfStream;
  s.source = source;
  s.num_frames = num_frames;
  s.seq = last_seq;
  return s;
}

ComponentStatus ComponentStatus::Done(ComponentKind source, uint64_t num_frames,
                                      std::string cut_short) {
  ComponentStatus s;
  s.event = StreamEvent::kComponentDone;
  s.source = source;
  s.num_frames = num_frames;
  s.reason = std::move(cut_short);
  return s;
}

ComponentStatus ComponentStatus::Failed(ComponentKind source, std::string reason) {
  ComponentStatus s;
  s.event = StreamEvent::kFailed;
  s.source = source;
  s.reason = std::move(reason);
  return s;
}

ComponentStatus ComponentStatus::MapLoaded(ComponentKind source, uint64_t keyframes,
                                           uint64_t checksum, std::string path) {
  ComponentStatus s;
  s.event = StreamEvent::kMapLoaded;
  s.source = source;
  s.num_frames = keyframes;
  s.map_checksum = checksum;
  s.map_path = std::move(path);
  return s;
}

msg::StreamStatus ToMsg(const ComponentStatus& status) {
  msg::StreamStatus m;
  m.kind(static_cast<uint8_t>(status.event));
  m.source(ToString(status.source));
  m.num_frames(status.num_frames);
  m.header().seq(status.seq);
  std::string detail;
  switch (status.event) {
    case StreamEvent::kStarted:
      if (!status.writers.empty()) {
        detail = kWritersTag;
        for (const auto& [topic, guid] : status.writers) {
          detail += std::string(" ") + ToString(topic) + "=" + ToHex(guid);
        }
      }
      break;
    case StreamEvent::kFailed:
    case StreamEvent::kComponentDone:
      detail = status.reason;
      break;
    case StreamEvent::kMapLoaded: {
      char id[32];
      std::snprintf(id, sizeof(id), "%016llx",
                    static_cast<unsigned long long>(status.map_checksum));
      detail = std::string(kMapTag) + " " + id + " " + status.map_path;
      break;
    }
    default:
      break;
  }
  m.header().frame_id(detail);
  return m;
}

ComponentStatus StatusFromMsg(const msg::StreamStatus& m) {
  const auto source = ComponentKindFromName(m.source());
  if (!source) {
    throw InputError("StreamStatus.source: unknown component '" + Echo(m.source()) + "' (" +
                     PipelineComponentNames() + " | ros2_bridge)");
  }
  if (m.kind() > static_cast<uint8_t>(StreamEvent::kFailed)) {
    throw InputError("StreamStatus.kind: " + std::to_string(m.kind()) +
                     " is not a status kind (0..5)");
  }
  ComponentStatus s;
  s.event = static_cast<StreamEvent>(m.kind());
  s.source = *source;
  s.num_frames = m.num_frames();
  s.seq = m.header().seq();
  const std::string& detail = m.header().frame_id();
  switch (s.event) {
    case StreamEvent::kStarted: {
      if (detail.empty()) break;  // a component that announces no data writers
      std::istringstream in(detail);
      std::string tag, item;
      in >> tag;
      if (tag != kWritersTag) {
        throw InputError("StreamStatus.header.frame_id: STARTED detail '" + Echo(detail) +
                         "' does not start with 'writers'");
      }
      while (in >> item) {
        const size_t eq = item.find('=');
        const auto topic =
            eq == std::string::npos ? std::nullopt : DataTopicFromName(item.substr(0, eq));
        const auto guid =
            eq == std::string::npos ? std::nullopt : WriterGuidFromHex(item.substr(eq + 1));
        if (!topic || !guid) {
          throw InputError("StreamStatus.header.frame_id: STARTED writer '" + Echo(item) +
                           "' is not <topic>=<32 hex digits>");
        }
        s.writers[*topic] = *guid;
      }
      break;
    }
    case StreamEvent::kFailed:
    case StreamEvent::kComponentDone:
      s.reason = detail;
      break;
    case StreamEvent::kMapLoaded: {
      // "map <16 hex> <path>" (the path may hold spaces).
      const std::string prefix = std::string(kMapTag) + " ";
      const bool shaped = detail.rfind(prefix, 0) == 0 && detail.size() >= prefix.size() + 16;
      unsigned long long checksum = 0;
      size_t used = 0;
      if (shaped) {
        try {
          checksum = std::stoull(detail.substr(prefix.size(), 16), &used, 16);
        } catch (const std::exception&) {
          used = 0;
        }
      }
      if (!shaped || used != 16) {
        throw InputError("StreamStatus.header.frame_id: MAP_LOADED detail '" + Echo(detail) +
                         "' is not 'map <16 hex digits> <path>'");
      }
      s.map_checksum = checksum;
      s.map_path = detail.size() > prefix.size() + 17 ? detail.substr(prefix.size() + 17) : "";
      break;
    }
    default:
      break;
  }
  return s;
}

RunWriters::Prefix RunWriters::PrefixOf(const WriterGuid& guid) {
  Prefix p{};
  std::copy(guid.begin(), guid.begin() + p.size(), p.begin());
  return p;
}

bool RunWriters::Announce(const ComponentStatus& status,
                          const std::optional<WriterGuid>& status_writer) {
  if (IsFrameSource(status.source)) {
    // Which participant: the status writer's, else that of the frames writer it announces.
    std::optional<Prefix> from;
    if (status_writer) {
      from = PrefixOf(*status_writer);
    } else if (const auto it = status.writers.find(DataTopic::kFrames);
               it != status.writers.end()) {
      from = PrefixOf(it->second);
    }
    if (from && rivals_.count(*from) > 0) return false;
    if (status.event == StreamEvent::kStarted && from) {
      if (frame_source_ && *frame_source_ != *from) {
        rivals_.insert(*from);
        WriterGuid padded{};
        std::copy(from->begin(), from->end(), padded.begin());
        last_rival_ = std::string(ToString(status.source)) + " (participant " +
                      ToHex(padded).substr(0, 2 * from->size()) + ")";
        return false;
      }
      frame_source_ = from;
    }
    if (status.event == StreamEvent::kStarted) stream_started_ = true;
    if (status.event == StreamEvent::kEndOfStream) stream_ended_ = true;
    if ((status.event == StreamEvent::kEndOfStream || status.event == StreamEvent::kFailed) &&
        from && frame_source_ == from) {
      frame_source_.reset();  // the next frame source may play (e.g. a player started again)
    }
  }
  if (status.event != StreamEvent::kStarted) {
    const bool ends =
        status.event == StreamEvent::kEndOfStream || status.event == StreamEvent::kComponentDone;
    if (ends && status_writer && announced_.count(PrefixOf(*status_writer)) == 0) {
      ++foreign_statuses_;
      return false;
    }
    return true;
  }
  if (status_writer) announced_.insert(PrefixOf(*status_writer));
  for (const auto& [topic, guid] : status.writers) writers_[topic].insert(guid);
  return true;
}

bool RunWriters::Owns(DataTopic topic, const WriterGuid& writer) const {
  const auto it = writers_.find(topic);
  return it != writers_.end() && it->second.count(writer) > 0;
}

size_t RunWriters::NumAnnounced(DataTopic topic) const {
  const auto it = writers_.find(topic);
  return it == writers_.end() ? 0 : it->second.size();
}

std::string IgnoredSamplesNote(const std::string& counted) {
  return "ignored " + counted +
         " from writers outside this run (another process on the DDS domain published into it; "
         "without --security any local process can: see docs/dds_components.md)";
}

std::string StoppedBeforeTheEnd(const StopFlag& stop, bool slam_done) {
  if (!stop.requested() || slam_done) return "";
  return stop.signal() != 0
             ? "stopped by signal " + std::to_string(stop.signal()) + " before the end of the run"
             : "stopped before the end of the run";
}

}  // namespace dygslam
