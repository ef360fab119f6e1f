// Fast DDS type support of rmw_dds_common/msg/ParticipantEntitiesInfo (ros2_graph.h) for one ROS 2
// distribution (the Gid size differs). Written by hand rather than generated: the Humble and
// Jazzy layouts share one type name and would collide as generated C++ types. Write-only (the
// bridge publishes its own graph entry and never reads others').
#pragma once

#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstring>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <functional>

#include "bridge/ros2_graph.h"

namespace dygslam::ros2 {

template <RosDistro kDistro>
class ParticipantEntitiesInfoPubSubType : public eprosima::fastdds::dds::TopicDataType {
 public:
  using type = RosParticipantEntities;

  ParticipantEntitiesInfoPubSubType() {
    setName(kParticipantEntitiesInfoType);
    m_typeSize = 4096;  // initial payload size; larger samples are reallocated
    m_isGetKeyDefined = false;
  }

  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override {
    const std::vector<uint8_t> bytes =
        EncodeParticipantEntitiesInfo(*static_cast<const type*>(data), kDistro);
    if (bytes.size() > payload->max_size) payload->reserve(static_cast<uint32_t>(bytes.size()));
    std::memcpy(payload->data, bytes.data(), bytes.size());
    payload->length = static_cast<uint32_t>(bytes.size());
    payload->encapsulation = CDR_LE;
    return true;
  }
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t*, void*) override {
    return false;  // never read by the bridge
  }
  std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
    return [data] {
      return static_cast<uint32_t>(
          EncodeParticipantEntitiesInfo(*static_cast<const type*>(data), kDistro).size());
    };
  }
  void* createData() override { return new type(); }
  void deleteData(void* data) override { delete static_cast<type*>(data); }
  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override {
    return false;  // keyless
  }
};

}  // namespace dygslam::ros2
