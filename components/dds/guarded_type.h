// GuardedType<PubSubType>: the fastddsgen-generated type support with a deserialize() that never
// throws and refuses oversized payloads.
//
// Why: the generated deserialize() of fastddsgen 2.3.0 catches only NotEnoughMemoryException. A
// malformed sample from any participant of the domain (e.g. a boolean byte of 2 -> fastcdr
// BadParamException) then escapes from DataReader::take_next_sample -- on a listener thread that
// is std::terminate -- and the sample is not consumed, so every retry throws again. When
// deserialize() returns false instead, Fast DDS drops the sample and reading goes on
// (tests/reliability/dds_malformed_test.cc).
//
// Size limit: fastcdr resizes a sequence to its claimed length (bounded by the remaining bytes)
// before decoding it, so the payload size bounds the memory a sample can make a reader allocate.
// Payloads above SampleSizeLimit<PubSubType>::kBytes are rejected before decoding. The dygslam
// types have their limits below; other types (e.g. the ROS 2 types of bridge/) get the generous
// default kDefaultSampleSizeLimit unless a specialization of SampleSizeLimit is visible where
// Participant::GetTopic is instantiated.
#pragma once

#include <fastdds/rtps/common/SerializedPayload.h>

#include <atomic>
#include <cstdint>
#include <exception>

#include "core/base/log.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/DetectionsPubSubTypes.h"
#include "dygslam_msg/GroundTruthPubSubTypes.h"
#include "dygslam_msg/KeyframePubSubTypes.h"
#include "dygslam_msg/MapUpdatePubSubTypes.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"

namespace dygslam::dds {

// Bytes; for types without a specialization.
inline constexpr uint32_t kDefaultSampleSizeLimit = 64u << 20;
inline constexpr uint32_t kSmallSampleSizeLimit = 1u << 20;

template <class PubSubType>
struct SampleSizeLimit {
  static constexpr uint32_t kBytes = kDefaultSampleSizeLimit;
};

#define DYGSLAM_SAMPLE_SIZE_LIMIT(Type, bytes)  \
  template <>                                   \
  struct SampleSizeLimit<Type> {                \
    static constexpr uint32_t kBytes = (bytes); \
  }

// Small messages: a few hundred bytes (Detections: ~100 boxes of ~60 B).
DYGSLAM_SAMPLE_SIZE_LIMIT(msg::CameraPosePubSubType, kSmallSampleSizeLimit);
DYGSLAM_SAMPLE_SIZE_LIMIT(msg::DetectionsPubSubType, kSmallSampleSizeLimit);
DYGSLAM_SAMPLE_SIZE_LIMIT(msg::GroundTruthPosePubSubType, kSmallSampleSizeLimit);
DYGSLAM_SAMPLE_SIZE_LIMIT(msg::StreamStatusPubSubType, kSmallSampleSizeLimit);
// RGB-D frame: 640x480 bgr8 + 16UC1 is 1.5 MB; 1280x720 is 4.6 MB.
DYGSLAM_SAMPLE_SIZE_LIMIT(msg::RgbdFramePubSubType, 8u << 20);
// Keyframe: bgr8 + 32FC1 depth + mono8 mask + keypoints, 2.5 MB at 640x480.
DYGSLAM_SAMPLE_SIZE_LIMIT(msg::KeyframePubSubType, 16u << 20);
// Whole-trajectory snapshots: ~72 B per pose, 16 MB is over 200k poses (2 h at 30 Hz).
DYGSLAM_SAMPLE_SIZE_LIMIT(msg::TrajectoryPubSubType, 16u << 20);
// OctoMap binary stream of the whole map.
DYGSLAM_SAMPLE_SIZE_LIMIT(msg::MapUpdatePubSubType, 32u << 20);

#undef DYGSLAM_SAMPLE_SIZE_LIMIT

template <class PubSubType>
class GuardedType : public PubSubType {
 public:
  static constexpr uint32_t kMaxSampleBytes = SampleSizeLimit<PubSubType>::kBytes;

  // False (Fast DDS drops the sample) when the payload is too large or does not decode.
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override {
    if (payload == nullptr || payload->length > kMaxSampleBytes) {
      Reject("larger than the limit");
      return false;
    }
    try {
      if (PubSubType::deserialize(payload, data)) return true;
      Reject("does not decode");
    } catch (const std::exception& e) {
      Reject(e.what());
    } catch (...) {
      Reject("unknown exception");
    }
    return false;
  }

  // Samples of this type rejected in this process so far.
  static int64_t rejected_count() { return rejected_.load(); }

 private:
  void Reject(const char* why) {
    const int64_t n = ++rejected_;
    // First few, then every 1000th: a flood of bad samples must not flood the log.
    if (n <= 3 || n % 1000 == 0) {
      LOG_WARNING << "DDS: dropped a malformed " << this->getName() << " sample (" << why << "; "
                  << n << " so far)";
    }
  }
  static inline std::atomic<int64_t> rejected_{0};
};

}  // namespace dygslam::dds
