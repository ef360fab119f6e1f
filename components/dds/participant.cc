#include "components/dds/participant.h"

#include <fastdds/rtps/attributes/ServerAttributes.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/attributes/LibrarySettingsAttributes.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastrtps/xmlparser/XMLProfileManager.h>

#include <cstdio>
#include <cstdlib>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/PublisherQos.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/SubscriberQos.hpp>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "core/base/error.h"
#include "core/base/log.h"

namespace dygslam::dds {

using namespace eprosima::fastdds::dds;  // NOLINT
using eprosima::fastdds::rtps::SharedMemTransportDescriptor;
using eprosima::fastdds::rtps::UDPv4TransportDescriptor;

void ParticipantOptions::Check() const {
  DYGSLAM_CHECK_OPTION(domain_id >= 0 && domain_id <= 232, "domain_id");
  DYGSLAM_CHECK_OPTION(!name.empty(), "participant name");
  DYGSLAM_CHECK_OPTION(use_shm || use_udp_loopback, "transports (shm or udp)");
  DYGSLAM_CHECK_OPTION(network.shared_memory || use_udp_loopback || !network.interfaces.empty() ||
                           network.all_interfaces,
                       "transports (shared memory off and no UDP interface)");
  network.Check();
  DYGSLAM_CHECK_OPTION(shm_segment_size >= (1u << 20), "shm_segment_size");
  DYGSLAM_CHECK_OPTION(socket_buffer_size >= (64u << 10), "socket_buffer_size");
  DYGSLAM_CHECK_OPTION(partition.find_first_of("*?[]") == std::string::npos,
                       "partition (no wildcards)");
  security.Check();
}

int DomainIdFromEnvironment(int fallback) {
  const char* text = std::getenv("DYGSLAM_DOMAIN_ID");
  if (text == nullptr || *text == '\0') return fallback;
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (*end != '\0' || value < 0 || value > 232) {
    throw InputError(std::string("DYGSLAM_DOMAIN_ID: expected an integer in [0, 232], got '") +
                     text + "'");
  }
  return static_cast<int>(value);
}

namespace {

// Fast DDS 2.9's intra-process delivery runs the reader's listener on the writer's thread and
// reaches the local reader through a raw pointer: a component that deletes its readers while
// another component of the same process still writes (the end of a single-process run) can then
// crash inside Fast DDS (seen as a rare SIGSEGV at the end of `dygslam run`). Local readers get
// their samples through the shared-memory transport instead (one extra copy of a 1.5 MB frame,
// ~0.5 ms), whose receive threads handle endpoint removal safely.
void DisableIntraprocessDelivery() {
  static std::once_flag once;
  std::call_once(once, [] {
    eprosima::fastrtps::LibrarySettingsAttributes settings =
        eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings();
    settings.intraprocess_delivery = eprosima::fastrtps::INTRAPROCESS_OFF;
    eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings(settings);
  });
}

std::string Describe(const ParticipantOptions& options) {
  std::string text;
  if (options.use_shm && options.network.shared_memory) text += "SHM + ";
  text += "UDPv4 ";
  if (options.network.all_interfaces) {
    text += "all interfaces";
  } else if (options.network.interfaces.empty()) {
    text += "127.0.0.1";
  }
  for (size_t i = 0; i < options.network.interfaces.size(); ++i) {
    text += (i ? "," : "") + options.network.interfaces[i];
  }
  if (!options.network.discovery_server.empty()) {
    text += ", discovery server " + options.network.discovery_server;
  }
  return text;
}

// The participant QoS from the XML profile file FASTRTPS_DEFAULT_PROFILES_FILE names (its
// profile options.xml_profile_name, else its default).
DomainParticipantQos QosFromXmlProfile(const ParticipantOptions& options, const char* profiles) {
  DomainParticipantFactory* factory = DomainParticipantFactory::get_instance();
  DomainParticipantQos qos;
  if (factory->load_profiles() != ReturnCode_t::RETCODE_OK) {
    throw InputError(std::string(profiles), 0,
                     "FASTRTPS_DEFAULT_PROFILES_FILE: cannot load the XML profiles");
  }
  factory->get_default_participant_qos(qos);
  if (!options.xml_profile_name.empty() &&
      factory->get_participant_qos_from_profile(options.xml_profile_name, qos) !=
          ReturnCode_t::RETCODE_OK) {
    factory->get_default_participant_qos(qos);
    LOG_INFO << "participant '" << options.name << "': no profile '" << options.xml_profile_name
             << "' in " << profiles << ", using its default profile";
  }
  return qos;
}

// Shared memory, and UDP on loopback, the given interfaces or all of them.
void AddTransports(const ParticipantOptions& options, DomainParticipantQos* qos) {
  qos->transport().use_builtin_transports = false;
  if (options.use_shm && options.network.shared_memory) {
    auto shm = std::make_shared<SharedMemTransportDescriptor>();
    shm->segment_size(options.shm_segment_size);
    qos->transport().user_transports.push_back(shm);
  }
  if (options.use_udp_loopback || !options.network.interfaces.empty() ||
      options.network.all_interfaces) {
    auto udp = std::make_shared<UDPv4TransportDescriptor>();
    if (options.network.all_interfaces) {
      // No whitelist: every interface, and remote locators on this host's own addresses
      // (a same-host peer announcing its LAN address) are kept.
    } else if (options.network.interfaces.empty()) {
      udp->interfaceWhiteList.push_back("127.0.0.1");
    } else {
      for (const std::string& address : options.network.interfaces) {
        udp->interfaceWhiteList.push_back(address);
      }
    }
    udp->sendBufferSize = options.socket_buffer_size;
    udp->receiveBufferSize = options.socket_buffer_size;
    qos->transport().user_transports.push_back(udp);
  }
  qos->transport().send_socket_buffer_size = options.socket_buffer_size;
  qos->transport().listen_socket_buffer_size = options.socket_buffer_size;
}

// Discovery through the server at options.network.discovery_server (this participant a client).
void UseDiscoveryServer(const ParticipantOptions& options, DomainParticipantQos* qos) {
  const Endpoint server = ParseEndpoint(options.network.discovery_server, "discovery server");
  eprosima::fastdds::rtps::RemoteServerAttributes remote;
  remote.ReadguidPrefix(DiscoveryServerGuidPrefix(0).c_str());
  eprosima::fastrtps::rtps::Locator_t locator;
  eprosima::fastrtps::rtps::IPLocator::setIPv4(locator, server.address);
  locator.port = server.port;
  remote.metatrafficUnicastLocatorList.push_back(locator);
  auto& discovery = qos->wire_protocol().builtin.discovery_config;
  discovery.discoveryProtocol = eprosima::fastrtps::rtps::DiscoveryProtocol_t::CLIENT;
  discovery.m_DiscoveryServers.push_back(remote);
}

}  // namespace

std::shared_ptr<Participant> Participant::Create(const ParticipantOptions& options) {
  options.Check();
  DisableIntraprocessDelivery();
  DomainParticipantFactory* factory = DomainParticipantFactory::get_instance();
  DomainParticipantQos qos;
  const char* profiles = std::getenv("FASTRTPS_DEFAULT_PROFILES_FILE");
  const bool xml = options.use_xml_profile && profiles != nullptr && *profiles != '\0';
  if (xml) {
    qos = QosFromXmlProfile(options, profiles);
  } else {
    qos = PARTICIPANT_QOS_DEFAULT;
    AddTransports(options, &qos);
    if (!options.network.discovery_server.empty()) UseDiscoveryServer(options, &qos);
  }
  qos.name(options.name);
  if (!options.user_data.empty()) {
    qos.user_data().data_vec(std::vector<eprosima::fastrtps::rtps::octet>(options.user_data.begin(),
                                                                          options.user_data.end()));
  }
  std::shared_ptr<Participant> result(new Participant());
  result->domain_id_ = options.domain_id;
  result->uses_xml_profile_ = xml;
  ApplySecurity(options.security, &qos);
  result->participant_ = factory->create_participant(options.domain_id, qos);
  if (result->participant_ == nullptr && options.security.enabled) {
    throw InputError("DDS Security: participant '" + options.name +
                     "' not created: the credentials were rejected (certificate " +
                     options.security.identity_certificate + ", private key " +
                     options.security.private_key + ", permissions " +
                     options.security.permissions + ", governance " + options.security.governance +
                     ", CA " + options.security.identity_ca + ")");
  }
  if (result->participant_ == nullptr) {
    throw std::runtime_error("Fast DDS: cannot create participant '" + options.name +
                             "' on domain " + std::to_string(options.domain_id));
  }
  result->CreatePublisherAndSubscriber(options.partition);
  LOG_DEBUG << "participant '" << options.name << "' domain " << options.domain_id
            << (options.partition.empty() ? "" : " partition '" + options.partition + "'")
            << (xml ? " (XML profile)" : " (" + Describe(options) + ")")
            << (options.security.enabled ? " DDS Security on" : "");
  return result;
}

void Participant::CreatePublisherAndSubscriber(const std::string& partition) {
  PublisherQos publisher_qos = PUBLISHER_QOS_DEFAULT;
  SubscriberQos subscriber_qos = SUBSCRIBER_QOS_DEFAULT;
  if (!partition.empty()) {
    publisher_qos.partition().push_back(partition.c_str());
    subscriber_qos.partition().push_back(partition.c_str());
  }
  publisher_ = participant_->create_publisher(publisher_qos);
  subscriber_ = participant_->create_subscriber(subscriber_qos);
  if (publisher_ == nullptr || subscriber_ == nullptr) {
    throw std::runtime_error("Fast DDS: cannot create publisher/subscriber");
  }
}

Topic* Participant::CreateTopicLocked(const std::string& name, TypeSupport type) {
  if (participant_->find_type(type.get_type_name()) == nullptr) {
    if (type.register_type(participant_) != ReturnCode_t::RETCODE_OK) {
      throw std::runtime_error("Fast DDS: cannot register type " + type.get_type_name());
    }
  }
  Topic* topic = participant_->create_topic(name, type.get_type_name(), TOPIC_QOS_DEFAULT);
  if (topic == nullptr) throw std::runtime_error("Fast DDS: cannot create topic " + name);
  topics_[name] = topic;
  return topic;
}

Participant::~Participant() {
  if (participant_ == nullptr) return;
  participant_->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(participant_);
}

}  // namespace dygslam::dds

