// Typed DataWriter / DataReader (RAII) on any publisher / subscriber of a Participant: the one
// implementation behind the pipeline's endpoints (components/dds/pubsub.h: Writer / Reader with
// the pipeline's QoS table) and the ROS 2 bridge's (bridge/ros2_endpoint.h: ROS 2 QoS profiles on
// a partition-less publisher / subscriber).
//
// `owner` keeps whatever owns the publisher / subscriber alive (the Participant, or the bridge's
// RosSession) until the endpoint has been deleted.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fastdds/dds/core/status/SampleRejectedStatus.hpp>
#include <fastdds/dds/core/status/SubscriptionMatchedStatus.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "components/dds/participant.h"
#include "components/protocol.h"
#include "components/sample_order.h"

namespace dygslam::dds {

namespace internal {
// Polls `matched` every 5 ms until it reaches `count`; false on timeout.
template <class Matched>
bool WaitForMatched(const Matched& matched, int count, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (matched() < count) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}
}  // namespace internal

// Samples a reader never delivered, as the middleware counts them (cumulative): `lost` (Fast DDS
// SampleLostStatus: a gap in the writer's sequence, e.g. a fragmented sample that never arrived
// whole because its fragments overflowed the socket buffers) and `rejected` (SampleRejectedStatus:
// the reader's resource limits).
// `missed` and `duplicates` come from the samples' sequence numbers (SequenceTracker): samples
// of a writer that never reached this reader (they left the writer's history while the reader
// was unreachable), and samples delivered again after a re-match (dropped, never handed on).
struct ReaderLosses {
  uint64_t lost = 0, rejected = 0;
  uint64_t missed = 0, duplicates = 0;
  std::string last_rejected_reason;  // "" before the first rejection
};
// Called on a DDS listener thread with the totals so far: keep it short.
using LossCallback = std::function<void(const ReaderLosses&)>;

template <class PubSubType>
class TypedWriter {
 public:
  using Message = typename PubSubType::type;

  TypedWriter(std::shared_ptr<const void> owner, Participant& participant,
              eprosima::fastdds::dds::Publisher* publisher, const std::string& topic,
              const eprosima::fastdds::dds::DataWriterQos& qos)
      : owner_(std::move(owner)), publisher_(publisher) {
    auto* t = participant.template GetTopic<PubSubType>(topic);
    writer_ = publisher_->create_datawriter(t, qos);
    if (writer_ == nullptr) throw std::runtime_error("Fast DDS: cannot create writer on " + topic);
  }
  ~TypedWriter() {
    if (writer_ != nullptr) publisher_->delete_datawriter(writer_);
  }
  TypedWriter(const TypedWriter&) = delete;
  TypedWriter& operator=(const TypedWriter&) = delete;

  // The writer's GUID as Fast DDS types it (GUID prefix of its participant + entity id).
  eprosima::fastrtps::rtps::GUID_t rtps_guid() const { return writer_->guid(); }
  // False if the middleware refused the sample (e.g. blocked longer than max_blocking_time).
  bool Write(const Message& message) { return writer_->write(const_cast<Message*>(&message)); }
  int matched() const {
    eprosima::fastdds::dds::PublicationMatchedStatus status;
    writer_->get_publication_matched_status(status);
    return status.current_count;
  }
  // Waits until at least `count` readers are matched; false on timeout.
  bool WaitForReaders(int count, std::chrono::milliseconds timeout) const {
    return internal::WaitForMatched([this] { return matched(); }, count, timeout);
  }
  // This writer's GUID (what readers see as the sample's publication handle), announced in the
  // component's STARTED status (components/protocol.h).
  WriterGuid guid() const {
    const eprosima::fastrtps::rtps::GUID_t& g = writer_->guid();
    WriterGuid out{};
    for (size_t i = 0; i < 12; ++i) out[i] = g.guidPrefix.value[i];
    for (size_t i = 0; i < 4; ++i) out[12 + i] = g.entityId.value[i];
    return out;
  }
  // Waits until every matched reliable reader acknowledged all samples; false on timeout.
  bool WaitForAcknowledgments(std::chrono::milliseconds timeout) {
    const eprosima::fastrtps::Duration_t d(
        static_cast<int32_t>(timeout.count() / 1000),
        static_cast<uint32_t>(timeout.count() % 1000) * 1000000u);
    return writer_->wait_for_acknowledgments(d) ==
           eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
  }

 private:
  std::shared_ptr<const void> owner_;  // destroyed last
  eprosima::fastdds::dds::Publisher* publisher_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
};

template <class PubSubType>
class TypedReader {
 public:
  using Message = typename PubSubType::type;
  using Callback = std::function<void(Message&&)>;
  // Also given the GUID of the writer of each sample (components/protocol.h).
  using CallbackWithWriter = std::function<void(Message&&, const WriterGuid&)>;

