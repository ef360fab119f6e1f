#include "bridge/tests/cyclone_peer.h"

#include <dds/dds.h>

#include <deque>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <thread>

// idlc (C) output from bridge/idl.
#include "geometry_msgs/msg/PoseStamped.h"
#include "nav_msgs/msg/Odometry.h"
#include "nav_msgs/msg/Path.h"
#include "octomap_msgs/msg/Octomap.h"
#include "ros_graph_humble.h"
#include "ros_graph_jazzy.h"
#include "sensor_msgs/msg/CameraInfo.h"
#include "sensor_msgs/msg/Image.h"
#include "tf2_msgs/msg/TFMessage.h"
#include "vision_msgs/msg/Detection2DArray.h"

namespace dygslam::testing {

namespace {

void Check(dds_return_t rc, const std::string& what) {
  if (rc < 0) throw std::runtime_error("Cyclone DDS: " + what + ": " + dds_strretcode(rc));
}

dds_qos_t* MakeQos(bool reliable, bool transient_local, int depth) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_SECS(1));
  dds_qset_durability(qos,
                      transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  if (depth > 0) {
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, depth);
  } else {
    dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
  }
  return qos;
}

int64_t Ns(const builtin_interfaces_msg_Time& t) {
  return static_cast<int64_t>(t.sec) * 1000000000 + t.nanosec;
}
builtin_interfaces_msg_Time ToTime(int64_t ns) {
  builtin_interfaces_msg_Time t;
  t.sec = static_cast<int32_t>(ns / 1000000000);
  t.nanosec = static_cast<uint32_t>(ns % 1000000000);
  return t;
}
std::string Str(const char* s) { return s ? s : ""; }

PeerPose FromPose(const std_msgs_msg_Header& h, const geometry_msgs_msg_Pose& p) {
  PeerPose out;
  out.stamp_ns = Ns(h.stamp);
  out.frame_id = Str(h.frame_id);
  out.position[0] = p.position.x;
  out.position[1] = p.position.y;
  out.position[2] = p.position.z;
  out.orientation[0] = p.orientation.x;
  out.orientation[1] = p.orientation.y;
  out.orientation[2] = p.orientation.z;
  out.orientation[3] = p.orientation.w;
  return out;
}

PeerTransform FromTransform(const geometry_msgs_msg_TransformStamped& t) {
  PeerTransform out;
  geometry_msgs_msg_Pose p;
  p.position.x = t.transform.translation.x;
  p.position.y = t.transform.translation.y;
  p.position.z = t.transform.translation.z;
  p.orientation = t.transform.rotation;
  out.pose = FromPose(t.header, p);
  out.child_frame_id = Str(t.child_frame_id);
  return out;
}

template <class T>
void TakeAll(dds_entity_t reader, const std::function<void(const T&)>& on_sample) {
  if (reader <= 0) return;
  while (true) {
    void* samples[16] = {nullptr};
    dds_sample_info_t infos[16];
    const int n = dds_take(reader, samples, infos, 16, 16);
    if (n <= 0) break;
    for (int i = 0; i < n; ++i) {
      if (infos[i].valid_data) on_sample(*static_cast<const T*>(samples[i]));
    }
    dds_return_loan(reader, samples, n);
  }
}

}  // namespace

