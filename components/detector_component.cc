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

namespace {

// The detector component: frames in, person boxes out (every n-th frame), until the run's frame
// source ended its stream (every announced frame seen, or 2 s idle past its end) or left without
// announcing it. State first, the DDS endpoints last: their listeners never outlive the state.
class DetectorShell {
 public:
  DetectorShell(const std::shared_ptr<dds::Participant>& participant,
                const DetectorOptions& options, int every_n_frames)
      : core_(options),
        every_n_frames_(every_n_frames),
        writer_(participant, dds::topics::kDetections, dds::TopicKind::kDetections),
        status_(participant, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus),
        frames_(participant, dds::topics::kRgbdFrame, dds::TopicKind::kRgbdFrame,
                [this](msg::RgbdFrame&& frame) { queue_.Push(std::move(frame)); }),
        status_reader_(participant, ComponentKind::kDetector,
                       [this](const ComponentStatus& s, const msg::StreamStatus& m,
                              const WriterGuid& from) { OnStatus(s, m, from); }),
        started_(status_, ComponentStatus::Started(ComponentKind::kDetector,
                                                   {{DataTopic::kDetections, writer_.guid()}})) {}

  DetectorStats Run(const StopFlagPtr& stop) {
    ReadyAnnouncer announcer(ComponentKind::kDetector);
    while (!stop->requested()) {
      started_.Poll(status_);
      announcer.Poll(status_, frames_.matched() > 0 && writer_.matched() > 0);
      std::optional<msg::RgbdFrame> sample = queue_.Pop(std::chrono::milliseconds(20));
      if (sample) {
        Process(*sample);
      } else if (StreamOver()) {
        break;
      }
    }
    Finish();
    return stats_;
  }

 private:
  using Clock = std::chrono::steady_clock;

  void OnStatus(const ComponentStatus& s, const msg::StreamStatus& m, const WriterGuid& from) {
    std::lock_guard<std::mutex> lock(mutex_);
    // A second frame source's end of stream is not this run's (components/protocol.h).
    if (!run_writers_.Announce(s, from)) return;
    if (s.event == StreamEvent::kEndOfStream && IsFrameSource(s.source)) {
      end_frames_ = StreamFrameCountFromMsg(m);
      if (end_frames_ == std::numeric_limits<int64_t>::max()) {
        LOG_WARNING << "detector: END_OF_STREAM announces " << m.num_frames()
                    << " frames; finishing when the stream goes idle";
      }
    }
  }

  // Done when every announced frame was seen, or (frames lost) after 2 s idle past the end; or
  // when a frame source left without END_OF_STREAM (killed, or the announcement lost): its
  // writer gone (time allowed to find it again after this process was suspended) and nothing
  // for 5 s.
  bool StreamOver() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (end_frames_ >= 0 && (static_cast<int64_t>(received_) >= end_frames_ ||
                             Clock::now() - idle_since_ > std::chrono::seconds(2)))
      return true;
    const bool source_gone = source_watch_.Update(frames_.matched() > 0);
    if (end_frames_ < 0 && source_gone && Clock::now() - idle_since_ > std::chrono::seconds(5)) {
      LOG_WARNING << "detector: the frame source left without announcing the end of its "
                     "stream; ending";
      return true;
    }
    return false;
  }

  void Process(const msg::RgbdFrame& sample) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++received_;
      idle_since_ = Clock::now();
    }
    if (sample.header().seq() % static_cast<uint64_t>(every_n_frames_) != 0) {
      ++stats_.frames_skipped;  // slam carries the boxes of the last detected frame to it
      return;
    }
    try {
      const RgbdFrameData frame = RgbdFrameFromMsg(sample);
      msg::Detections out = core_.Process(frame);
      total_ms_ += out.inference_ms();
      writer_.Write(out);
      ++stats_.frames_processed;
    } catch (const InputError& e) {
      ++stats_.bad_samples;
      LOG_WARNING << "detector: dropped frame seq " << sample.header().seq() << ": " << e.what();
    }
  }

  void Finish() {
    if (stats_.frames_processed > 0) stats_.mean_inference_ms = total_ms_ / stats_.frames_processed;
    status_.Write(ToMsg(ComponentStatus::Done(ComponentKind::kDetector, stats_.frames_processed)));
    writer_.WaitForAcknowledgments(std::chrono::milliseconds(2000));
    LOG_INFO << "detector: " << stats_.frames_processed << " frames, mean inference "
             << stats_.mean_inference_ms << " ms";
    if (every_n_frames_ > 1) {
      LOG_INFO << "detector: " << stats_.frames_skipped << " frames skipped (every "
               << every_n_frames_ << " frames detected)";
    }
  }

  DetectorCore core_;
  const int every_n_frames_;
  DetectorStats stats_;
  double total_ms_ = 0;
  BlockingQueue<msg::RgbdFrame> queue_;
  std::mutex mutex_;
  int64_t end_frames_ = -1;  // frames announced by END_OF_STREAM (guarded by mutex_)
  size_t received_ = 0;      // guarded by mutex_
  Clock::time_point idle_since_ = Clock::now();            // guarded by mutex_
  WriterGoneWatch source_watch_{std::chrono::seconds(0)};  // the frame writer, matched then gone
  RunWriters run_writers_;  // which frame source is the run's (guarded by mutex_)
  // DDS endpoints last (see above).
  dds::Writer<msg::DetectionsPubSubType> writer_;
  dds::Writer<msg::StreamStatusPubSubType> status_;
  dds::Reader<msg::RgbdFramePubSubType> frames_;
  StatusReader status_reader_;
  StartedAnnouncer started_;
};

}  // namespace

DetectorStats RunDetector(std::shared_ptr<dds::Participant> participant,
                          const DetectorOptions& options, const StopFlagPtr& stop,
                          int every_n_frames) {
  DYGSLAM_CHECK_OPTION(every_n_frames >= 1 && every_n_frames <= 1000,
                       "Detector.every_n_frames (1..1000)");
  DetectorShell shell(participant, options, every_n_frames);
  return shell.Run(stop);
}

}  // namespace dygslam
