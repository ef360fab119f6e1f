#include "bridge/ros2_qos.h"

#include <cctype>

#include "core/base/error.h"

namespace dygslam::ros2 {

using namespace eprosima::fastdds::dds;  // NOLINT

std::string DdsTopicName(const std::string& ros_name, const std::string& option) {
  std::string name = ros_name;
  if (!name.empty() && name[0] == '/') name = name.substr(1);
  auto fail = [&](const std::string& why) {
    throw InvalidOptions("invalid option " + option + ": '" + ros_name +
                         "' is not a ROS 2 topic name (" + why + ")");
  };
  if (name.empty()) fail("empty");
  if (name.back() == '/') fail("ends with '/'");
  bool token_start = true;
  for (char c : name) {
    if (c == '/') {
      if (token_start) fail("empty token '//'");
      token_start = true;
      continue;
    }
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) {
      fail(std::string("character '") + c + "'");
    }
    if (token_start && std::isdigit(static_cast<unsigned char>(c))) fail("token starts with a digit");
    token_start = false;
  }
  return "rt/" + name;
}

namespace {
template <class Qos>
void Apply(const RosQos& p, Qos* qos) {
  qos->reliability().kind = p.reliable ? RELIABLE_RELIABILITY_QOS : BEST_EFFORT_RELIABILITY_QOS;
  qos->durability().kind =
      p.transient_local ? TRANSIENT_LOCAL_DURABILITY_QOS : VOLATILE_DURABILITY_QOS;
  qos->history().kind = KEEP_LAST_HISTORY_QOS;
  qos->history().depth = p.depth;
  qos->resource_limits().max_samples = -1;
  qos->resource_limits().max_instances = 1;
  qos->resource_limits().max_samples_per_instance = -1;
  qos->endpoint().history_memory_policy =
      eprosima::fastrtps::rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
}
}  // namespace

DataWriterQos RosWriterQos(const RosQos& qos) {
  DataWriterQos q = DATAWRITER_QOS_DEFAULT;
  Apply(qos, &q);
  q.reliability().max_blocking_time = eprosima::fastrtps::Duration_t(0, 500000000);
  q.data_sharing().off();
  return q;
}

DataReaderQos RosReaderQos(const RosQos& qos) {
  DataReaderQos q = DATAREADER_QOS_DEFAULT;
  Apply(qos, &q);
  q.data_sharing().off();
  return q;
}

}  // namespace dygslam::ros2
