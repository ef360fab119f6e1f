// libFuzzer target: every decoder of incoming DDS samples, from raw serialized bytes.
// Input: byte 0 selects the message type (SampleKind, modulo kCount); the rest is the serialized
// payload (encapsulation header + CDR), as a DataReader receives it. Seeds: valid samples of
// every type (fuzz/make_dds_seeds). Any crash, sanitizer report, leak, allocation above
// -malloc_limit_mb or a broken decoder contract (std::logic_error -> abort) is a finding.
#include <cstdlib>
#include <cstdio>
#include <stdexcept>

#include "fuzz/dds_decoders.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dygslam::fuzz;
  if (size < 1) return 0;
  const auto kind = static_cast<SampleKind>(data[0] % static_cast<uint8_t>(SampleKind::kCount));
  try {
    DecodeSample(kind, data + 1, size - 1);
  } catch (const std::logic_error& e) {
    std::fprintf(stderr, "%s: decoder contract broken: %s\n", ToString(kind), e.what());
    std::abort();
  }
  return 0;
}
