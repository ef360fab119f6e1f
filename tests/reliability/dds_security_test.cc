// DDS Security with Fast DDS's builtin plugins (components/dds/security.h) and the test
// credentials of scripts/make_dds_certs.sh: authenticated participants exchange camera poses;
// a participant without credentials, or with credentials from another CA, reads nothing.
// Runs in a private network namespace (tests/reliability/CMakeLists.txt); own domain id.
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/dds/qos.h"
#include "components/dds/security.h"
#include "core/base/error.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;
using namespace eprosima::fastdds::dds;  // NOLINT
using eprosima::fastrtps::types::ReturnCode_t;

constexpr const char* kTopic = "dygslam/camera_pose";  // components/dds/qos.h topics::kCameraPose
constexpr int kDomain = 87;

// A participant on loopback UDP with (or without) security, one topic, optional writer/reader.
class Node : public DataReaderListener {
 public:
  Node(const std::string& name, const dds::SecurityOptions& security) {
    DomainParticipantQos qos = PARTICIPANT_QOS_DEFAULT;
    qos.name(name);
    qos.transport().use_builtin_transports = false;
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.push_back("127.0.0.1");
    qos.transport().user_transports.push_back(udp);
    dds::ApplySecurity(security, &qos);
    participant_ = DomainParticipantFactory::get_instance()->create_participant(kDomain, qos);
    if (participant_ == nullptr) return;
    TypeSupport type(new msg::CameraPosePubSubType());
    type.register_type(participant_);
    topic_ = participant_->create_topic(kTopic, type.get_type_name(), TOPIC_QOS_DEFAULT);
  }
  ~Node() override {
    if (participant_ == nullptr) return;
    if (reader_ != nullptr) reader_->set_listener(nullptr);
    participant_->delete_contained_entities();
    DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  bool ok() const { return participant_ != nullptr && topic_ != nullptr; }

  void MakeWriter() {
    Publisher* pub = participant_->create_publisher(PUBLISHER_QOS_DEFAULT);
    DataWriterQos q = DATAWRITER_QOS_DEFAULT;
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.durability().kind = TRANSIENT_LOCAL_DURABILITY_QOS;
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = 100;
    writer_ = pub->create_datawriter(topic_, q);
  }
  void MakeReader() {
    Subscriber* sub = participant_->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
    DataReaderQos q = DATAREADER_QOS_DEFAULT;
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.durability().kind = TRANSIENT_LOCAL_DURABILITY_QOS;
    reader_ = sub->create_datareader(topic_, q, this);
  }
  bool Write(uint64_t seq) {
    msg::CameraPose p;
    p.header().seq(seq);
    p.has_pose(true);
    p.world_from_cam().orientation().w(1);
    p.world_from_cam().position().x(0.01 * seq);
    return writer_->write(&p);
  }
  void on_data_available(DataReader* reader) override {
    msg::CameraPose p;
    SampleInfo info;
    while (reader->take_next_sample(&p, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) ++received;
    }
  }
  void on_subscription_matched(DataReader*, const SubscriptionMatchedStatus& s) override {
    matched = s.current_count;
  }
  int writer_matches() const {
    PublicationMatchedStatus s;
    writer_->get_publication_matched_status(s);
    return s.current_count;
  }

  std::atomic<int> received{0};
  std::atomic<int> matched{0};

 private:
  DomainParticipant* participant_ = nullptr;
  Topic* topic_ = nullptr;
  DataWriter* writer_ = nullptr;
  DataReader* reader_ = nullptr;
};

bool WaitFor(const std::function<bool()>& cond, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!cond()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

class DdsSecurity : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    certs_ = new std::string(testing::MakeTempDir("dds_certs"));
    const std::string script = std::string(DYGSLAM_TEST_SOURCE_DIR) + "/scripts/make_dds_certs.sh";
    const std::string cmd =
        script + " " + *certs_ + " slam recorder viewer > " + *certs_ + "/log.txt 2>&1";
    script_status_ = std::system(cmd.c_str());
  }
  static void TearDownTestSuite() { delete certs_; }
  void SetUp() override {
    ASSERT_TRUE(dds::SecurityPluginsAvailable());
    ASSERT_EQ(script_status_, 0) << "make_dds_certs.sh failed, see " << *certs_ << "/log.txt";
  }
  static dds::SecurityOptions Identity(const std::string& name) {
    return dds::SecurityOptions::FromDirectory(*certs_ + "/" + name);
  }
  static std::string* certs_;
  static int script_status_;
};
std::string* DdsSecurity::certs_ = nullptr;
int DdsSecurity::script_status_ = -1;

