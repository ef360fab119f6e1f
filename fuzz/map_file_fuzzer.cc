// libFuzzer target: SLAM map files through DecodeMapFile (core/slam/map/map_file.h). Input: a map
// file. With the first byte even, the input is decoded as it is (header checks: size, magic,
// version, truncation, checksum); odd, the bytes after the 20-byte header and before the 8-byte
// checksum are re-wrapped with a matching size and checksum, so mutations reach the payload
// parser (counts, indices, ids, numbers). Contract: InputError, or a map that EncodeMapFile writes
// back and DecodeMapFile reads again to the same bytes.
#include <cstdlib>
#include <cstring>
#include <string>

#include "core/base/error.h"
#include "fuzz/map_file_seed.h"

namespace {

std::string Rewrap(const std::string& input) {
  constexpr size_t kHeader = 20, kTrailer = 8;
  const std::string payload = input.size() > kHeader + kTrailer
                                  ? input.substr(kHeader, input.size() - kHeader - kTrailer)
                                  : std::string();
  std::string file("DYGSLMAP", 8);
  const uint32_t version = dygslam::kMapFileVersion;
  const uint64_t size = payload.size();
  file.append(reinterpret_cast<const char*>(&version), 4);
  file.append(reinterpret_cast<const char*>(&size), 8);
  file += payload;
  const uint64_t checksum = dygslam::MapFileChecksum(file.data(), file.size(), version);
  file.append(reinterpret_cast<const char*>(&checksum), 8);
  return file;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dygslam;
  if (size == 0) return 0;
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::string bytes = (data[0] & 1) ? Rewrap(input) : input;
  const auto geometry = fuzz::MapSeedGeometry();
  const MapFileSettings settings = fuzz::MapSeedSettings();
  LoadedMap loaded;
  try {
    loaded = DecodeMapFile(bytes, "fuzz.dygmap", settings, geometry);
  } catch (const InputError&) {
    return 0;
  }
  const std::string again = EncodeMapFile(*loaded.map, settings);
  const LoadedMap reloaded = DecodeMapFile(again, "again.dygmap", settings, geometry);
  if (EncodeMapFile(*reloaded.map, settings) != again) std::abort();
  if (reloaded.info.keyframes != loaded.info.keyframes) std::abort();
  return 0;
}
