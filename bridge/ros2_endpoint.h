// Typed Fast DDS DataWriter / DataReader on a ROS 2 topic ("rt/" + name) with a ROS 2 QoS
// profile, over a shared dds::Participant (the same RAII endpoints as the pipeline's,
// components/dds/endpoint.h, with ROS 2 QoS instead of the pipeline's topic table).
//
// Partitions: ROS 2 (rmw_fastrtps, rmw_cyclonedds) puts every endpoint in the default partition,
// while the participant's own publisher / subscriber carry the pipeline's partition
// (ParticipantOptions::partition, e.g. the one of a `dygslam run`). The ROS endpoints therefore
// live on a separate publisher / subscriber without a partition (RosSession), so one participant
// talks to the pipeline in its partition and to ROS 2 in the default one.
#pragma once

#include <atomic>
#include <chrono>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/PublisherQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/SubscriberQos.hpp>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include "bridge/ros2_qos.h"
#include "components/dds/endpoint.h"
#include "components/dds/participant.h"

namespace dygslam::ros2 {

// A publisher and a subscriber in the default partition on `participant` (for ROS endpoints).
class RosSession {
 public:
  static std::shared_ptr<RosSession> Create(std::shared_ptr<dds::Participant> participant) {
    std::shared_ptr<RosSession> s(new RosSession(std::move(participant)));
    auto* p = s->participant_->get();
    s->publisher_ = p->create_publisher(eprosima::fastdds::dds::PUBLISHER_QOS_DEFAULT);
    s->subscriber_ = p->create_subscriber(eprosima::fastdds::dds::SUBSCRIBER_QOS_DEFAULT);
    if (s->publisher_ == nullptr || s->subscriber_ == nullptr) {
      throw std::runtime_error("Fast DDS: cannot create the ROS 2 publisher/subscriber");
    }
    return s;
  }
  ~RosSession() {
    auto* p = participant_->get();
    if (publisher_ != nullptr) p->delete_publisher(publisher_);
    if (subscriber_ != nullptr) p->delete_subscriber(subscriber_);
  }
  RosSession(const RosSession&) = delete;
  RosSession& operator=(const RosSession&) = delete;

  dds::Participant& participant() const { return *participant_; }
  eprosima::fastdds::dds::Publisher* publisher() const { return publisher_; }
  eprosima::fastdds::dds::Subscriber* subscriber() const { return subscriber_; }

 private:
  explicit RosSession(std::shared_ptr<dds::Participant> participant)
      : participant_(std::move(participant)) {}
  std::shared_ptr<dds::Participant> participant_;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
};

template <class PubSubType>
class RosWriter : public dds::TypedWriter<PubSubType> {
 public:
  // topic: the DDS name (DdsTopicName()).
  RosWriter(std::shared_ptr<RosSession> ros, const std::string& topic, const RosQos& qos)
      : dds::TypedWriter<PubSubType>(ros, ros->participant(), ros->publisher(), topic,
                                     RosWriterQos(qos)) {}
};

template <class PubSubType>
class RosReader : public dds::TypedReader<PubSubType> {
 public:
  using Callback = typename dds::TypedReader<PubSubType>::Callback;
  RosReader(std::shared_ptr<RosSession> ros, const std::string& topic, const RosQos& qos,
            Callback callback, dds::LossCallback on_loss = {})
      : dds::TypedReader<PubSubType>(ros, ros->participant(), ros->subscriber(), topic,
                                     RosReaderQos(qos), std::move(callback), std::move(on_loss)) {}
};

}  // namespace dygslam::ros2
