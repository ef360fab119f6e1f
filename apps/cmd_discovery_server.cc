// dygslam discovery-server --listen ADDRESS:PORT: a Fast DDS discovery server for networks without
// multicast. Components and bridges started with `--discovery-server ADDRESS:PORT` discover each
// other through it (the data still flows directly between them). Runs until SIGINT / SIGTERM.
#ifdef DYGSLAM_HAVE_COMPONENTS
#include <string>

#include "apps/command.h"
#include "components/dds/participant.h"
#include "components/pipeline.h"
#include "core/base/error.h"

namespace dygslam::cli {
namespace {

int RunDiscoveryServerCommand(const std::vector<std::string>& args) {
  ArgParser p("discovery-server", "--listen ADDRESS:PORT [--domain N]",
              "Runs a Fast DDS discovery server (server id 0) until SIGINT / SIGTERM. Start the\n"
              "components with --discovery-server ADDRESS:PORT (and --dds-interface with this\n"
              "host's address) on networks without multicast.");
  p.AddOption("listen", "ADDRESS:PORT", "IPv4 address of this host and UDP port to listen on");
  p.AddOption("domain", "N", "DDS domain id (default DYGSLAM_DOMAIN_ID or 0)", "-1");
  if (!p.Parse(args)) return p.exit_code();
  if (!p.Has("listen")) return p.UsageError("--listen ADDRESS:PORT is required");
  int domain = -1;
  try {
    dds::ParseEndpoint(p.Get("listen"), "--listen");
  } catch (const InvalidOptions& e) {
    return p.UsageError(e.what());
  }
  if (!p.GetInt("domain", -1, 232, &domain)) return p.exit_code();
  if (domain < 0) domain = dds::DomainIdFromEnvironment(0);
  auto stop = std::make_shared<StopFlag>(StopFlag::Signals::kStop);
  dds::RunDiscoveryServer(p.Get("listen"), domain, [&] { return stop->requested(); });
  return 0;
}

const CommandRegistrar kRegistrar({"discovery-server",
                                   "Fast DDS discovery server for components on several hosts",
                                   RunDiscoveryServerCommand});

}  // namespace
}  // namespace dygslam::cli
#endif  // DYGSLAM_HAVE_COMPONENTS
