// Typed DataWriter / DataReader wrappers (RAII) over a shared Participant.
//   auto w = Writer<msg::RgbdFramePubSubType>(participant, topics::kRgbdFrame, TopicKind::kRgbdFrame);
//   w.Write(frame);
//   Reader<msg::CameraPosePubSubType> r(participant, topics::kCameraPose, TopicKind::kCameraPose,
//       [](msg::CameraPose&& pose) { ... });   // called on the DDS listener thread
// Callbacks must be short (enqueue + notify); the components do their work on their own threads.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include <fastdds/dds/core/status/SubscriptionMatchedStatus.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>

#include "components/dds/participant.h"
#include "components/dds/qos.h"

namespace dygslam::dds {

template <class PubSubType>
class Writer {
 public:
  using Message = typename PubSubType::type;

  Writer(std::shared_ptr<Participant> participant, const std::string& topic, TopicKind kind)
      : participant_(std::move(participant)) {
    auto* t = participant_->template GetTopic<PubSubType>(topic);
    writer_ = participant_->publisher()->create_datawriter(t, WriterQos(kind));
    if (writer_ == nullptr) throw std::runtime_error("Fast DDS: cannot create writer on " + topic);
  }
  ~Writer() {
    if (writer_ != nullptr) participant_->publisher()->delete_datawriter(writer_);
  }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // False if the middleware refused the sample (e.g. blocked longer than max_blocking_time).
  bool Write(const Message& message) {
    return writer_->write(const_cast<Message*>(&message));
  }
  int matched() const {
    eprosima::fastdds::dds::PublicationMatchedStatus status;
    writer_->get_publication_matched_status(status);
    return status.current_count;
  }
  // Waits until at least `count` readers are matched; false on timeout.
  bool WaitForReaders(int count, std::chrono::milliseconds timeout) const {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (matched() < count) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }
  // Waits until every matched reliable reader acknowledged all samples; false on timeout.
  bool WaitForAcknowledgments(std::chrono::milliseconds timeout) {
    const eprosima::fastrtps::Duration_t d(static_cast<int32_t>(timeout.count() / 1000),
                                           static_cast<uint32_t>(timeout.count() % 1000) * 1000000u);
    return writer_->wait_for_acknowledgments(d) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
  }

 private:
  std::shared_ptr<Participant> participant_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
};

template <class PubSubType>
class Reader {
 public:
  using Message = typename PubSubType::type;
  using Callback = std::function<void(Message&&)>;

  Reader(std::shared_ptr<Participant> participant, const std::string& topic, TopicKind kind,
         Callback callback)
      : participant_(std::move(participant)), listener_(std::move(callback)) {
    auto* t = participant_->template GetTopic<PubSubType>(topic);
    reader_ = participant_->subscriber()->create_datareader(t, ReaderQos(kind), &listener_);
    if (reader_ == nullptr) throw std::runtime_error("Fast DDS: cannot create reader on " + topic);
  }
  ~Reader() {
    if (reader_ != nullptr) {
      reader_->set_listener(nullptr);
      participant_->subscriber()->delete_datareader(reader_);
    }
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  int matched() const { return listener_.matched.load(); }
  bool WaitForWriters(int count, std::chrono::milliseconds timeout) const {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (matched() < count) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }

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

  std::shared_ptr<Participant> participant_;
  Listener listener_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
};

}  // namespace dygslam::dds
