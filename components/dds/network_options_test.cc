#include "components/dds/network_options.h"

#include <gtest/gtest.h>

#include "core/base/error.h"

namespace dygslam::dds {
namespace {

TEST(NetworkOptions, EndpointsParseOrNameTheProblem) {
  const Endpoint e = ParseEndpoint("10.251.0.2:11811", "--discovery-server");
  EXPECT_EQ(e.address, "10.251.0.2");
  EXPECT_EQ(e.port, 11811);
  for (const char* bad : {"10.251.0.2", "10.251.0.2:", "10.251.0.2:0", "10.251.0.2:65536",
                          "10.251.0.2:12ab", "host:11811", "10.251.0:11811", ":11811"}) {
    try {
      ParseEndpoint(bad, "--discovery-server");
      ADD_FAILURE() << bad << " accepted";
    } catch (const InvalidOptions& error) {
      EXPECT_NE(std::string(error.what()).find("--discovery-server"), std::string::npos) << bad;
      EXPECT_NE(std::string(error.what()).find(bad), std::string::npos) << error.what();
    }
  }
}

TEST(NetworkOptions, CheckRejectsWhatIsNotAnAddress) {
  NetworkOptions options;
  EXPECT_NO_THROW(options.Check());  // default: this machine only
  // This host's loopback address is an interface address; a foreign one is refused, naming
  // --dds-interface (before, Fast DDS filtered it out and the participant ran without one).
  options.interfaces = {"127.0.0.1"};
  options.discovery_server = "10.251.0.2:11811";
  EXPECT_NO_THROW(options.Check());
  options.interfaces = {"192.0.2.77"};  // TEST-NET-1: never a local address here
  try {
    options.Check();
    ADD_FAILURE() << "a foreign address was accepted";
  } catch (const InvalidOptions& e) {
    EXPECT_NE(std::string(e.what()).find("--dds-interface: 192.0.2.77 is not an address"),
              std::string::npos)
        << e.what();
  }
  options.interfaces = {"eth0"};
  EXPECT_THROW(options.Check(), InvalidOptions);
  options.interfaces = {"127.0.0.1"};
  options.discovery_server = "10.251.0.2";
  EXPECT_THROW(options.Check(), InvalidOptions);
}

}  // namespace
}  // namespace dygslam::dds