  // callback runs on a DDS listener thread: keep it short (enqueue + notify).
  TypedReader(std::shared_ptr<const void> owner, Participant& participant,
              eprosima::fastdds::dds::Subscriber* subscriber, const std::string& topic,
              const eprosima::fastdds::dds::DataReaderQos& qos, Callback callback,
              LossCallback on_loss = {})
      : TypedReader(std::move(owner), participant, subscriber, topic, qos,
                    CallbackWithWriter([cb = std::move(callback)](Message&& m, const WriterGuid&) {
                      cb(std::move(m));
                    }),
                    std::move(on_loss)) {}
  TypedReader(std::shared_ptr<const void> owner, Participant& participant,
              eprosima::fastdds::dds::Subscriber* subscriber, const std::string& topic,
              const eprosima::fastdds::dds::DataReaderQos& qos, CallbackWithWriter callback,
              LossCallback on_loss = {})
      : owner_(std::move(owner)),
        subscriber_(subscriber),
        listener_(std::move(callback), std::move(on_loss)) {
    auto* t = participant.template GetTopic<PubSubType>(topic);
    reader_ = subscriber_->create_datareader(t, qos, &listener_);
    if (reader_ == nullptr) throw std::runtime_error("Fast DDS: cannot create reader on " + topic);
  }
  ~TypedReader() {
    if (reader_ != nullptr) {
      reader_->set_listener(nullptr);
      subscriber_->delete_datareader(reader_);
    }
  }
  TypedReader(const TypedReader&) = delete;
  TypedReader& operator=(const TypedReader&) = delete;

  int matched() const { return listener_.matched.load(); }
  // Whether `writer` is matched now (its participant is there: announced writers tell a peer's
  // presence without a topic of its own). From the match events (Fast DDS 2.9 has no
  // get_matched_publications).
  bool IsMatched(const WriterGuid& writer) const {
    std::lock_guard<std::mutex> lock(listener_.state_mutex);
    return listener_.matched_writers.count(writer) > 0;
  }
  // Samples lost / rejected so far (ReaderLosses).
  ReaderLosses losses() const {
    std::lock_guard<std::mutex> lock(listener_.state_mutex);
    return listener_.losses;
  }
  // The reader's GUID (GUID prefix of its participant + entity id).
  eprosima::fastrtps::rtps::GUID_t rtps_guid() const { return reader_->guid(); }
  bool WaitForWriters(int count, std::chrono::milliseconds timeout) const {
    return internal::WaitForMatched([this] { return matched(); }, count, timeout);
  }

 private:
  class Listener : public eprosima::fastdds::dds::DataReaderListener {
   public:
    Listener(CallbackWithWriter cb, LossCallback loss_cb)
        : callback(std::move(cb)), on_loss(std::move(loss_cb)) {}
    void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
      eprosima::fastdds::dds::SampleInfo info;
      while (true) {
        Message message;
        if (reader->take_next_sample(&message, &info) !=
            eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
          break;
        }
        if (!info.valid_data) continue;
        WriterGuid writer{};
        for (size_t i = 0; i < writer.size(); ++i) writer[i] = info.publication_handle.value[i];
        if (!Sequenced(writer, info)) continue;
        callback(std::move(message), writer);
      }
    }
    void on_subscription_matched(
        eprosima::fastdds::dds::DataReader*,
        const eprosima::fastdds::dds::SubscriptionMatchedStatus& status) override {
      matched.store(status.current_count);
      WriterGuid writer{};
      for (size_t i = 0; i < writer.size(); ++i)
        writer[i] = status.last_publication_handle.value[i];
      std::lock_guard<std::mutex> lock(state_mutex);
      if (status.current_count_change > 0) matched_writers.insert(writer);
      if (status.current_count_change < 0) matched_writers.erase(writer);
    }
    void on_sample_lost(eprosima::fastdds::dds::DataReader*,
                        const eprosima::fastdds::dds::SampleLostStatus& status) override {
      ReaderLosses now;
      {
        std::lock_guard<std::mutex> lock(state_mutex);
        losses.lost = static_cast<uint64_t>(std::max(0, status.total_count));
        now = losses;
      }
      if (on_loss) on_loss(now);
    }
    void on_sample_rejected(eprosima::fastdds::dds::DataReader*,
                            const eprosima::fastrtps::SampleRejectedStatus& status) override {
      ReaderLosses now;
      {
        std::lock_guard<std::mutex> lock(state_mutex);
        losses.rejected = status.total_count;
        switch (status.last_reason) {
          case eprosima::fastdds::dds::REJECTED_BY_INSTANCES_LIMIT:
            losses.last_rejected_reason = "instances limit";
            break;
          case eprosima::fastdds::dds::REJECTED_BY_SAMPLES_LIMIT:
            losses.last_rejected_reason = "samples limit";
            break;
          case eprosima::fastdds::dds::REJECTED_BY_SAMPLES_PER_INSTANCE_LIMIT:
            losses.last_rejected_reason = "samples per instance limit";
            break;
          default:
            losses.last_rejected_reason = "unknown";
        }
        now = losses;
      }
      if (on_loss) on_loss(now);
    }
    // False for a sample that came before (dropped); counts the samples a jump skipped.
    bool Sequenced(const WriterGuid& writer, const eprosima::fastdds::dds::SampleInfo& info) {
      const uint64_t sequence = info.sample_identity.sequence_number().to64long();
      std::lock_guard<std::mutex> lock(state_mutex);
      if (!sequences.Accept(writer, sequence)) {
        losses.duplicates = sequences.duplicates();
        return false;
      }
      losses.missed = sequences.missed();
      return true;
    }
    CallbackWithWriter callback;
    LossCallback on_loss;
    SequenceTracker sequences;
    // The sequence tracking, the losses and the matched writers: guarded by state_mutex.
    std::set<WriterGuid> matched_writers;
    std::atomic<int> matched{0};
    mutable std::mutex state_mutex;
    ReaderLosses losses;
  };

  std::shared_ptr<const void> owner_;  // destroyed last
  eprosima::fastdds::dds::Subscriber* subscriber_;
  Listener listener_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
};

}  // namespace dygslam::dds