TEST_F(DdsSecurity, AuthenticatedParticipantsExchangePosesOthersReadNothing) {
  Node slam("slam", Identity("slam"));
  ASSERT_TRUE(slam.ok()) << "secure participant not created (plugins or credentials rejected)";
  slam.MakeWriter();
  Node recorder("recorder", Identity("recorder"));
  ASSERT_TRUE(recorder.ok());
  recorder.MakeReader();
  // No credentials at all.
  Node plain("eavesdropper", dds::SecurityOptions());
  ASSERT_TRUE(plain.ok());
  plain.MakeReader();
  // Well-formed credentials issued by another CA.
  Node rogue("rogue", Identity("rogue"));
  if (rogue.ok()) rogue.MakeReader();

  ASSERT_TRUE(WaitFor([&] { return recorder.matched.load() >= 1; }, std::chrono::seconds(20)))
      << "authenticated reader never matched the writer";
  for (uint64_t i = 0; i < 20; ++i) ASSERT_TRUE(slam.Write(i));
  ASSERT_TRUE(WaitFor([&] { return recorder.received.load() >= 20; }, std::chrono::seconds(10)))
      << "authenticated reader got " << recorder.received.load() << " of 20 poses";
  // Give the others ample time (discovery + handshake retries) and write more.
  std::this_thread::sleep_for(std::chrono::seconds(3));
  for (uint64_t i = 20; i < 30; ++i) ASSERT_TRUE(slam.Write(i));
  ASSERT_TRUE(WaitFor([&] { return recorder.received.load() >= 30; }, std::chrono::seconds(10)));
  std::this_thread::sleep_for(std::chrono::seconds(1));
  EXPECT_EQ(plain.matched.load(), 0) << "an unauthenticated participant matched the secure writer";
  EXPECT_EQ(plain.received.load(), 0) << "an unauthenticated participant read poses";
  EXPECT_EQ(rogue.matched.load(), 0) << "a participant from another CA matched the secure writer";
  EXPECT_EQ(rogue.received.load(), 0) << "a participant from another CA read poses";
  EXPECT_EQ(slam.writer_matches(), 1) << "the writer matched someone besides the recorder";
  // Control: the unauthenticated reader itself works -- it reads an unsecured writer at once.
  Node plain_writer("plain_writer", dds::SecurityOptions());
  ASSERT_TRUE(plain_writer.ok());
  plain_writer.MakeWriter();
  ASSERT_TRUE(
      WaitFor([&] { return plain_writer.writer_matches() >= 1; }, std::chrono::seconds(10)));
  for (uint64_t i = 0; i < 5; ++i) ASSERT_TRUE(plain_writer.Write(i));
  EXPECT_TRUE(WaitFor([&] { return plain.received.load() >= 5; }, std::chrono::seconds(10)))
      << "control failed: plain reader got " << plain.received.load() << " of 5 unsecured samples";
  EXPECT_EQ(recorder.received.load(), 30) << "the secure reader accepted unsecured samples";
}

TEST_F(DdsSecurity, InsecureWriterCannotInjectIntoSecureReader) {
  Node recorder("recorder", Identity("recorder"));
  ASSERT_TRUE(recorder.ok());
  recorder.MakeReader();
  Node intruder("intruder", dds::SecurityOptions());
  ASSERT_TRUE(intruder.ok());
  intruder.MakeWriter();
  std::this_thread::sleep_for(std::chrono::seconds(3));
  for (uint64_t i = 0; i < 10; ++i) intruder.Write(i);
  std::this_thread::sleep_for(std::chrono::seconds(2));
  EXPECT_EQ(intruder.writer_matches(), 0);
  EXPECT_EQ(recorder.received.load(), 0)
      << "a secure reader accepted poses from an unauthenticated writer";
}