namespace {

template <class Info>
PeerGraphInfo FromGraph(const Info& m) {
  PeerGraphInfo g;
  auto gid = [](const auto& x) {
    return std::vector<uint8_t>(std::begin(x.data), std::end(x.data));
  };
  g.gid = gid(m.gid);
  for (uint32_t k = 0; k < m.node_entities_info_seq._length; ++k) {
    const auto& n = m.node_entities_info_seq._buffer[k];
    PeerNodeInfo node;
    node.node_namespace = n.node_namespace;
    node.node_name = n.node_name;
    for (uint32_t j = 0; j < n.reader_gid_seq._length; ++j) {
      node.readers.push_back(gid(n.reader_gid_seq._buffer[j]));
    }
    for (uint32_t j = 0; j < n.writer_gid_seq._length; ++j) {
      node.writers.push_back(gid(n.writer_gid_seq._buffer[j]));
    }
    g.nodes.push_back(std::move(node));
  }
  return g;
}

PeerGuid FromGuid(const dds_guid_t& g) {
  PeerGuid out{};
  std::copy(g.v, g.v + 16, out.begin());
  return out;
}

// Every sample of a built-in topic reader (read, not taken: each call sees all of them).
template <class T>
void ReadAll(dds_entity_t reader, const std::function<void(const T&)>& on_sample) {
  void* samples[256] = {nullptr};
  dds_sample_info_t infos[256];
  const int n = dds_read(reader, samples, infos, 256, 256);
  for (int i = 0; i < n; ++i) {
    if (infos[i].valid_data && infos[i].instance_state == DDS_IST_ALIVE) {
      on_sample(*static_cast<const T*>(samples[i]));
    }
  }
  if (n > 0) dds_return_loan(reader, samples, n);
}

}  // namespace

struct CyclonePeer::Impl {
  dds_entity_t domain = 0, participant = 0;
  std::deque<dds_topic_descriptor_t> descriptors;  // stable addresses, outlive the topics
  std::deque<std::string> type_names;
  dds_entity_t pose = 0, odom = 0, path = 0, tf = 0, tf_static = 0, detections = 0, octomap = 0;
  dds_entity_t color = 0, depth = 0, info = 0;
  dds_entity_t graph = 0;
  PeerDistro graph_distro = PeerDistro::kJazzy;
  dds_entity_t publications = 0, subscriptions = 0, participants = 0;

  dds_entity_t Topic(const dds_topic_descriptor_t& d, const std::string& ros_type,
                     const std::string& name) {
    type_names.push_back(ros_type);
    descriptors.push_back(d);
    descriptors.back().m_typename = type_names.back().c_str();
    const dds_entity_t t =
        dds_create_topic(participant, &descriptors.back(), name.c_str(), nullptr, nullptr);
    Check(t, "create topic " + name);
    return t;
  }
  dds_entity_t Reader(dds_entity_t topic, bool reliable, bool transient_local, int depth) {
    dds_qos_t* qos = MakeQos(reliable, transient_local, depth);
    const dds_entity_t r = dds_create_reader(participant, topic, qos, nullptr);
    dds_delete_qos(qos);
    Check(r, "create reader");
    return r;
  }
  dds_entity_t Writer(dds_entity_t topic, bool reliable, bool transient_local, int depth) {
    dds_qos_t* qos = MakeQos(reliable, transient_local, depth);
    const dds_entity_t w = dds_create_writer(participant, topic, qos, nullptr);
    dds_delete_qos(qos);
    Check(w, "create writer");
    return w;
  }
};

CyclonePeer::CyclonePeer(int domain, PeerNetwork network) : impl_(std::make_unique<Impl>()) {
  if (network == PeerNetwork::kLoopback) {
    // Loopback only, multicast discovery on lo; socket buffers large enough for whole images.
    const std::string config =
        "<CycloneDDS><Domain><General>"
        "<Interfaces><NetworkInterface name=\"lo\" multicast=\"true\"/></Interfaces>"
        "</General><Internal><SocketReceiveBufferSize min=\"4MB\"/>"
        "<SocketSendBufferSize min=\"4MB\"/></Internal></Domain></CycloneDDS>";
    impl_->domain = dds_create_domain(static_cast<dds_domainid_t>(domain), config.c_str());
    Check(impl_->domain, "create domain " + std::to_string(domain));
  }
  // kDefault: the participant creates the domain with Cyclone's defaults (CYCLONEDDS_URI, which
  // the tests unset).
  impl_->participant =
      dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
  Check(impl_->participant, "create participant");
}

