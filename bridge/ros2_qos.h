// ROS 2 wire conventions for Fast DDS endpoints: topic names ("rt/" + ROS name) and the QoS
// profiles of rclcpp (rmw/qos_profiles.h):
//
// | profile          | reliability | durability      | history     | used for                    |
// |------------------|-------------|-----------------|-------------|-----------------------------|
// | sensor data      | best effort | volatile        | keep-last 5 | images, camera info (in)    |
// | default          | reliable    | volatile        | keep-last 10| pose, path, odom, tf, dets  |
// | transient local  | reliable    | transient-local | keep-last 1 | /tf_static, the OctoMap     |
//
// Inbound readers are best effort: a best-effort reader matches both best-effort and reliable
// writers (drivers differ). A transient-local writer also serves volatile readers (rviz
// defaults), and late joiners get the static transform and the newest map.
#pragma once

#include <string>

#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

namespace dygslam::ros2 {

struct RosQos {
  bool reliable = true;
  bool transient_local = false;
  int depth = 10;

  static RosQos SensorData() { return {false, false, 5}; }
  static RosQos Default() { return {true, false, 10}; }
  static RosQos TransientLocal() { return {true, true, 1}; }
};

// "rt/" + name without its leading '/' ("/camera/color/image_raw" -> "rt/camera/color/image_raw").
// Throws InvalidOptions naming `option` for an invalid ROS 2 topic name (empty, characters other
// than [A-Za-z0-9_/], "//", a trailing '/', a token starting with a digit).
std::string DdsTopicName(const std::string& ros_name, const std::string& option);

eprosima::fastdds::dds::DataWriterQos RosWriterQos(const RosQos& qos);
eprosima::fastdds::dds::DataReaderQos RosReaderQos(const RosQos& qos);

}  // namespace dygslam::ros2
