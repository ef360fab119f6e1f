// libFuzzer target: settings YAML (ConfigReader + LoadSettings' parser + every module section
// read by SystemOptionsFromSettings). Contract: InputError (or InvalidOptions) naming the source,
// or options that pass SystemOptions::Check(); never a crash, never a yaml-cpp exception leaking.
#include <cstdlib>
#include <string>

#include "core/base/error.h"
#include "core/config/config_reader.h"
#include "core/config/settings.h"
#include "run/settings_table.h"
#include "run/system_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dygslam;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ConfigReader reader = ConfigReader::FromString(text, "fuzz.yaml");
    for (const std::string& key : reader.Keys()) {
      reader.LineOf(key);
      try {
        reader.Get<double>(key, 0.0);
      } catch (const InputError&) {
      }
      try {
        reader.Get<std::vector<int>>(key, {});
      } catch (const InputError&) {
      }
      try {
        reader.Get<std::string>(key, "");
      } catch (const InputError&) {
      }
    }
  } catch (const InputError&) {
  }
  try {
    const Settings settings = ParseSettings(text, "fuzz.yaml");
    const SystemOptions options = SystemOptionsFromSettings(settings);
    options.Check();  // must not throw: everything accepted is valid
  } catch (const InputError&) {
  }
  return 0;
}