TEST_F(DdsSecurity, MissingOrUnreadableCredentialsNameTheFile) {
  const fs::path dir = testing::MakeTempDir("dds_certs_partial");
  try {
    dds::SecurityOptions::FromDirectory((dir / "nope").string());
    ADD_FAILURE() << "accepted a missing directory";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nope"), std::string::npos) << e.what();
  }
  fs::copy(*certs_ + "/viewer", dir / "viewer");
  fs::remove(dir / "viewer" / "permissions.smime");
  try {
    dds::SecurityOptions::FromDirectory((dir / "viewer").string());
    ADD_FAILURE() << "accepted a directory without permissions.smime";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("permissions.smime"), std::string::npos) << e.what();
  }
  // A FIFO in place of a credential file is named as such (not "not found"), and never opened
  // (its open would wait for a writer).
  ASSERT_EQ(mkfifo((dir / "viewer" / "permissions.smime").c_str(), 0600), 0);
  try {
    dds::SecurityOptions::FromDirectory((dir / "viewer").string());
    ADD_FAILURE() << "accepted a FIFO as permissions.smime";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("permissions.smime"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a regular file: a FIFO"), std::string::npos)
        << e.what();
  }
  // Disabled options add nothing; enabled ones add the three plugins.
  DomainParticipantQos qos;
  const size_t defaults = qos.properties().properties().size();
  dds::ApplySecurity(dds::SecurityOptions(), &qos);
  EXPECT_EQ(qos.properties().properties().size(), defaults);
  dds::ApplySecurity(Identity("viewer"), &qos);
  int plugins = 0;
  for (const auto& p : qos.properties().properties()) {
    plugins += p.name() == "dds.sec.auth.plugin" || p.name() == "dds.sec.access.plugin" ||
               p.name() == "dds.sec.crypto.plugin";
  }
  EXPECT_EQ(plugins, 3);
}

