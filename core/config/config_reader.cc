#include "core/config/config_reader.h"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/base/echo.h"
#include "core/base/input_file.h"

namespace dygslam {

struct ConfigReader::Impl {
  std::string path;
  YAML::Node root;  // a map (possibly empty)
};

namespace {

struct Hit {
  YAML::Node value;
  int line = 0;  // 1-based line of the key
};

// All entries of `node` (a map) that spell `key`, flat or nested at any dot.
void FindAll(const YAML::Node& node, const std::string& key, std::vector<Hit>* hits) {
  if (!node.IsMap()) return;
  for (const auto& entry : node) {
    if (!entry.first.IsScalar()) continue;
    const std::string& k = entry.first.Scalar();
    if (k == key) {
      hits->push_back({entry.second, entry.first.Mark().line + 1});
    } else if (key.size() > k.size() && key.compare(0, k.size(), k) == 0 && key[k.size()] == '.') {
      FindAll(entry.second, key.substr(k.size() + 1), hits);
    }
  }
}

std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

// Settings files are small: deeper nesting or more nodes than this is not a settings file (and
// an alias chain that doubles at every level would take forever to walk).
constexpr int kMaxDepth = 32;
constexpr size_t kMaxNodes = 200000;

// Checks the whole tree once, before anything else walks it: no alias that refers to one of its
// own ancestors (a cycle), nesting at most kMaxDepth, at most kMaxNodes visited (aliases
// expanded). Throws InputError with the line of the offending key.
void CheckTree(const YAML::Node& node, const std::string& path, int line,
               std::vector<YAML::Node>* ancestors, size_t* visited) {
  if (++*visited > kMaxNodes) {
    throw InputError(path, line,
                     "more than " + std::to_string(kMaxNodes) +
                         " values (aliases expanded); not a settings file");
  }
  if (!node.IsMap() && !node.IsSequence()) return;
  for (const YAML::Node& a : *ancestors) {
    if (a.is(node)) {
      throw InputError(path, line,
                       "recursive alias: a value refers to a map or list that contains it");
    }
  }
  if (static_cast<int>(ancestors->size()) >= kMaxDepth) {
    throw InputError(path, line, "nested deeper than " + std::to_string(kMaxDepth) + " levels");
  }
  ancestors->push_back(node);
  if (node.IsMap()) {
    for (const auto& entry : node) {
      const int key_line = entry.first.Mark().line >= 0 ? entry.first.Mark().line + 1 : line;
      // Settings keys are names: a complex key (`? [a, b]`, `{a: 1}: x`) or a null key (`~: 1`,
      // `: 1`) can name no setting and would be skipped without a word.
      if (entry.first.IsSequence() || entry.first.IsMap()) {
        throw InputError(path, key_line,
                         std::string("a ") + (entry.first.IsSequence() ? "list" : "map") +
                             " used as a key (YAML complex key '? ...'); settings keys are names");
      }
      if (!entry.first.IsScalar() || Trim(entry.first.Scalar()).empty()) {
        throw InputError(path, key_line,
                         "empty or null key ('~', 'null' or nothing before ':'); settings keys "
                         "are names");
      }
      // A YAML 1.1 merge key: yaml-cpp keeps it as a key named "<<", so the merged values would
      // land below "<<" and be dropped (with a misleading unknown-key warning).
      if (entry.first.Scalar() == "<<" && entry.first.Tag() != "!") {
        throw InputError(path, key_line,
                         "merge key '<<' is not supported in settings files; write the keys "
                         "themselves into the section");
      }
      CheckTree(entry.first, path, key_line, ancestors, visited);
      CheckTree(entry.second, path, key_line, ancestors, visited);
    }
  } else {
    for (const auto& item : node) {
      const int item_line = item.Mark().line >= 0 ? item.Mark().line + 1 : line;
      CheckTree(item, path, item_line, ancestors, visited);
    }
  }
  ancestors->pop_back();
}

// `depth` guards the recursion (CheckTree has bounded the tree already; this keeps the walk safe
// on its own).
void CollectKeys(const YAML::Node& node, const std::string& prefix, std::vector<std::string>* out,
                 int depth = 0) {
  if (!node.IsMap() || depth > kMaxDepth) return;
  for (const auto& entry : node) {
    if (!entry.first.IsScalar()) continue;
    const std::string key =
        prefix.empty() ? entry.first.Scalar() : prefix + "." + entry.first.Scalar();
    // An OpenCV matrix is a leaf value, not a section.
    if (entry.second.IsMap() && entry.second.Tag() != "tag:yaml.org,2002:opencv-matrix") {
      CollectKeys(entry.second, key, out, depth + 1);
    } else {
      out->push_back(key);
    }
  }
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// Strips OpenCV's "%YAML:1.0" directive (not valid YAML 1.2 for yaml-cpp), keeping line numbers.
std::string Preprocess(const std::string& text) {
  size_t start = 0;
  // Skip a UTF-8 byte order mark.
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) start = 3;
  const size_t eol = text.find('\n', start);
  const std::string first =
      text.substr(start, eol == std::string::npos ? std::string::npos : eol - start);
  if (first.rfind("%YAML", 0) == 0) {
    return eol == std::string::npos ? std::string() : text.substr(eol);
  }
  return text.substr(start);
}

// Typed conversion; `fail` throws with the key and line.
template <typename Fail>
double ParseDouble(const YAML::Node& node, const Fail& fail) {
  if (!node.IsScalar())
    fail("expected a number, found a " + std::string(node.IsMap() ? "map" : "sequence"));
  const std::string text = Trim(node.Scalar());
  const std::string lower = Lower(text);
  const std::string unsigned_lower =
      (!lower.empty() && (lower[0] == '-' || lower[0] == '+')) ? lower.substr(1) : lower;
  if (unsigned_lower == ".nan" || unsigned_lower == ".inf" || unsigned_lower == "nan" ||
      unsigned_lower == "inf" || unsigned_lower == "infinity") {
    fail("value must be a finite number, found '" + EchoValue(text) + "'");
  }
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (text.empty() || end == begin || *end != '\0')
    fail("expected a number, found '" + EchoValue(text) + "'");
  if (errno == ERANGE && std::isfinite(v) && std::abs(v) < 1.0)
    fail("value too close to zero for a double (underflow), found '" + EchoValue(text) + "'");
  if (!std::isfinite(v) || errno == ERANGE)
    fail("value must be a finite number, found '" + EchoValue(text) + "'");
  return v;
}

template <typename Fail>
int64_t ParseInt(const YAML::Node& node, int64_t lo, int64_t hi, const Fail& fail) {
  if (!node.IsScalar())
    fail("expected an integer, found a " + std::string(node.IsMap() ? "map" : "sequence"));
  const std::string text = Trim(node.Scalar());
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(begin, &end, 10);
  if (text.empty() || end == begin || *end != '\0') {
    // Accept "1000.0" style integral floats (OpenCV writes some ints that way), nothing else.
    char* fend = nullptr;
    const double d = std::strtod(begin, &fend);
    if (!text.empty() && fend != begin && *fend == '\0' && std::isfinite(d) && d == std::floor(d) &&
        std::abs(d) < 9e15) {
      if (d < double(lo) || d > double(hi)) fail("integer out of range: '" + EchoValue(text) + "'");
      return static_cast<int64_t>(d);
    }
    fail("expected an integer, found '" + EchoValue(text) + "'");
  }
  if (errno == ERANGE || v < lo || v > hi) fail("integer out of range: '" + EchoValue(text) + "'");
  return v;
}

template <typename Fail>
bool ParseBool(const YAML::Node& node, const Fail& fail) {
  if (!node.IsScalar()) fail("expected true/false");
  const std::string text = Lower(Trim(node.Scalar()));
  if (text == "true" || text == "yes" || text == "on" || text == "1") return true;
  if (text == "false" || text == "no" || text == "off" || text == "0") return false;
  fail("expected true/false (or 1/0), found '" + EchoValue(node.Scalar()) + "'");
  return false;
}

template <typename T>
struct Converter;

template <>
struct Converter<double> {
  template <typename F>
  static double Convert(const YAML::Node& n, const F& fail) {
    return ParseDouble(n, fail);
  }
};
template <>
struct Converter<float> {
  template <typename F>
  static float Convert(const YAML::Node& n, const F& fail) {
    const double v = ParseDouble(n, fail);
    if (std::abs(v) > std::numeric_limits<float>::max()) fail("value out of float range");
    return static_cast<float>(v);
  }
};
template <>
struct Converter<int> {
  template <typename F>
  static int Convert(const YAML::Node& n, const F& fail) {
    return static_cast<int>(
        ParseInt(n, std::numeric_limits<int>::min(), std::numeric_limits<int>::max(), fail));
  }
};
template <>
struct Converter<int64_t> {
  template <typename F>
  static int64_t Convert(const YAML::Node& n, const F& fail) {
    return ParseInt(n, std::numeric_limits<int64_t>::min(), std::numeric_limits<int64_t>::max(),
                    fail);
  }
};
template <>
struct Converter<bool> {
  template <typename F>
  static bool Convert(const YAML::Node& n, const F& fail) {
    return ParseBool(n, fail);
  }
};
template <>
struct Converter<std::string> {
  template <typename F>
  static std::string Convert(const YAML::Node& n, const F& fail) {
    if (!n.IsScalar()) fail("expected a string");
    return n.Scalar();
  }
};

// A sequence, a single scalar (one element), or an !!opencv-matrix (its `data`).
template <typename E>
struct Converter<std::vector<E>> {
  template <typename F>
  static std::vector<E> Convert(const YAML::Node& n, const F& fail) {
    YAML::Node seq = n;
    if (n.IsMap()) {
      if (!n["data"]) fail("expected a list (or an !!opencv-matrix with 'data')");
      seq = n["data"];
    }
    std::vector<E> out;
    if (seq.IsScalar()) {
      out.push_back(Converter<E>::Convert(seq, fail));
      return out;
    }
    if (!seq.IsSequence()) fail("expected a list");
    size_t i = 0;
    for (const auto& item : seq) {
      const auto item_fail = [&](const std::string& m) {
        fail("element " + std::to_string(i) + ": " + m);
      };
      out.push_back(Converter<E>::Convert(item, item_fail));
      ++i;
    }
    if (n.IsMap() && n["rows"] && n["cols"]) {
      const int64_t rows = ParseInt(n["rows"], 0, 1 << 20, fail);
      const int64_t cols = ParseInt(n["cols"], 0, 1 << 20, fail);
      if (static_cast<size_t>(rows * cols) != out.size()) {
        fail("opencv-matrix has " + std::to_string(out.size()) +
             " values, expected rows*cols = " + std::to_string(rows * cols));
      }
    }
    return out;
  }
};

// Records where a document starts and whether it holds anything but an empty value.
class DocumentProbe : public YAML::EventHandler {
 public:
  int first_pos = -1;
  int first_line = -1;
  bool has_content = false;

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { Seen(mark, false); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { Seen(mark, true); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                const std::string&) override {
    Seen(mark, true);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    Seen(mark, true);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    Seen(mark, true);
  }
  void OnMapEnd() override {}

 private:
  void Seen(const YAML::Mark& mark, bool content) {
    if (first_pos < 0) {
      first_pos = mark.pos;
      first_line = mark.line;
    }
    has_content = has_content || content;
  }
};

// Walks the documents of `yaml` (instead of YAML::LoadAll) and refuses a second one with content.
// yaml-cpp 0.7's LoadAll never returns on a ',' at the top level: its parser hands out an empty
// document at the same place forever (found by the settings fuzzer). A document that starts where
// the previous one started made no progress: that is a malformed file, said as such.
void CheckSingleDocument(const std::string& yaml, const std::string& name) {
  constexpr int kMaxDocuments = 1000;
  std::istringstream in(yaml);
  YAML::Parser parser(in);
  int previous_pos = -1;
  for (int index = 0;; ++index) {
    DocumentProbe probe;
    if (!parser.HandleNextDocument(probe)) return;
    const int line = probe.first_line >= 0 ? probe.first_line + 1 : 0;
    if (probe.first_pos >= 0 && probe.first_pos == previous_pos) {
      throw InputError(name, line,
                       "malformed YAML: a ',' outside a [ ] list or { } map (the parser cannot "
                       "move past it)");
    }
    if (index > 0 && probe.has_content) {
      throw InputError(name, line,
                       "a second YAML document (after '---' or '...'): a settings file is one "
                       "document; its keys would be ignored");
    }
    if (probe.first_pos >= 0) previous_pos = probe.first_pos;
    if (index >= kMaxDocuments) {
      throw InputError(name, line,
                       "more than " + std::to_string(kMaxDocuments) +
                           " YAML documents ('---' or '...'); not a settings file");
    }
  }
}

}  // namespace

ConfigReader::ConfigReader() {
  auto impl = std::make_shared<Impl>();
  impl->root = YAML::Node(YAML::NodeType::Map);
  impl_ = std::move(impl);
}

ConfigReader::ConfigReader(std::shared_ptr<const Impl> impl, std::string prefix)
    : impl_(std::move(impl)), prefix_(std::move(prefix)) {}

ConfigReader ConfigReader::FromString(const std::string& text, const std::string& name) {
  auto impl = std::make_shared<Impl>();
  impl->path = name;
  try {
    const std::string yaml = Preprocess(text);
    // Every document: settings are one document, a second one ("---" or "..." followed by more
    // keys) would be dropped without a word by YAML::Load.
    CheckSingleDocument(yaml, name);
    impl->root = YAML::Load(yaml);
  } catch (const InputError&) {
    throw;
  } catch (const YAML::DeepRecursion& e) {
    // yaml-cpp's own guard (thousands of levels) says "bad file": say what is wrong.
    throw InputError(name, e.mark.line >= 0 ? e.mark.line + 1 : 0,
                     "nested deeper than " + std::to_string(kMaxDepth) +
                         " levels (the YAML parser gave up at " + std::to_string(e.depth()) +
                         "); not a settings file");
  } catch (const YAML::Exception& e) {
    throw InputError(name, e.mark.line >= 0 ? e.mark.line + 1 : 0, "malformed YAML: " + e.msg);
  }
  if (!impl->root || impl->root.IsNull()) {
    impl->root = YAML::Node(YAML::NodeType::Map);
  } else if (!impl->root.IsMap()) {
    throw InputError(name, impl->root.Mark().line + 1,
                     "top level must be a map of 'key: value' entries");
  }
  std::vector<YAML::Node> ancestors;
  size_t visited = 0;
  CheckTree(impl->root, name, 0, &ancestors, &visited);
  return ConfigReader(std::move(impl), "");
}

ConfigReader ConfigReader::FromFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path, 0, "settings file not found");
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path, 0, "is a directory, expected a settings file");
  // A pipe is fine (`--config <(...)`); a device (/dev/zero) or a socket would be read forever.
  if (!std::filesystem::is_regular_file(path, ec) && !std::filesystem::is_fifo(path, ec))
    throw InputError(path, 0, "settings file is not a regular file (a device or a socket)");
  // Settings files are a few KB; a bounded read keeps a huge or endless one from taking the memory.
  constexpr size_t kMaxSettingsBytes = 16u << 20;
  std::string text;
  if (std::filesystem::is_fifo(path, ec)) {
    // A pipe nobody writes into is an error after a while, not a hang.
    text = ReadPipeBounded(path, kMaxSettingsBytes, "settings file");
  } else {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path, 0, "cannot open settings file");
    text.assign(kMaxSettingsBytes + 1, '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<size_t>(in.gcount()));
  }
  if (text.size() > kMaxSettingsBytes)
    throw InputError(path, 0, "settings file larger than 16 MiB: not a settings file");
  return FromString(text, path);
}

