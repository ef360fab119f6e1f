#include "core/dynamic/yolo_detector.h"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <opencv2/core/utility.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/base/log.h"
#include "core/base/paths.h"

namespace dygslam {
namespace fs = std::filesystem;

void DetectorOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!cfg_path.empty(), "Detector.cfg_path");
  DYGSLAM_CHECK_OPTION(!weights_path.empty(), "Detector.weights_path");
  DYGSLAM_CHECK_OPTION(!names_path.empty(), "Detector.names_path");
  DYGSLAM_CHECK_OPTION(input_width >= 32 && input_width <= 4096 && input_width % 32 == 0,
                       "Detector.input_width");
  DYGSLAM_CHECK_OPTION(
      input_height == 0 || (input_height >= 32 && input_height <= 4096 && input_height % 32 == 0),
      "Detector.input_height");
  DYGSLAM_CHECK_OPTION(confidence_threshold > 0.f && confidence_threshold <= 1.f,
                       "Detector.confidence_threshold");
  DYGSLAM_CHECK_OPTION(nms_threshold > 0.f && nms_threshold <= 1.f, "Detector.nms_threshold");
  DYGSLAM_CHECK_OPTION(report_all_classes || !dynamic_classes.empty(), "Detector.dynamic_classes");
  DYGSLAM_CHECK_OPTION(num_threads >= 0 && num_threads <= 256, "Detector.num_threads");
}

cv::Size DetectorInputSize(const DetectorOptions& options, const cv::Size& image_size) {
  if (options.input_height > 0) return {options.input_width, options.input_height};
  if (image_size.width <= 0 || image_size.height <= 0) return {options.input_width, 32};
  const int64_t w = options.input_width;
  // input_width * rows / cols, rounded up to a multiple of 32 (at least 32, at most 4096).
  const int64_t h = (w * image_size.height + image_size.width - 1) / image_size.width;
  const int64_t rounded = std::clamp<int64_t>((h + 31) / 32 * 32, 32, 4096);
  return {options.input_width, static_cast<int>(rounded)};
}

namespace {

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

void RequireReadableFile(const std::string& path, const char* what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, 0, std::string(what) + " file not found");
  if (!fs::is_regular_file(path, ec))
    throw InputError(path, 0, std::string(what) + " is not a regular file");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path, 0, std::string("cannot open ") + what + " file");
}

struct CfgSection {
  std::string type;
  int line = 0;
  std::map<std::string, std::string> values;
};

std::vector<CfgSection> ReadCfgSections(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open Darknet cfg file");
  std::vector<CfgSection> sections;
  std::string raw;
  int line_no = 0;
  while (std::getline(in, raw)) {
    ++line_no;
    std::string line = Trim(raw);
    if (line.empty() || line[0] == '#' || line[0] == ';') continue;
    if (line[0] == '[') {
      const auto close = line.find(']');
      if (close == std::string::npos || close < 2)
        throw InputError(path, line_no, "malformed section header '" + line + "'");
      sections.push_back({line.substr(1, close - 1), line_no, {}});
      continue;
    }
    const auto eq = line.find('=');
    if (eq == std::string::npos)
      throw InputError(path, line_no, "expected key=value, got '" + line + "'");
    if (sections.empty()) throw InputError(path, line_no, "key=value before the first [section]");
    sections.back().values[Trim(line.substr(0, eq))] = Trim(line.substr(eq + 1));
  }
  if (sections.empty())
    throw InputError(path, 0, "Darknet cfg has no sections (empty or not a cfg)");
  if (sections.front().type != "net" && sections.front().type != "network")
    throw InputError(path, sections.front().line, "Darknet cfg must start with [net]");
  return sections;
}

int GetInt(const std::string& path, const CfgSection& s, const std::string& key, int def) {
  auto it = s.values.find(key);
  if (it == s.values.end()) return def;
  try {
    size_t pos = 0;
    const int v = std::stoi(it->second, &pos);
    if (pos != it->second.size()) throw std::invalid_argument("trailing");
    return v;
  } catch (const std::exception&) {
    throw InputError(path, s.line,
                     "[" + s.type + "] " + key + "=" + it->second + " is not an integer");
  }
}

