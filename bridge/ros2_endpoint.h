// Typed Fast DDS DataWriter / DataReader on a ROS 2 topic ("rt/" + name) with a ROS 2 QoS
// profile, over a shared dds::Participant (RAII, like components/dds/pubsub.h, whose endpoints
// are tied to the pipeline's own topic table).
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
class RosWriter {
 public:
  using Message = typename PubSubType::type;
  // topic: the DDS name (DdsTopicName()).
  RosWriter(std::shared_ptr<RosSession> session, const std::string& topic, const RosQos& qos)
      : session_(std::move(session)) {
    auto* t = session_->participant().template GetTopic<PubSubType>(topic);
    writer_ = session_->publisher()->create_datawriter(t, RosWriterQos(qos));
    if (writer_ == nullptr) throw std::runtime_error("Fast DDS: cannot create writer on " + topic);
  }
  ~RosWriter() {
    if (writer_ != nullptr) session_->publisher()->delete_datawriter(writer_);
  }
  RosWriter(const RosWriter&) = delete;
  RosWriter& operator=(const RosWriter&) = delete;

  bool Write(const Message& message) { return writer_->write(const_cast<Message*>(&message)); }
  int matched() const {
    eprosima::fastdds::dds::PublicationMatchedStatus status;
    writer_->get_publication_matched_status(status);
    return status.current_count;
  }
  bool WaitForAcknowledgments(std::chrono::milliseconds timeout) {
    const eprosima::fastrtps::Duration_t d(
        static_cast<int32_t>(timeout.count() / 1000),
        static_cast<uint32_t>(timeout.count() % 1000) * 1000000u);
    return writer_->wait_for_acknowledgments(d) ==
           eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
  }

 private:
  std::shared_ptr<RosSession> session_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
};

template <class PubSubType>
class RosReader {
 public:
  using Message = typename PubSubType::type;
  using Callback = std::function<void(Message&&)>;

  // callback runs on a DDS listener thread: keep it short.
  RosReader(std::shared_ptr<RosSession> session, const std::string& topic, const RosQos& qos,
            Callback callback)
      : session_(std::move(session)), listener_(std::move(callback)) {
    auto* t = session_->participant().template GetTopic<PubSubType>(topic);
    reader_ = session_->subscriber()->create_datareader(t, RosReaderQos(qos), &listener_);
    if (reader_ == nullptr) throw std::runtime_error("Fast DDS: cannot create reader on " + topic);
  }
  ~RosReader() {
    if (reader_ != nullptr) {
      reader_->set_listener(nullptr);
      session_->subscriber()->delete_datareader(reader_);
    }
  }
  RosReader(const RosReader&) = delete;
  RosReader& operator=(const RosReader&) = delete;

  int matched() const { return listener_.matched.load(); }

 private:
  class Listener : public eprosima::fastdds::dds::DataReaderListener {
   public:
    explicit Listener(Callback cb) : callback(std::move(cb)) {}
    void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
      eprosima::fastdds::dds::SampleInfo info;
      while (true) {
        Message message;
        if (reader->take_next_sample(&message, &info) !=
            eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
          break;
        }
        if (info.valid_data) callback(std::move(message));
      }
    }
    void on_subscription_matched(
        eprosima::fastdds::dds::DataReader*,
        const eprosima::fastdds::dds::SubscriptionMatchedStatus& status) override {
      matched.store(status.current_count);
    }
    Callback callback;
    std::atomic<int> matched{0};
  };

  std::shared_ptr<RosSession> session_;
  Listener listener_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
};

}  // namespace dygslam::ros2