const std::string& ConfigReader::path() const { return impl_->path; }

std::string ConfigReader::FullKey(const std::string& key) const {
  return prefix_.empty() ? key : prefix_ + "." + key;
}

// The single entry for `full_key` (line 0 when absent); a key given twice is an error.
namespace {
struct ConfigLookup {
  static Hit Find(const std::string& path, const YAML::Node& root, const std::string& full_key) {
    std::vector<Hit> hits;
    FindAll(root, full_key, &hits);
    if (hits.size() > 1) {
      throw InputError(path, hits[1].line,
                       "key '" + EchoValue(full_key) + "' is given more than once (also on line " +
                           std::to_string(hits[0].line) + ")");
    }
    if (hits.empty()) return Hit{};
    return hits[0];
  }
};
}  // namespace

ConfigReader ConfigReader::Section(const std::string& name) const {
  const std::string full = FullKey(name);
  const Hit h = ConfigLookup::Find(impl_->path, impl_->root, full);
  if (h.line > 0 && !h.value.IsNull() && !h.value.IsMap()) {
    throw InputError(impl_->path, h.line,
                     "section '" + EchoValue(full) +
                         "' must be a map of 'key: value' entries, found a " +
                         (h.value.IsSequence() ? "list" : "single value"));
  }
  return ConfigReader(impl_, full);
}