std::vector<int> GetIntList(const std::string& path, const CfgSection& s, const std::string& key) {
  auto it = s.values.find(key);
  if (it == s.values.end()) throw InputError(path, s.line, "[" + s.type + "] lacks " + key + "=");
  std::vector<int> out;
  std::stringstream ss(it->second);
  std::string item;
  while (std::getline(ss, item, ',')) {
    item = Trim(item);
    if (item.empty()) continue;
    try {
      out.push_back(std::stoi(item));
    } catch (const std::exception&) {
      throw InputError(path, s.line,
                       "[" + s.type + "] " + key + "=" + it->second + " is not a list of integers");
    }
  }
  if (out.empty()) throw InputError(path, s.line, "[" + s.type + "] " + key + "= is empty");
  return out;
}

std::vector<std::string> ReadNames(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open class names file");
  std::vector<std::string> names;
  std::string line;
  while (std::getline(in, line)) names.push_back(Trim(line));
  while (!names.empty() && names.back().empty()) names.pop_back();
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i].empty()) throw InputError(path, static_cast<int>(i + 1), "empty class name");
  if (names.empty()) throw InputError(path, 0, "class names file is empty");
  return names;
}

}  // namespace

DarknetCfgInfo ParseDarknetCfg(const std::string& cfg_path) {
  RequireReadableFile(cfg_path, "Darknet cfg");
  const std::vector<CfgSection> sections = ReadCfgSections(cfg_path);
  DarknetCfgInfo info;
  const CfgSection& net = sections.front();
  info.input_width = GetInt(cfg_path, net, "width", 0);
  info.input_height = GetInt(cfg_path, net, "height", 0);
  info.input_channels = GetInt(cfg_path, net, "channels", 3);
  if (info.input_channels <= 0) throw InputError(cfg_path, net.line, "[net] channels must be > 0");

  std::vector<int> out_channels;  // per layer (sections after [net])
  int channels = info.input_channels;
  for (size_t k = 1; k < sections.size(); ++k) {
    const CfgSection& s = sections[k];
    const int index = static_cast<int>(k) - 1;
    auto layer_ref = [&](int ref) {
      const int abs = ref < 0 ? index + ref : ref;
      if (abs < 0 || abs >= index)
        throw InputError(cfg_path, s.line,
                         "[" + s.type + "] refers to layer " + std::to_string(ref) +
                             " which does not precede layer " + std::to_string(index));
      return abs;
    };
    if (s.type == "convolutional" || s.type == "conv") {
      const int filters = GetInt(cfg_path, s, "filters", 1);
      const int size = GetInt(cfg_path, s, "size", 1);
      const int groups = GetInt(cfg_path, s, "groups", 1);
      const bool bn = GetInt(cfg_path, s, "batch_normalize", 0) != 0;
      if (filters <= 0 || size <= 0 || groups <= 0 || channels % groups != 0)
        throw InputError(cfg_path, s.line,
                         "[convolutional] with invalid filters/size/groups for " +
                             std::to_string(channels) + " input channels");
      info.num_parameters += int64_t{filters} * (bn ? 4 : 1);
      info.num_parameters += int64_t{filters} * (channels / groups) * size * size;
      ++info.num_conv_layers;
      info.conv_layers.push_back({filters, int64_t{channels / groups} * size * size, bn});
      channels = filters;
    } else if (s.type == "route") {
      const std::vector<int> refs = GetIntList(cfg_path, s, "layers");
      int sum = 0;
      for (int r : refs) sum += out_channels[layer_ref(r)];
      const int groups = GetInt(cfg_path, s, "groups", 1);
      if (groups <= 0 || sum % groups != 0)
        throw InputError(cfg_path, s.line, "[route] invalid groups");
      channels = sum / groups;
    } else if (s.type == "shortcut") {
      layer_ref(GetInt(cfg_path, s, "from", -1));
      // output has the channels of the previous layer
    } else if (s.type == "reorg") {
      const int stride = GetInt(cfg_path, s, "stride", 2);
      channels *= stride * stride;
    } else if (s.type == "maxpool" || s.type == "upsample" || s.type == "dropout" ||
               s.type == "avgpool" || s.type == "scale_channels" || s.type == "sam") {
      // channel count unchanged
    } else if (s.type == "yolo" || s.type == "region") {
      const int classes = GetInt(cfg_path, s, "classes", -1);
      if (classes <= 0) throw InputError(cfg_path, s.line, "[" + s.type + "] lacks classes=");
      if (info.num_classes >= 0 && info.num_classes != classes)
        throw InputError(cfg_path, s.line, "[" + s.type + "] classes differ between output layers");
      info.num_classes = classes;
    } else {
      throw InputError(cfg_path, s.line, "unsupported Darknet layer type [" + s.type + "]");
    }
    out_channels.push_back(channels);
  }
  if (info.num_conv_layers == 0)
    throw InputError(cfg_path, 0, "Darknet cfg has no [convolutional] layer");
  return info;
}

