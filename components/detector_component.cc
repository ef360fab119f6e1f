#include "components/detector_component.h"

#include <chrono>
#include <limits>
#include <mutex>
#include <optional>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/status_reader.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "dygslam_msg/DetectionsPubSubTypes.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"

namespace dygslam {

DetectorStats RunDetector(std::shared_ptr<dds::Participant> participant,
                          const DetectorOptions& options, const StopFlagPtr& stop,
                          int every_n_frames) {
  DYGSLAM_CHECK_OPTION(every_n_frames >= 1 && every_n_frames <= 1000,
                       "Detector.every_n_frames (1..1000)");
  DetectorCore core(options);
  DetectorStats stats;
  BlockingQueue<msg::RgbdFrame> queue;
  std::mutex mutex;
  int64_t end_frames = -1;  // frames announced by END_OF_STREAM
  RunWriters run_writers;   // which frame source is the run's (guarded by mutex)

  dds::Writer<msg::DetectionsPubSubType> writer(participant, dds::topics::kDetections,
                                                dds::TopicKind::kDetections);
  dds::Writer<msg::StreamStatusPubSubType> status(participant, dds::topics::kStreamStatus,
                                                  dds::TopicKind::kStreamStatus);
  dds::Reader<msg::RgbdFramePubSubType> frames(
      participant, dds::topics::kRgbdFrame, dds::TopicKind::kRgbdFrame,
      [&](msg::RgbdFrame&& frame) { queue.Push(std::move(frame)); });
  StatusReader status_reader(
      participant, ComponentKind::kDetector,
      [&](const ComponentStatus& s, const msg::StreamStatus& m, const WriterGuid& from) {
        std::lock_guard<std::mutex> lock(mutex);
        // A second frame source's end of stream is not this run's (components/protocol.h).
        if (!run_writers.Announce(s, from)) return;
        if (s.event == StreamEvent::kEndOfStream && IsFrameSource(s.source)) {
          end_frames = StreamFrameCountFromMsg(m);
          if (end_frames == std::numeric_limits<int64_t>::max()) {
            LOG_WARNING << "detector: END_OF_STREAM announces " << m.num_frames()
                        << " frames; finishing when the stream goes idle";
          }
        }
      });
  StartedAnnouncer started(status,
                           ComponentStatus::Started(ComponentKind::kDetector,
                                                    {{DataTopic::kDetections, writer.guid()}}));

  double total_ms = 0;
  size_t received = 0;
  auto idle_since = std::chrono::steady_clock::now();
  bool frame_source_seen = false;  // a frame writer was matched
  ReadyAnnouncer announcer(ComponentKind::kDetector);
  while (!stop->requested()) {
    started.Poll(status);
    announcer.Poll(status, frames.matched() > 0 && writer.matched() > 0);
    std::optional<msg::RgbdFrame> sample = queue.Pop(std::chrono::milliseconds(20));
    if (!sample) {
      std::lock_guard<std::mutex> lock(mutex);
      // Done when every announced frame was seen, or (frames lost) after 2 s idle past the end.
      if (end_frames >= 0 &&
          (static_cast<int64_t>(received) >= end_frames ||
           std::chrono::steady_clock::now() - idle_since > std::chrono::seconds(2))) {
        break;
      }
      // A frame source that left without END_OF_STREAM (killed, or the announcement lost): its
      // writer gone and nothing for 5 s.
      const int frame_writers = frames.matched();
      frame_source_seen = frame_source_seen || frame_writers > 0;
      if (end_frames < 0 && frame_source_seen && frame_writers == 0 &&
          std::chrono::steady_clock::now() - idle_since > std::chrono::seconds(5)) {
        LOG_WARNING << "detector: the frame source left without announcing the end of its "
                       "stream; ending";
        break;
      }
      continue;
    }
    ++received;
    idle_since = std::chrono::steady_clock::now();
    if (sample->header().seq() % static_cast<uint64_t>(every_n_frames) != 0) {
      ++stats.frames_skipped;  // slam carries the boxes of the last detected frame to it
      continue;
    }
    try {
      const RgbdFrameData frame = RgbdFrameFromMsg(*sample);
      msg::Detections out = core.Process(frame);
      total_ms += out.inference_ms();
      writer.Write(out);
      ++stats.frames_processed;
    } catch (const InputError& e) {
      ++stats.bad_samples;
      LOG_WARNING << "detector: dropped frame seq " << sample->header().seq() << ": " << e.what();
    }
  }
  if (stats.frames_processed > 0) stats.mean_inference_ms = total_ms / stats.frames_processed;
  status.Write(ToMsg(ComponentStatus::Done(ComponentKind::kDetector, stats.frames_processed)));
  writer.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  LOG_INFO << "detector: " << stats.frames_processed << " frames, mean inference "
           << stats.mean_inference_ms << " ms";
  if (every_n_frames > 1) {
    LOG_INFO << "detector: " << stats.frames_skipped << " frames skipped (every " << every_n_frames
             << " frames detected)";
  }
  return stats;
}

}  // namespace dygslam
