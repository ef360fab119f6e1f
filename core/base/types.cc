#include "core/base/types.h"

namespace dygslam {
const char* ToString(TrackingState state) {
  switch (state) {
    case TrackingState::kNotInitialized: return "not_initialized";
    case TrackingState::kOk: return "ok";
    case TrackingState::kRelocalized: return "relocalized";
    case TrackingState::kLost: return "lost";
    case TrackingState::kFallback: return "fallback";
  }
  return "unknown";
}
}  // namespace dygslam