namespace {
thread_local KeyLookupRecorder* current_recorder = nullptr;

}  // namespace

KeyLookupRecorder::KeyLookupRecorder() : previous_(current_recorder) { current_recorder = this; }

KeyLookupRecorder::~KeyLookupRecorder() { current_recorder = previous_; }

void KeyLookupRecorder::Record(const std::string& full_key) {
  if (current_recorder) current_recorder->keys_.insert(full_key);
}

bool ConfigReader::Has(const std::string& key) const {
  KeyLookupRecorder::Record(FullKey(key));
  const Hit h = ConfigLookup::Find(impl_->path, impl_->root, FullKey(key));
  return h.line > 0 && !h.value.IsNull();
}

int ConfigReader::LineOf(const std::string& key) const {
  return ConfigLookup::Find(impl_->path, impl_->root, FullKey(key)).line;
}

std::vector<std::string> ConfigReader::Keys() const {
  std::vector<std::string> all;
  CollectKeys(impl_->root, "", &all);
  if (prefix_.empty()) return all;
  std::vector<std::string> out;
  for (const std::string& k : all) {
    if (k.size() > prefix_.size() && k.compare(0, prefix_.size(), prefix_) == 0 &&
        k[prefix_.size()] == '.') {
      out.push_back(k);
    }
  }
  return out;
}