CyclonePeer::~CyclonePeer() {
  if (impl_->participant > 0) dds_delete(impl_->participant);
  if (impl_->domain > 0) dds_delete(impl_->domain);
}

void CyclonePeer::Subscribe(const RosOutputTopics& t) {
  Impl& i = *impl_;
  // Keep-all reliable readers: the test checks every sample.
  i.pose = i.Reader(
      i.Topic(geometry_msgs_msg_PoseStamped_desc, "geometry_msgs::msg::dds_::PoseStamped_", t.pose),
      true, false, 0);
  i.odom = i.Reader(i.Topic(nav_msgs_msg_Odometry_desc, "nav_msgs::msg::dds_::Odometry_", t.odom),
                    true, false, 0);
  i.path = i.Reader(i.Topic(nav_msgs_msg_Path_desc, "nav_msgs::msg::dds_::Path_", t.path), true,
                    false, 0);
  const dds_entity_t tf_type_topic =
      i.Topic(tf2_msgs_msg_TFMessage_desc, "tf2_msgs::msg::dds_::TFMessage_", t.tf);
  i.tf = i.Reader(tf_type_topic, true, false, 0);
  i.tf_static =
      i.Reader(i.Topic(tf2_msgs_msg_TFMessage_desc, "tf2_msgs::msg::dds_::TFMessage_", t.tf_static),
               true, true, 1);
  i.detections = i.Reader(i.Topic(vision_msgs_msg_Detection2DArray_desc,
                                  "vision_msgs::msg::dds_::Detection2DArray_", t.detections),
                          true, false, 0);
  i.octomap = i.Reader(
      i.Topic(octomap_msgs_msg_Octomap_desc, "octomap_msgs::msg::dds_::Octomap_", t.octomap), true,
      true, 1);
}

int CyclonePeer::MatchedWriters() const {
  int total = 0;
  for (dds_entity_t r : {impl_->pose, impl_->odom, impl_->path, impl_->tf, impl_->tf_static,
                         impl_->detections, impl_->octomap}) {
    if (r <= 0) continue;
    dds_subscription_matched_status_t s{};
    if (dds_get_subscription_matched_status(r, &s) >= 0) total += static_cast<int>(s.current_count);
  }
  return total;
}

