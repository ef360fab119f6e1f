// StreamStatus helpers shared by the component shells.
#pragma once

#include <chrono>
#include <string>

#include "components/component_common.h"
#include "dygslam_msg/StreamStatus.h"

namespace dygslam {

inline msg::StreamStatus MakeStreamStatus(StreamEvent event, const std::string& source,
                                          uint64_t num_frames = 0, uint64_t seq = 0) {
  msg::StreamStatus s;
  s.kind(static_cast<uint8_t>(event));
  s.source(source);
  s.num_frames(num_frames);
  s.header().seq(seq);
  s.header().frame_id("");
  return s;
}

// Announces STARTED (source = component name) once the component's inputs are matched, or after
// `timeout` in any case. The player waits for these announcements of the components the pipeline
// runs before it publishes the first frame, so no component misses the start of the stream.
// Call Poll() from the component's loop (non-blocking).
class StartAnnouncer {
 public:
  explicit StartAnnouncer(std::string name,
                          std::chrono::milliseconds timeout = std::chrono::seconds(30))
      : name_(std::move(name)), deadline_(std::chrono::steady_clock::now() + timeout) {}

  template <class StatusWriter>
  void Poll(StatusWriter& status, bool inputs_ready) {
    if (done_) return;
    if (!inputs_ready && std::chrono::steady_clock::now() < deadline_) return;
    status.Write(MakeStreamStatus(StreamEvent::kStarted, name_));
    done_ = true;
  }
  bool done() const { return done_; }

 private:
  std::string name_;
  std::chrono::steady_clock::time_point deadline_;
  bool done_ = false;
};

}  // namespace dygslam
