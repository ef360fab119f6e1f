// A malformed sample on the wire from another participant (raw bytes published under the
// dygslam CameraPose type name, boolean byte = 2): the generated deserialize() lets fastcdr's
// BadParamException escape, so it comes out of DataReader::take_next_sample -- in a listener
// without try/catch that is std::terminate, i.e. any participant on the domain could kill a
// component with one sample. Catching it around take_next_sample is not enough either: the
// sample is not consumed and the next take throws again (pinned below with the raw generated
// type). The components therefore register every type through dds::GuardedType
// (components/dds/guarded_type.h, used by Participant::GetTopic): its deserialize() catches every
// exception and rejects oversized payloads, returns false, and Fast DDS drops the sample.
#include <fastcdr/exceptions/Exception.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "components/convert.h"
#include "components/dds/guarded_type.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/dds/qos.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "fuzz/dds_decoders.h"

namespace dygslam {
namespace {
using namespace eprosima::fastdds::dds;  // NOLINT
using eprosima::fastrtps::types::ReturnCode_t;

constexpr int kDomain = 88;
constexpr const char* kTopic = "dygslam/camera_pose";

// Publishes raw payload bytes (encapsulation + CDR) under another type's name.
class RawType : public TopicDataType {
 public:
  explicit RawType(const std::string& name) {
    setName(name.c_str());
    m_typeSize = 4096;  // initial allocation; larger payloads are reallocated
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override {
    const auto* bytes = static_cast<std::vector<uint8_t>*>(data);
    if (bytes->size() > payload->max_size) return false;
    std::memcpy(payload->data, bytes->data(), bytes->size());
    payload->length = static_cast<uint32_t>(bytes->size());
    payload->encapsulation = CDR_LE;
    return true;
  }
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t*, void*) override { return false; }
  std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
    return
        [data] { return static_cast<uint32_t>(static_cast<std::vector<uint8_t>*>(data)->size()); };
  }
  void* createData() override { return new std::vector<uint8_t>(); }
  void deleteData(void* data) override { delete static_cast<std::vector<uint8_t>*>(data); }
  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override { return false; }
};

DomainParticipant* MakeParticipant(const std::string& name, int domain_offset) {
  DomainParticipantQos qos = PARTICIPANT_QOS_DEFAULT;
  qos.name(name);
  qos.transport().use_builtin_transports = false;
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.push_back("127.0.0.1");
  qos.transport().user_transports.push_back(udp);
  return DomainParticipantFactory::get_instance()->create_participant(kDomain + domain_offset, qos);
}

// Counts samples whose take threw / decoded / were rejected.
class CountingListener : public DataReaderListener {
 public:
  void on_data_available(DataReader* reader) override {
    for (int guard = 0; guard < 1000; ++guard) {  // bounded: a stuck sample cannot spin forever
      msg::CameraPose pose;
      SampleInfo info;
      ReturnCode_t rc;
      try {
        rc = reader->take_next_sample(&pose, &info);
      } catch (const eprosima::fastcdr::exception::Exception&) {
        ++exceptions;
        continue;
      }
      if (rc != ReturnCode_t::RETCODE_OK) return;
      if (info.valid_data) ++good;
    }
    ++stuck;
  }
  void on_subscription_matched(DataReader*, const SubscriptionMatchedStatus& s) override {
    matched = s.current_count;
  }
  std::atomic<int> good{0}, exceptions{0}, stuck{0}, matched{0};
};

struct Result {
  int good, exceptions, stuck;
};

// Publishes bad, good, bad, good, ... (5 each) from a raw writer to a reader of `reader_type`.
Result Exchange(TopicDataType* reader_type, const std::vector<uint8_t>& bad,
                const std::vector<uint8_t>& good, int domain_offset) {
  DomainParticipant* reader_p = MakeParticipant("reader", domain_offset);
  DomainParticipant* writer_p = MakeParticipant("intruder", domain_offset);
  EXPECT_NE(reader_p, nullptr);
  EXPECT_NE(writer_p, nullptr);
  TypeSupport real(reader_type);
  real.register_type(reader_p);
  TypeSupport raw(new RawType(real.get_type_name()));
  raw.register_type(writer_p);
  Topic* rt = reader_p->create_topic(kTopic, real.get_type_name(), TOPIC_QOS_DEFAULT);
  Topic* wt = writer_p->create_topic(kTopic, raw.get_type_name(), TOPIC_QOS_DEFAULT);
  CountingListener listener;
  DataReaderQos rq = DATAREADER_QOS_DEFAULT;
  rq.reliability().kind = RELIABLE_RELIABILITY_QOS;
  DataReader* reader =
      reader_p->create_subscriber(SUBSCRIBER_QOS_DEFAULT)->create_datareader(rt, rq, &listener);
  DataWriterQos wq = DATAWRITER_QOS_DEFAULT;
  wq.reliability().kind = RELIABLE_RELIABILITY_QOS;
  wq.history().depth = 50;
  DataWriter* writer = writer_p->create_publisher(PUBLISHER_QOS_DEFAULT)->create_datawriter(wt, wq);
  EXPECT_NE(reader, nullptr);
  EXPECT_NE(writer, nullptr);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  auto writer_matched = [&] {
    PublicationMatchedStatus st;
    writer->get_publication_matched_status(st);
    return st.current_count;
  };
  while ((listener.matched.load() < 1 || writer_matched() < 1) &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(listener.matched.load(), 1);
  EXPECT_EQ(writer_matched(), 1);
  std::vector<uint8_t> b = bad, g = good;
  for (int i = 0; i < 5; ++i) {
    EXPECT_TRUE(writer->write(&b));
    EXPECT_TRUE(writer->write(&g));
  }
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (listener.good.load() < 5 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  reader->set_listener(nullptr);
  reader_p->delete_contained_entities();
  writer_p->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(reader_p);
  DomainParticipantFactory::get_instance()->delete_participant(writer_p);
  std::printf("good %d exceptions %d stuck %d matched %d\n", listener.good.load(),
              listener.exceptions.load(), listener.stuck.load(), listener.matched.load());
  return {listener.good.load(), listener.exceptions.load(), listener.stuck.load()};
}

// The bad payload: a valid CameraPose with one boolean byte set to 2.
void Payloads(std::vector<uint8_t>* bad, std::vector<uint8_t>* good) {
  msg::CameraPose cp;
  cp.has_pose(true);
  cp.world_from_cam().orientation().w(1);
  *good = fuzz::Serialize<msg::CameraPosePubSubType>(cp);
  for (size_t i = 4; i < good->size(); ++i) {
    if ((*good)[i] != 1) continue;
    std::vector<uint8_t> probe = *good;
    probe[i] = 2;
    if (fuzz::DecodeSample(fuzz::SampleKind::kCameraPose, probe.data(), probe.size()).status ==
        fuzz::DecodeStatus::kCdrException) {
      *bad = probe;
      return;
    }
  }
}

TEST(DdsMalformed, GeneratedTypeThrowsOutOfTakeAndTheSampleStaysStuck) {
  std::vector<uint8_t> bad, good;
  Payloads(&bad, &good);
  ASSERT_FALSE(bad.empty());
  const Result r = Exchange(new msg::CameraPosePubSubType(), bad, good, 0);
  // Pins Fast DDS 2.9.1 + fastddsgen 2.3.0 behaviour (why the components need GuardedType).
  EXPECT_GT(r.exceptions, 5) << "take_next_sample no longer throws for a bad boolean";
  EXPECT_GT(r.stuck, 0) << "the bad sample is now consumed by a throwing take";
}

TEST(DdsMalformed, GuardedTypeDropsBadSamplesAndReadingGoesOn) {
  std::vector<uint8_t> bad, good;
  Payloads(&bad, &good);
  ASSERT_FALSE(bad.empty());
  using Guarded = dds::GuardedType<msg::CameraPosePubSubType>;
  const int64_t rejected_before = Guarded::rejected_count();
  const Result r = Exchange(new Guarded(), bad, good, 1);
  EXPECT_EQ(r.good, 5) << "valid samples after malformed ones were lost";
  EXPECT_EQ(r.exceptions, 0);
  EXPECT_EQ(r.stuck, 0);
  EXPECT_EQ(Guarded::rejected_count() - rejected_before, 5);
}

// The components' own path: dds::Participant::GetTopic registers the type (GuardedType) and a
// dds::Reader with the CameraPose QoS receives from an intruder that publishes malformed,
// valid and oversized (valid + 1.1 MB of trailing bytes, above the 1 MB CameraPose limit)
// samples. The reader's listener thread survives, every valid sample arrives, every bad one is
// dropped.
TEST(DdsMalformed, ComponentReaderSurvivesMalformedAndOversizedSamples) {
  std::vector<uint8_t> bad, good;
  Payloads(&bad, &good);
  ASSERT_FALSE(bad.empty());
  std::vector<uint8_t> oversized = good;
  oversized.resize(good.size() + (1100u << 10), 0);

  using Guarded = dds::GuardedType<msg::CameraPosePubSubType>;
  const int64_t rejected_before = Guarded::rejected_count();
  dds::ParticipantOptions options;
  options.domain_id = kDomain + 2;
  options.name = "slam";
  options.use_xml_profile = false;
  auto participant = dds::Participant::Create(options);
  std::atomic<int> received{0};
  dds::Reader<msg::CameraPosePubSubType> reader(participant, dds::topics::kCameraPose,
                                                dds::TopicKind::kCameraPose,
                                                [&received](msg::CameraPose&& pose) {
                                                  if (pose.has_pose()) ++received;
                                                });

  DomainParticipant* writer_p = MakeParticipant("intruder", 2);
  ASSERT_NE(writer_p, nullptr);
  TypeSupport raw(new RawType(msg::CameraPosePubSubType().getName()));
  ASSERT_EQ(raw.register_type(writer_p), ReturnCode_t::RETCODE_OK);
  Topic* topic =
      writer_p->create_topic(dds::topics::kCameraPose, raw.get_type_name(), TOPIC_QOS_DEFAULT);
  ASSERT_NE(topic, nullptr);
  DataWriterQos wq = dds::WriterQos(dds::TopicKind::kCameraPose);
  wq.history().kind = KEEP_ALL_HISTORY_QOS;
  DataWriter* writer =
      writer_p->create_publisher(PUBLISHER_QOS_DEFAULT)->create_datawriter(topic, wq);
  ASSERT_NE(writer, nullptr);
  EXPECT_TRUE(reader.WaitForWriters(1, std::chrono::seconds(15)));
  for (int i = 0; i < 5; ++i) {
    EXPECT_TRUE(writer->write(&bad));
    EXPECT_TRUE(writer->write(&good));
    EXPECT_TRUE(writer->write(&oversized));
  }
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while ((received.load() < 5 || Guarded::rejected_count() - rejected_before < 10) &&
         std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  writer_p->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(writer_p);
  EXPECT_EQ(received.load(), 5) << "valid samples after malformed ones were lost";
  EXPECT_EQ(Guarded::rejected_count() - rejected_before, 10) << "5 malformed + 5 oversized";
}

}  // namespace
}  // namespace dygslam