void CyclonePeer::Poll() {
  Impl& i = *impl_;
  TakeAll<geometry_msgs_msg_PoseStamped>(
      i.pose, [&](const auto& m) { poses.push_back(FromPose(m.header, m.pose)); });
  TakeAll<nav_msgs_msg_Odometry>(i.odom, [&](const auto& m) {
    PeerOdometry o;
    o.pose = FromPose(m.header, m.pose.pose);
    o.child_frame_id = Str(m.child_frame_id);
    o.linear[0] = m.twist.twist.linear.x;
    o.linear[1] = m.twist.twist.linear.y;
    o.linear[2] = m.twist.twist.linear.z;
    o.angular[0] = m.twist.twist.angular.x;
    o.angular[1] = m.twist.twist.angular.y;
    o.angular[2] = m.twist.twist.angular.z;
    odometry.push_back(o);
  });
  TakeAll<nav_msgs_msg_Path>(i.path, [&](const auto& m) {
    PeerPath p;
    p.stamp_ns = Ns(m.header.stamp);
    p.frame_id = Str(m.header.frame_id);
    for (uint32_t k = 0; k < m.poses._length; ++k) {
      p.poses.push_back(FromPose(m.poses._buffer[k].header, m.poses._buffer[k].pose));
    }
    paths.push_back(std::move(p));
  });
  auto take_tf = [&](dds_entity_t reader, std::vector<PeerTransform>* out) {
    TakeAll<tf2_msgs_msg_TFMessage>(reader, [&](const auto& m) {
      for (uint32_t k = 0; k < m.transforms._length; ++k) {
        out->push_back(FromTransform(m.transforms._buffer[k]));
      }
    });
  };
  take_tf(i.tf, &transforms);
  take_tf(i.tf_static, &static_transforms);
  TakeAll<vision_msgs_msg_Detection2DArray>(i.detections, [&](const auto& m) {
    PeerDetections d;
    d.stamp_ns = Ns(m.header.stamp);
    d.frame_id = Str(m.header.frame_id);
    for (uint32_t k = 0; k < m.detections._length; ++k) {
      const vision_msgs_msg_Detection2D& det = m.detections._buffer[k];
      PeerBox b;
      if (det.results._length > 0) {
        b.class_id = Str(det.results._buffer[0].hypothesis.class_id);
        b.score = det.results._buffer[0].hypothesis.score;
      }
      b.center_x = det.bbox.center.position.x;
      b.center_y = det.bbox.center.position.y;
      b.size_x = det.bbox.size_x;
      b.size_y = det.bbox.size_y;
      d.boxes.push_back(b);
    }
    detections.push_back(std::move(d));
  });
  TakeAll<octomap_msgs_msg_Octomap>(i.octomap, [&](const auto& m) {
    PeerOctomap o;
    o.stamp_ns = Ns(m.header.stamp);
    o.frame_id = Str(m.header.frame_id);
    o.binary = m.binary;
    o.id = Str(m.id);
    o.resolution = m.resolution;
    o.data.assign(m.data._buffer, m.data._buffer + m.data._length);
    maps.push_back(std::move(o));
  });
  if (i.graph_distro == PeerDistro::kHumble) {
    TakeAll<humble_rmw_dds_common_msg_ParticipantEntitiesInfo>(
        i.graph, [&](const auto& m) { graph.push_back(FromGraph(m)); });
  } else {
    TakeAll<jazzy_rmw_dds_common_msg_ParticipantEntitiesInfo>(
        i.graph, [&](const auto& m) { graph.push_back(FromGraph(m)); });
  }
}

void CyclonePeer::SubscribeRosGraph(PeerDistro distro) {
  Impl& i = *impl_;
  i.graph_distro = distro;
  const dds_topic_descriptor_t& d = distro == PeerDistro::kHumble
                                        ? humble_rmw_dds_common_msg_ParticipantEntitiesInfo_desc
                                        : jazzy_rmw_dds_common_msg_ParticipantEntitiesInfo_desc;
  i.graph = i.Reader(
      i.Topic(d, "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_", "ros_discovery_info"), true,
      true, 0);
}

