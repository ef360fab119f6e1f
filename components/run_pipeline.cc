#include "components/run_pipeline.h"

#include <unistd.h>

#include <cstdio>
#include <random>

#include "components/pipeline.h"
#include "components/protocol.h"
#include "core/base/echo.h"

namespace dygslam {

std::string UniqueRunPartition() {
  char host[64] = {0};
  gethostname(host, sizeof(host) - 1);
  std::random_device rd;
  return "dygslam_run_" + std::string(host) + "_" + std::to_string(getpid()) + "_" +
         std::to_string(rd() % 100000);
}

PipelineRunResult RunControllerPipeline(const RunControllerOptions& s) {
  PipelineOptions o;
  o.dataset_dir = s.dataset_dir;
  o.output_dir = s.out.string();
  o.settings_path = s.settings_path;
  o.system = s.system;
  o.octomap = s.octomap;
  o.first_entry = s.first;
  o.last_entry = s.last;
  o.processes = s.mode == RunMode::kPipelineProcesses;
  o.run_mapper = s.map;
  o.domain_id = s.domain_id;
  o.partition = s.partition.empty() ? UniqueRunPartition() : s.partition;
  o.security_dir = s.security_dir;
  std::fprintf(stderr, "[run] DDS partition '%s' (a bridge joins with --partition %s)\n",
               EchoValue(o.partition).c_str(), EchoValue(o.partition).c_str());
  o.progress = s.progress;
  o.loop_minutes = s.loop_minutes;
  o.rate = s.rate;
  if (s.rate > 0) o.window = 0;  // a camera does not wait for the pipeline
  o.save_map = s.save_map;
  o.load_octomap = s.load_octomap;
  StopReport report;
  PipelineRunResult result;
  result.exit_code = RunPipeline(o, &report);
  result.interrupted = report.signaled;
  result.ignored_samples = report.ignored_samples;
  if (report.ignored_samples > 0)
    result.ignored_samples_note =
        IgnoredSamplesNote(std::to_string(report.ignored_samples) + " samples");
  result.components_cut_short = report.components_cut_short;
  return result;
}

}  // namespace dygslam