DetectorOptions DetectorOptionsForModel(const std::string& name, const std::string& models_dir_in) {
  const std::string models_dir = models_dir_in.empty() ? ModelsDir() : models_dir_in;
  if (models_dir.empty())
    throw InputError("models directory not found (set DYGSLAM_MODELS_DIR) while resolving model '" +
                     name + "'");
  struct Known {
    const char* name;
    const char* dir;
    const char* stem;
    const char* names;
    int input;
  };
  static const Known kKnown[] = {
      {"yolo-fastest-1.1", "yolo-fastest-1.1_coco", "yolo-fastest-1.1", "coco.names", 320},
      {"yolo-fastest-1.1-xl", "yolo-fastest-1.1_coco", "yolo-fastest-1.1-xl", "coco.names", 320},
      {"yolo-fastest-1.1_body", "yolo-fastest-1.1_body", "yolo-fastest-1.1_body", "body.names",
       320},
      {"body", "yolo-fastest-1.1_body", "yolo-fastest-1.1_body", "body.names", 320},
      {"yolov3-tiny", "yolov3-tiny", "yolov3-tiny", "coco.names", 416},
      {"CYTI", "crowd-slam-CYTI-yolov3-tiny-crowdhuman_cfg-only", "CYTI", "CYTI.names", 160},
      {"crowd-slam-CYTI", "crowd-slam-CYTI-yolov3-tiny-crowdhuman_cfg-only", "CYTI", "CYTI.names",
       160},
  };
  DetectorOptions options;
  for (const Known& k : kKnown) {
    if (name != k.name) continue;
    const fs::path dir = fs::path(models_dir) / k.dir;
    options.cfg_path = (dir / (std::string(k.stem) + ".cfg")).string();
    options.weights_path = (dir / (std::string(k.stem) + ".weights")).string();
    options.names_path = (dir / k.names).string();
    options.input_width = k.input;
    options.input_height = 0;  // the image's aspect ratio
    return options;
  }
  // Generic: <models_dir>/<name>/ with one cfg.
  const fs::path dir = fs::path(models_dir) / name;
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(dir.string(), 0, "unknown detector model '" + name + "' (no such directory)");
  std::vector<fs::path> cfgs, names;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".cfg") cfgs.push_back(e.path());
    if (e.path().extension() == ".names") names.push_back(e.path());
  }
  if (cfgs.size() != 1)
    throw InputError(
        dir.string(), 0,
        "expected exactly one .cfg in model directory, found " + std::to_string(cfgs.size()));
  if (names.size() != 1)
    throw InputError(
        dir.string(), 0,
        "expected exactly one .names in model directory, found " + std::to_string(names.size()));
  options.cfg_path = cfgs[0].string();
  options.weights_path = fs::path(cfgs[0]).replace_extension(".weights").string();
  options.names_path = names[0].string();
  const DarknetCfgInfo info = ParseDarknetCfg(options.cfg_path);
  if (info.input_width > 0 && info.input_width % 32 == 0) options.input_width = info.input_width;
  if (info.input_height > 0 && info.input_height % 32 == 0)
    options.input_height = info.input_height;
  return options;
}

struct YoloDetector::Impl {
  cv::dnn::Net net;
  std::vector<std::string> output_names;
  std::vector<cv::Mat> outputs;
  cv::Mat blob;
};