// Credentials that could never authenticate are refused when read, naming the files: a
// certificate not issued by the folder's CA, and participants of one run that trust different
// CAs (Fast DDS would only stall discovery, without a message).
TEST_F(DdsSecurity, CertificateFromAnotherCaIsRefusedByName) {
  const fs::path dir = testing::MakeTempDir("dds_certs_mixed");
  fs::copy(*certs_ + "/slam", dir / "slam");
  fs::copy_file(*certs_ + "/rogue/cert.pem", dir / "slam" / "cert.pem",
                fs::copy_options::overwrite_existing);
  fs::copy_file(*certs_ + "/rogue/key.pem", dir / "slam" / "key.pem",
                fs::copy_options::overwrite_existing);
  try {
    dds::SecurityOptions::FromDirectory((dir / "slam").string());
    ADD_FAILURE() << "accepted a certificate of another CA";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cert.pem"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not issued by the identity CA"), std::string::npos)
        << e.what();
  }
  // A private key that is not PEM, or not the certificate's, is named.
  fs::copy((*certs_ + "/recorder"), dir / "recorder");
  std::ofstream(dir / "recorder" / "key.pem") << "garbage\n";
  try {
    dds::SecurityOptions::FromDirectory((dir / "recorder").string());
    ADD_FAILURE() << "accepted a garbage private key";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("key.pem"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a PEM private key"), std::string::npos) << e.what();
  }
  fs::copy_file(*certs_ + "/slam/key.pem", dir / "recorder" / "key.pem",
                fs::copy_options::overwrite_existing);
  try {
    dds::SecurityOptions::FromDirectory((dir / "recorder").string());
    ADD_FAILURE() << "accepted another identity's private key";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not the key of the identity certificate"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(
      dds::CheckSameIdentityCa({{"slam", Identity("slam")}, {"recorder", Identity("recorder")}}));
  try {
    dds::CheckSameIdentityCa({{"slam", Identity("slam")}, {"rogue", Identity("rogue")}});
    ADD_FAILURE() << "accepted participants of two CAs";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "component 'rogue' trusts another identity CA than component 'slam'"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(DdsSecurity, TamperedPermissionsAreRejectedAtParticipantCreation) {
  const fs::path dir = testing::MakeTempDir("dds_certs_tampered");
  fs::copy(*certs_ + "/viewer", dir / "viewer");
  // Edit the signed permissions text (widen nothing, just change a byte): signature check fails.
  const fs::path p = dir / "viewer" / "permissions.smime";
  std::ifstream in(p);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  in.close();
  const auto at = text.find("<max>232</max>");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 14, "<max>231</max>");
  std::ofstream(p) << text;
  Node node("tampered", dds::SecurityOptions::FromDirectory((dir / "viewer").string()));
  EXPECT_FALSE(node.ok()) << "a participant was created with tampered permissions";
}

// The components' own participants: ParticipantOptions::security goes through
// Participant::Create (default transports, SHM + UDP loopback). Secured component participants
// exchange poses; a component participant without security reads nothing; tampered credentials
// are an InputError at creation.
TEST_F(DdsSecurity, ComponentParticipantsApplySecurityOptions) {
  auto make = [](const std::string& name, const dds::SecurityOptions& security) {
    dds::ParticipantOptions options;
    options.domain_id = kDomain + 1;
    options.name = name;
    options.use_xml_profile = false;
    options.security = security;
    return dds::Participant::Create(options);
  };
  auto slam = make("slam", Identity("slam"));
  auto recorder = make("recorder", Identity("recorder"));
  auto plain = make("eavesdropper", dds::SecurityOptions());
  std::atomic<int> received{0}, eavesdropped{0};
  dds::Reader<msg::CameraPosePubSubType> reader(recorder, dds::topics::kCameraPose,
                                                dds::TopicKind::kCameraPose,
                                                [&received](msg::CameraPose&&) { ++received; });
  dds::Reader<msg::CameraPosePubSubType> eavesdropper(
      plain, dds::topics::kCameraPose, dds::TopicKind::kCameraPose,
      [&eavesdropped](msg::CameraPose&&) { ++eavesdropped; });
  dds::Writer<msg::CameraPosePubSubType> writer(slam, dds::topics::kCameraPose,
                                                dds::TopicKind::kCameraPose);
  ASSERT_TRUE(writer.WaitForReaders(1, std::chrono::seconds(20)))
      << "secured component participants never matched";
  for (uint64_t i = 0; i < 10; ++i) {
    msg::CameraPose pose;
    pose.header().seq(i);
    pose.has_pose(true);
    pose.world_from_cam().orientation().w(1);
    ASSERT_TRUE(writer.Write(pose));
  }
  EXPECT_TRUE(WaitFor([&] { return received.load() >= 10; }, std::chrono::seconds(10)))
      << "secured reader got " << received.load() << " of 10 poses";
  std::this_thread::sleep_for(std::chrono::seconds(2));
  EXPECT_EQ(writer.matched(), 1) << "the secured writer matched an unauthenticated reader";
  EXPECT_EQ(eavesdropper.matched(), 0);
  EXPECT_EQ(eavesdropped.load(), 0) << "a component participant without security read poses";

  // Tampered permissions: Create() throws an InputError naming the permissions file.
  const fs::path dir = testing::MakeTempDir("dds_certs_component_tampered");
  fs::copy(*certs_ + "/viewer", dir / "viewer");
  const fs::path p = dir / "viewer" / "permissions.smime";
  std::ifstream in(p);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  in.close();
  const auto at = text.find("<max>232</max>");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 14, "<max>231</max>");
  std::ofstream(p) << text;
  try {
    make("tampered", dds::SecurityOptions::FromDirectory((dir / "viewer").string()));
    ADD_FAILURE() << "a component participant was created with tampered permissions";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("credentials were rejected"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dygslam