namespace dygslam::dds {

std::string DiscoveryServerGuidPrefix(int id) {
  DYGSLAM_CHECK_OPTION(id >= 0 && id <= 255, "discovery server id (0..255)");
  char text[64];
  std::snprintf(text, sizeof(text), "44.53.%02x.5f.45.50.52.4f.53.49.4d.41", id);
  return text;
}

void RunDiscoveryServer(const std::string& listen, int domain_id,
                        const std::function<bool()>& stop_requested) {
  const Endpoint endpoint = ParseEndpoint(listen, "--listen");
  DYGSLAM_CHECK_OPTION(domain_id >= 0 && domain_id <= 232, "domain_id");
  DomainParticipantQos qos = PARTICIPANT_QOS_DEFAULT;
  qos.name("dygslam_discovery_server");
  qos.transport().use_builtin_transports = false;
  auto udp = std::make_shared<UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.push_back(endpoint.address);
  qos.transport().user_transports.push_back(udp);
  auto& discovery = qos.wire_protocol().builtin.discovery_config;
  discovery.discoveryProtocol = eprosima::fastrtps::rtps::DiscoveryProtocol_t::SERVER;
  std::istringstream(DiscoveryServerGuidPrefix(0)) >> qos.wire_protocol().prefix;
  eprosima::fastrtps::rtps::Locator_t locator;
  eprosima::fastrtps::rtps::IPLocator::setIPv4(locator, endpoint.address);
  locator.port = endpoint.port;
  qos.wire_protocol().builtin.metatrafficUnicastLocatorList.push_back(locator);
  DomainParticipant* server =
      DomainParticipantFactory::get_instance()->create_participant(domain_id, qos);
  if (server == nullptr) {
    throw InputError("--listen " + listen +
                     ": cannot start a discovery server there (is the address one of this host's "
                     "and the port free?)");
  }
  LOG_INFO << "discovery server on " << listen << ", domain " << domain_id << ", GUID prefix "
           << DiscoveryServerGuidPrefix(0);
  while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  DomainParticipantFactory::get_instance()->delete_participant(server);
}

}  // namespace dygslam::dds