namespace {

// Edit distance (insertions, deletions, substitutions; case-insensitive).
size_t EditDistance(const std::string& a_in, const std::string& b_in) {
  const std::string a = Lower(a_in), b = Lower(b_in);
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

bool IsKnown(const std::string& key, const std::vector<std::string>& known) {
  for (const std::string& k : known) {
    if (k == key) return true;
    // A known section given as a list or a single value (`OctoMap: [..]`, `Viewer: ~`): not an
    // unknown key; the module that reads the section says what is wrong with it.
    if (k.size() > key.size() && k.compare(0, key.size(), key) == 0 && k[key.size()] == '.')
      return true;
    // "Viewer.*": every key below Viewer.
    if (k.size() >= 2 && k.compare(k.size() - 2, 2, ".*") == 0 &&
        key.compare(0, k.size() - 1, k, 0, k.size() - 1) == 0) {
      return true;
    }
  }
  return false;
}

// `key` lies inside the value of a known key (`Detector.dynamic_classes: {a: 1}` gives
// `Detector.dynamic_classes.a`): the known key is mistyped, not misspelt; its reader reports the
// type error, so no unknown-key warning comes before it.
bool IsBelowKnownKey(const std::string& key, const std::vector<std::string>& known) {
  for (size_t dot = key.find('.'); dot != std::string::npos; dot = key.find('.', dot + 1)) {
    if (std::find(known.begin(), known.end(), key.substr(0, dot)) != known.end()) return true;
  }
  return false;
}

}  // namespace

std::vector<ConfigReader::UnknownKey> ConfigReader::UnknownKeys(
    const std::vector<std::string>& known) const {
  std::vector<UnknownKey> out;
  // What a misspelling may stand for: a known key, or a section (`OctoMapp: [..]`).
  std::vector<std::string> candidates;
  for (const std::string& k : known) {
    if (k.size() >= 2 && k.compare(k.size() - 2, 2, ".*") == 0) continue;
    candidates.push_back(k);
    for (size_t dot = k.find('.'); dot != std::string::npos; dot = k.find('.', dot + 1)) {
      if (std::find(candidates.begin(), candidates.end(), k.substr(0, dot)) == candidates.end())
        candidates.push_back(k.substr(0, dot));
    }
  }
  for (const std::string& key : Keys()) {
    if (IsKnown(key, known) || IsBelowKnownKey(key, known)) continue;
    UnknownKey u;
    u.key = key;
    try {
      u.line = ConfigLookup::Find(impl_->path, impl_->root, key).line;
    } catch (const InputError&) {
    }
    // The closest known key, if it is close: a few edits, at most a third of the key.
    size_t best = std::numeric_limits<size_t>::max();
    for (const std::string& k : candidates) {
      const size_t d = EditDistance(key, k);
      if (d < best) {
        best = d;
        u.closest = k;
      }
    }
    if (best > std::max<size_t>(2, key.size() / 3)) u.closest.clear();
    out.push_back(u);
  }
  return out;
}

std::string ConfigReader::UnknownKeyMessage(const UnknownKey& unknown) const {
  return InputError::Format(
      impl_->path, unknown.line,
      "unknown key '" + EchoValue(unknown.key) + "'" +
          (unknown.closest.empty() ? std::string(" (not a dygslam or ORB-SLAM2 settings key)")
                                   : " (did you mean '" + unknown.closest + "'?)"));
}

void ConfigReader::Fail(const std::string& key, const std::string& message) const {
  const std::string full = FullKey(key);
  int line = 0;
  try {
    line = LineOf(key);
  } catch (const InputError&) {
  }
  throw InputError(impl_->path, line, "key '" + EchoValue(full) + "': " + message);
}

namespace {

// "DynamicFilter.p_init" and "DynamicFilter.P_init" alike: lower case, no '_', no "_path" suffix.
std::string LooseKey(const std::string& key) {
  std::string k = key;
  if (k.size() > 5 && k.compare(k.size() - 5, 5, "_path") == 0) k.resize(k.size() - 5);
  std::string out;
  for (char c : k) {
    if (c != '_') out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  return out;
}

}  // namespace

void ConfigReader::FailInvalidOptions(const InvalidOptions& e) const {
  // DYGSLAM_CHECK_OPTION: "invalid option <name>: requires <condition>". The option's name is the
  // struct's ("DynamicFilter.c1"); messages use the key as the file spells it ("DynamicFilter.C1").
  const std::string message = e.what();
  const std::string head = "invalid option ";
  std::string name;
  if (message.rfind(head, 0) == 0) {
    const size_t colon = message.find(": ", head.size());
    name = message.substr(head.size(),
                          colon == std::string::npos ? std::string::npos : colon - head.size());
  }
  if (name.empty()) throw InputError(impl_->path, 0, message);
  std::string key = name;
  int line = 0;
  for (const std::string& candidate : {name, FullKey(name)}) {
    try {
      line = ConfigLookup::Find(impl_->path, impl_->root, candidate).line;
    } catch (const InputError&) {
    }
    if (line > 0) {
      key = candidate;
      break;
    }
  }
  if (line == 0) {
    std::vector<std::string> all;
    CollectKeys(impl_->root, "", &all);
    for (const std::string& candidate : all) {
      if (LooseKey(candidate) != LooseKey(name) && LooseKey(candidate) != LooseKey(FullKey(name)))
        continue;
      try {
        line = ConfigLookup::Find(impl_->path, impl_->root, candidate).line;
      } catch (const InputError&) {
      }
      key = candidate;
      break;
    }
  }
  std::string value;
  try {
    const Hit h = ConfigLookup::Find(impl_->path, impl_->root, key);
    if (h.line > 0 && h.value.IsScalar()) value = " " + EchoValue(h.value.Scalar(), 60);
  } catch (const InputError&) {
  }
  throw InputError(impl_->path, line,
                   "key '" + key + "': invalid value" + value + " (" + message + ")");
}

template <typename T>
bool ConfigReader::ReadIfPresent(const std::string& key, T* value) const {
  const std::string full = FullKey(key);
  KeyLookupRecorder::Record(full);
  const Hit h = ConfigLookup::Find(impl_->path, impl_->root, full);
  if (h.line <= 0 || h.value.IsNull()) return false;
  const auto fail = [&](const std::string& m) -> void {
    throw InputError(impl_->path, h.line, "key '" + EchoValue(full) + "': " + m);
  };
  *value = Converter<T>::Convert(h.value, fail);
  return true;
}

template <typename T>
T ConfigReader::Get(const std::string& key, const T& default_value) const {
  T value = default_value;
  ReadIfPresent(key, &value);
  return value;
}

template <typename T>
T ConfigReader::Require(const std::string& key) const {
  T value{};
  if (!ReadIfPresent(key, &value)) {
    const int line = LineOf(key);
    throw InputError(impl_->path, line,
                     line > 0 ? "key '" + FullKey(key) + "' has no value (required)"
                              : "missing required key '" + FullKey(key) + "'");
  }
  return value;
}

#define DYGSLAM_CONFIG_INSTANTIATE(T)                                         \
  template bool ConfigReader::ReadIfPresent<T>(const std::string&, T*) const; \
  template T ConfigReader::Get<T>(const std::string&, const T&) const;        \
  template T ConfigReader::Require<T>(const std::string&) const;

DYGSLAM_CONFIG_INSTANTIATE(double)
DYGSLAM_CONFIG_INSTANTIATE(float)
DYGSLAM_CONFIG_INSTANTIATE(int)
DYGSLAM_CONFIG_INSTANTIATE(int64_t)
DYGSLAM_CONFIG_INSTANTIATE(bool)
DYGSLAM_CONFIG_INSTANTIATE(std::string)
DYGSLAM_CONFIG_INSTANTIATE(std::vector<std::string>)
DYGSLAM_CONFIG_INSTANTIATE(std::vector<double>)
DYGSLAM_CONFIG_INSTANTIATE(std::vector<int>)

}  // namespace dygslam
