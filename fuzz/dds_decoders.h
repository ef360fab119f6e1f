// The decode path of every incoming DDS sample, from the raw serialized payload (CDR with its
// 4-byte encapsulation header, as it arrives from the wire) to the library types:
//   <Type>PubSubType::deserialize -> convert.h *FromMsg (what the component shells call).
// Used by the libFuzzer target (fuzz/dds_sample_fuzzer.cc) and the reliability tests.
//
// Contract checked here: every payload either decodes to valid library data or is rejected
// (DecodeStatus::kRejectedCdr / kRejectedContent with a message) -- no crash, no leak, no
// unbounded allocation. Note: the generated deserialize() catches only NotEnoughMemoryException;
// other fastcdr exceptions (BadParamException for a boolean byte other than 0/1, a bounded
// sequence longer than its bound) escape it, so readers must catch
// eprosima::fastcdr::exception::Exception around take_next_sample (see tests/reliability).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>

#include <fastcdr/exceptions/Exception.h>
#include <fastdds/rtps/common/SerializedPayload.h>

#include "components/convert.h"
#include "core/base/error.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/DetectionsPubSubTypes.h"
#include "dygslam_msg/GroundTruthPubSubTypes.h"
#include "dygslam_msg/KeyframePubSubTypes.h"
#include "dygslam_msg/MapUpdatePubSubTypes.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"

namespace dygslam::fuzz {

enum class DecodeStatus { kOk, kRejectedCdr, kCdrException, kRejectedContent };

struct DecodeResult {
  DecodeStatus status = DecodeStatus::kOk;
  std::string message;
};

// Deserializes `bytes` as `PubSubType` into *message. kRejectedCdr: deserialize() returned false;
// kCdrException: a fastcdr exception escaped deserialize().
template <class PubSubType>
DecodeResult Deserialize(const uint8_t* bytes, size_t size, typename PubSubType::type* message) {
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<uint32_t>(size));
  if (size > 0) std::memcpy(payload.data, bytes, size);
  payload.length = static_cast<uint32_t>(size);
  PubSubType type;
  try {
    if (!type.deserialize(&payload, message)) return {DecodeStatus::kRejectedCdr, "deserialize failed"};
  } catch (const eprosima::fastcdr::exception::Exception& e) {
    return {DecodeStatus::kCdrException, e.what()};
  }
  return {};
}

// Serializes a message the way a DataWriter does.
template <class PubSubType>
std::vector<uint8_t> Serialize(typename PubSubType::type message) {
  PubSubType type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(&message)());
  if (!type.serialize(&message, &payload)) return {};
  return std::vector<uint8_t>(payload.data, payload.data + payload.length);
}

enum class SampleKind : uint8_t {
  kRgbdFrame = 0,
  kDetections,
  kCameraPose,
  kKeyframe,
  kGroundTruth,
  kTrajectory,
  kStreamStatus,
  kMapUpdate,
  kCount
};
const char* ToString(SampleKind kind);

// Full decode of one incoming sample of `kind`: deserialize + the component's conversion.
// Throws only if the contract is broken (never for bad input).
DecodeResult DecodeSample(SampleKind kind, const uint8_t* bytes, size_t size);

}  // namespace dygslam::fuzz
