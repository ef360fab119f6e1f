// The DDS modes of `dygslam run`: the run controller's PipelineRunner (run/run_controller.h) over
// the component pipeline (components/pipeline.h).
#pragma once

#include <string>

#include "run/run_controller.h"

namespace dygslam {

// A DDS partition name unique to this run (host, process, a random number): concurrent runs on
// one domain never mix.
std::string UniqueRunPartition();

// Runs the pipeline for `options` (options.partition "": UniqueRunPartition(), said on stderr so a
// bridge can join) and reports its end for the controller's judgement.
PipelineRunResult RunControllerPipeline(const RunControllerOptions& options);

}  // namespace dygslam