YoloDetector::YoloDetector(const DetectorOptions& options) : options_(options), impl_(new Impl) {}
YoloDetector::~YoloDetector() = default;

namespace {

// Weights: header (major, minor, revision int32; `seen` uint64 from version 0.2, else int32),
// then the float parameters. A short file would make OpenCV read garbage or fail obscurely.
void CheckWeightsSize(const DetectorOptions& options, const DarknetCfgInfo& info) {
  std::ifstream w(options.weights_path, std::ios::binary);
  int32_t header[3] = {0, 0, 0};
  if (!w.read(reinterpret_cast<char*>(header), sizeof(header)))
    throw InputError(options.weights_path, 0, "Darknet weights file is too short for its header");
  const bool seen64 = (header[0] * 10 + header[1]) >= 2 && header[0] < 1000 && header[1] < 1000;
  const int64_t header_bytes = 12 + (seen64 ? 8 : 4);
  const int64_t expected = header_bytes + 4 * info.num_parameters;
  std::error_code ec;
  const int64_t actual = static_cast<int64_t>(fs::file_size(options.weights_path, ec));
  if (actual != expected)
    throw InputError(options.weights_path, 0,
                     std::string(actual < expected ? "Darknet weights file is truncated or"
                                                   : "Darknet weights file is too large:") +
                         " does not belong to " + options.cfg_path + ": " + std::to_string(actual) +
                         " bytes, the cfg needs " + std::to_string(expected));
}

}  // namespace

void YoloDetector::ClassifyClasses() {
  bool any_dynamic = false;
  for (const std::string& n : class_names_) {
    auto it = options_.class_aliases.find(n);
    const std::string canonical = it == options_.class_aliases.end() ? n : it->second;
    const bool dyn = std::find(options_.dynamic_classes.begin(), options_.dynamic_classes.end(),
                               canonical) != options_.dynamic_classes.end();
    canonical_names_.push_back(canonical);
    is_dynamic_.push_back(dyn ? 1 : 0);
    any_dynamic |= dyn;
  }
  if (!any_dynamic && !options_.report_all_classes) {
    std::string wanted;
    for (const auto& c : options_.dynamic_classes) wanted += (wanted.empty() ? "" : ", ") + c;
    throw InputError(options_.names_path, 0,
                     "none of the dynamic classes {" + wanted +
                         "} is in the class names file "
                         "(after aliases); first class is '" +
                         class_names_.front() + "'");
  }
}

std::unique_ptr<YoloDetector> YoloDetector::Create(const DetectorOptions& options) {
  options.Check();
  RequireReadableFile(options.cfg_path, "Darknet cfg");
  RequireReadableFile(options.weights_path, "Darknet weights");
  RequireReadableFile(options.names_path, "class names");

  const DarknetCfgInfo info = ParseDarknetCfg(options.cfg_path);
  if (info.num_classes <= 0)
    throw InputError(options.cfg_path, 0, "Darknet cfg has no [yolo] or [region] output layer");

  CheckWeightsSize(options, info);

  std::unique_ptr<YoloDetector> det(new YoloDetector(options));
  det->class_names_ = ReadNames(options.names_path);
  if (static_cast<int>(det->class_names_.size()) != info.num_classes)
    throw InputError(options.names_path, 0,
                     "class names file has " + std::to_string(det->class_names_.size()) +
                         " names but " + options.cfg_path + " declares " +
                         std::to_string(info.num_classes) + " classes");
  det->ClassifyClasses();

  if (options.confidence_threshold < 0.2f) {
    LOG_WARNING
        << "Detector.confidence_threshold " << options.confidence_threshold
        << " is below the 0.2 that OpenCV's yolo layer applies internally; 0.2 is in effect";
  }
  if (options.num_threads > 0) cv::setNumThreads(options.num_threads);
  try {
    det->impl_->net = cv::dnn::readNetFromDarknet(options.cfg_path, options.weights_path);
  } catch (const cv::Exception& e) {
    throw InputError(options.cfg_path, 0,
                     "OpenCV cannot load the Darknet network with weights " + options.weights_path +
                         ": " + e.what());
  }
  if (det->impl_->net.empty())
    throw InputError(options.cfg_path, 0,
                     "OpenCV loaded an empty network (weights " + options.weights_path + ")");
  det->impl_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  det->impl_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  det->impl_->output_names = det->impl_->net.getUnconnectedOutLayersNames();
  // OpenCV sets the network up (layer fusion, buffers) on its first forward pass, which takes
  // several times a normal one: done here, at start-up, not on the first frames of a run, which
  // would otherwise reach their poses late at the camera's rate.
  det->Detect(cv::Mat(480, 640, CV_8UC3, cv::Scalar(0, 0, 0)));
  return det;
}

