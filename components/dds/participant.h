// Fast DDS participant factory for the dygslam components.
//
// Default transports (no XML profile): builtin transports off; shared memory with a 16 MiB
// segment (640x480 RGB-D frames are ~1.5 MB; the 512 KiB default segment makes large reliable
// samples stall) + UDPv4 restricted to 127.0.0.1 (interface whitelist) with 4 MiB socket buffers.
// Nothing leaves the machine.
//
// Multi-machine use: set FASTRTPS_DEFAULT_PROFILES_FILE=/path/profiles.xml. The factory then calls
// DomainParticipantFactory::load_profiles() and starts from get_default_participant_qos(), i.e.
// the XML's default participant profile (is_default_profile="true") defines the transports,
// discovery and interfaces; only the participant name is set in code. (Copying
// PARTICIPANT_QOS_DEFAULT would silently ignore the XML.) Set ParticipantOptions::use_xml_profile
// = false to force the loopback default even when the variable is set.
#pragma once

#include <cstdint>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "components/dds/guarded_type.h"
#include "components/dds/network_options.h"
#include "components/dds/security.h"

namespace dygslam::dds {

struct ParticipantOptions {
  int domain_id = 0;
  std::string name = "dygslam";
  // Honour FASTRTPS_DEFAULT_PROFILES_FILE when it is set.
  bool use_xml_profile = true;
  // With an XML profile: the participant profile of this name if the XML has one, else the
  // XML's default profile ("" = always the default profile).
  std::string xml_profile_name;
  // Participant USER_DATA (e.g. ROS 2's "enclave=/;"), applied with or without an XML profile.
  std::string user_data;
  bool use_shm = true;
  bool use_udp_loopback = true;
  uint32_t shm_segment_size = 16u << 20;   // bytes
  uint32_t socket_buffer_size = 4u << 20;  // bytes, UDP send + receive
  // DDS partition of every reader and writer of this participant ("" = the default partition).
  // `dygslam run` gives each run its own partition so that two runs on the same domain (two
  // users on one machine) never exchange samples; components started by hand use "".
  std::string partition;
  // DDS Security (authentication, access control, encryption); off by default. Applied to the
  // XML-profile and the default QoS alike.
  SecurityOptions security;
  // Interfaces, shared memory and discovery server (default: this machine only). Ignored when an
  // XML profile is used (the XML then says it all).
  NetworkOptions network;
  void Check() const;
};

// The discovery server's GUID prefix for server id `id` (0..255): the one Fast DDS's tools use
// (44.53.<id>.5f.45.50.52.4f.53.49.4d.41), so `fastdds discovery -i ID` works as a server too.
std::string DiscoveryServerGuidPrefix(int id = 0);

// Runs a discovery server on `listen` ("ADDRESS:PORT") until `stop_requested()` returns true
// (polled every 100 ms). Clients: NetworkOptions::discovery_server = the same "ADDRESS:PORT".
void RunDiscoveryServer(const std::string& listen, int domain_id,
                        const std::function<bool()>& stop_requested);

// Domain id from DYGSLAM_DOMAIN_ID (0..232) if set, else `fallback`.
int DomainIdFromEnvironment(int fallback = 0);

// Owns one DomainParticipant (deleted with all its entities on destruction) and the topics
// created on it. Thread-safe topic creation. Share it with std::shared_ptr between the readers /
// writers that use it; they keep it alive.
class Participant {
 public:
  static std::shared_ptr<Participant> Create(const ParticipantOptions& options);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  eprosima::fastdds::dds::DomainParticipant* get() const { return participant_; }
  int domain_id() const { return domain_id_; }
  bool uses_xml_profile() const { return uses_xml_profile_; }

  // Registers `PubSubType` once, wrapped in GuardedType (malformed or oversized samples are
  // dropped instead of throwing out of take), and returns the topic `name` (created once).
  template <class PubSubType>
  eprosima::fastdds::dds::Topic* GetTopic(const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = topics_.find(name);
    if (it != topics_.end()) return it->second;
    eprosima::fastdds::dds::TypeSupport type(new GuardedType<PubSubType>());
    return CreateTopicLocked(name, type);
  }

  eprosima::fastdds::dds::Publisher* publisher() const { return publisher_; }
  eprosima::fastdds::dds::Subscriber* subscriber() const { return subscriber_; }

 private:
  // The publisher and subscriber of the participant, in `partition` ("" = the default one).
  void CreatePublisherAndSubscriber(const std::string& partition);
  Participant() = default;
  eprosima::fastdds::dds::Topic* CreateTopicLocked(const std::string& name,
                                                   eprosima::fastdds::dds::TypeSupport type);

  std::mutex mutex_;
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
  int domain_id_ = 0;
  bool uses_xml_profile_ = false;
};

}  // namespace dygslam::dds