std::vector<PeerEndpoint> CyclonePeer::DiscoveredEndpoints() const {
  Impl& i = *impl_;
  if (i.publications == 0) {
    i.publications =
        dds_create_reader(i.participant, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
    i.subscriptions =
        dds_create_reader(i.participant, DDS_BUILTIN_TOPIC_DCPSSUBSCRIPTION, nullptr, nullptr);
    Check(i.publications, "DCPSPublication reader");
    Check(i.subscriptions, "DCPSSubscription reader");
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // built-in data arrives
  }
  std::vector<PeerEndpoint> out;
  for (const bool writer : {true, false}) {
    ReadAll<dds_builtintopic_endpoint_t>(writer ? i.publications : i.subscriptions,
                                         [&](const dds_builtintopic_endpoint_t& e) {
                                           PeerEndpoint p;
                                           p.guid = FromGuid(e.key);
                                           p.participant_guid = FromGuid(e.participant_key);
                                           p.topic = Str(e.topic_name);
                                           p.type = Str(e.type_name);
                                           p.writer = writer;
                                           out.push_back(p);
                                         });
  }
  return out;
}

std::vector<PeerParticipant> CyclonePeer::DiscoveredParticipants() const {
  Impl& i = *impl_;
  if (i.participants == 0) {
    i.participants =
        dds_create_reader(i.participant, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, nullptr);
    Check(i.participants, "DCPSParticipant reader");
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  std::vector<PeerParticipant> out;
  ReadAll<dds_builtintopic_participant_t>(
      i.participants, [&](const dds_builtintopic_participant_t& b) {
        PeerParticipant p;
        p.guid = FromGuid(b.key);
        void* value = nullptr;
        size_t size = 0;
        if (b.qos != nullptr && dds_qget_userdata(b.qos, &value, &size) && value != nullptr) {
          p.user_data.assign(static_cast<const char*>(value), size);
        }
        dds_free(value);
        out.push_back(p);
      });
  return out;
}

void CyclonePeer::Advertise(const std::string& color_topic, const std::string& depth_topic,
                            const std::string& info_topic) {
  Impl& i = *impl_;
  // rclcpp's sensor-data profile: best effort, volatile, keep-last 5.
  i.color =
      i.Writer(i.Topic(sensor_msgs_msg_Image_desc, "sensor_msgs::msg::dds_::Image_", color_topic),
               false, false, 5);
  i.depth =
      i.Writer(i.Topic(sensor_msgs_msg_Image_desc, "sensor_msgs::msg::dds_::Image_", depth_topic),
               false, false, 5);
  i.info = i.Writer(
      i.Topic(sensor_msgs_msg_CameraInfo_desc, "sensor_msgs::msg::dds_::CameraInfo_", info_topic),
      false, false, 5);
}

bool CyclonePeer::WaitForCameraReaders(std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    int matched = 0;
    for (dds_entity_t w : {impl_->color, impl_->depth, impl_->info}) {
      dds_publication_matched_status_t s{};
      if (dds_get_publication_matched_status(w, &s) >= 0 && s.current_count > 0) ++matched;
    }
    if (matched == 3) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

void CyclonePeer::PublishFrame(int64_t stamp_ns, const cv::Mat& bgr, const cv::Mat& depth,
                               const PeerCamera& camera, const std::string& frame_id,
                               const std::string& color_encoding) {
  Impl& i = *impl_;
  std::string frame = frame_id;
  std_msgs_msg_Header header;
  header.stamp = ToTime(stamp_ns);
  header.frame_id = frame.data();

  sensor_msgs_msg_CameraInfo info{};
  info.header = header;
  info.width = camera.width;
  info.height = camera.height;
  std::string model = camera.model;
  info.distortion_model = model.data();
  std::vector<double> d = camera.d;
  info.d._buffer = d.data();
  info.d._length = info.d._maximum = static_cast<uint32_t>(d.size());
  info.d._release = false;
  const double k9[9] = {camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1};
  const double r9[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double p12[12] = {camera.fx, 0, camera.cx, 0, 0, camera.fy, camera.cy, 0, 0, 0, 1, 0};
  for (int k = 0; k < 9; ++k) {
    info.k[k] = k9[k];
    info.r[k] = r9[k];
  }
  for (int k = 0; k < 12; ++k) info.p[k] = p12[k];
  Check(dds_write(i.info, &info), "write camera info");

  auto write_image = [&](dds_entity_t writer, const cv::Mat& image, const std::string& enc) {
    cv::Mat packed = image.isContinuous() ? image : image.clone();
    std::string encoding = enc;
    sensor_msgs_msg_Image m{};
    m.header = header;
    m.height = packed.rows;
    m.width = packed.cols;
    m.encoding = encoding.data();
    m.is_bigendian = 0;
    m.step = static_cast<uint32_t>(packed.cols * packed.elemSize());
    m.data._buffer = packed.data;
    m.data._length = m.data._maximum = static_cast<uint32_t>(m.step * packed.rows);
    m.data._release = false;
    Check(dds_write(writer, &m), "write image " + enc);
  };
  if (color_encoding.empty()) {
    cv::Mat rgb;
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    write_image(i.color, rgb, "rgb8");
  } else {
    write_image(i.color, bgr, color_encoding);
  }
  write_image(i.depth, depth, depth.type() == CV_32FC1 ? "32FC1" : "16UC1");
}

}  // namespace dygslam::testing