bool YoloDetector::IsDynamicClass(int class_id) const {
  return class_id >= 0 && class_id < static_cast<int>(is_dynamic_.size()) && is_dynamic_[class_id];
}

std::vector<Detection> YoloDetector::Detect(const cv::Mat& bgr) {
  if (bgr.empty()) throw InputError("YoloDetector::Detect: empty image");
  if (bgr.type() != CV_8UC3) throw InputError("YoloDetector::Detect: image must be CV_8UC3 BGR");
  // Plain resize (Darknet's detector does not letterbox these models), BGR -> RGB, [0, 1].
  cv::dnn::blobFromImage(bgr, impl_->blob, 1.0 / 255.0, DetectorInputSize(options_, bgr.size()),
                         cv::Scalar(),
                         /*swapRB=*/true, /*crop=*/false, CV_32F);
  impl_->net.setInput(impl_->blob);
  impl_->net.forward(impl_->outputs, impl_->output_names);

  const int num_classes = static_cast<int>(class_names_.size());
  const float width = static_cast<float>(bgr.cols), height = static_cast<float>(bgr.rows);
  std::map<int, std::vector<cv::Rect2d>> boxes;
  std::map<int, std::vector<float>> scores;
  for (const cv::Mat& out : impl_->outputs) {
    // Rows: [cx, cy, w, h, objectness, class scores...] normalised to the input; OpenCV's yolo
    // layer already multiplies the class probabilities by the objectness.
    const cv::Mat m = out.reshape(1, static_cast<int>(out.total() / out.size[out.dims - 1]));
    if (m.cols != 5 + num_classes)
      throw InputError(options_.cfg_path, 0,
                       "network output has " + std::to_string(m.cols) + " columns, expected " +
                           std::to_string(5 + num_classes));
    for (int r = 0; r < m.rows; ++r) {
      const float* row = m.ptr<float>(r);
      int best = -1;
      float best_score = 0.f;
      for (int c = 0; c < num_classes; ++c) {
        if (!options_.report_all_classes && !is_dynamic_[c]) continue;
        if (row[5 + c] > best_score) {
          best_score = row[5 + c];
          best = c;
        }
      }
      if (best < 0 || best_score < options_.confidence_threshold) continue;
      const float cx = row[0] * width, cy = row[1] * height;
      const float w = row[2] * width, h = row[3] * height;
      boxes[best].emplace_back(cx - 0.5f * w, cy - 0.5f * h, w, h);
      scores[best].push_back(best_score);
    }
  }

  std::vector<Detection> result;
  const cv::Rect2d image_rect(0, 0, width, height);
  for (auto& [cls, cls_boxes] : boxes) {
    std::vector<int> keep;
    cv::dnn::NMSBoxes(cls_boxes, scores[cls], options_.confidence_threshold, options_.nms_threshold,
                      keep);
    for (int k : keep) {
      const cv::Rect2d clipped = cls_boxes[k] & image_rect;
      if (clipped.width <= 0 || clipped.height <= 0) continue;
      Detection d;
      d.box = cv::Rect2f(static_cast<float>(clipped.x), static_cast<float>(clipped.y),
                         static_cast<float>(clipped.width), static_cast<float>(clipped.height));
      d.class_id = cls;
      d.label = canonical_names_[cls];
      d.score = scores[cls][k];
      result.push_back(d);
    }
  }
  std::sort(result.begin(), result.end(),
            [](const Detection& a, const Detection& b) { return a.score > b.score; });
  return result;
}

}  // namespace dygslam
