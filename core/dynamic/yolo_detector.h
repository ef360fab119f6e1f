// Darknet YOLO object detector through OpenCV DNN (CPU). Finds the dynamic objects (people) whose
// boxes define the dynamic region of the DYG-SLAM filter (paper sec. 2.2).
//
//   DetectorOptions options = DetectorOptionsForModel("yolo-fastest-1.1");
//   std::unique_ptr<YoloDetector> detector = YoloDetector::Create(options);
//   std::vector<Detection> people = detector->Detect(bgr);
//
// Supported models (Darknet cfg + weights + names): YOLOv3-tiny (COCO, 80 classes), the
// CrowdHuman YOLOv3-tiny of Crowd-SLAM (CYTI, 1 class "person"), Yolo-Fastest-1.1 and -1.1-xl
// (COCO) and Yolo-Fastest-1.1_body (1 class "body"). Class names are mapped through
// `class_aliases` before they are compared with `dynamic_classes`: by default "body" -> "person",
// so the body model reports "person" detections.
//
// Preprocessing is a plain resize to input_width x input_height (no letterbox), RGB, [0,1]:
// that is how Darknet's own detector feeds these networks. Boxes are returned in pixels of the
// input image.
//
// Threads: cv::dnn parallelises layers with OpenCV's thread pool (TBB here). `num_threads > 0`
// calls cv::setNumThreads(num_threads) when the detector is created; this is PROCESS-WIDE (it
// also affects every other OpenCV parallel_for_, e.g. cv::ORB). To run the detector on one core
// concurrently with ORB extraction on the other, create it with num_threads = 1 and run Detect on
// its own std::thread.
//
// A detector instance is not thread-safe (cv::dnn::Net::forward); use one instance per thread.
#pragma once

#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/base/types.h"

namespace dygslam {

struct DetectorOptions {
  std::string cfg_path;      // Darknet .cfg
  std::string weights_path;  // Darknet .weights
  std::string names_path;    // one class name per line, in class-id order
  // Network input size (multiples of 32). The models were trained at 320 (Yolo-Fastest) /
  // 416 (YOLOv3-tiny) / 160 (CYTI); any multiple of 32 works. input_height 0: from the image's
  // aspect ratio, input_width * rows / cols rounded up to a multiple of 32 (DetectorInputSize;
  // 320 x 256 for 640 x 480 frames): a 4:3 frame is not stretched to a square, which costs
  // 0.8x the network's time for boxes that agree with the square input's
  // (BENCHMARKS.md). The dataset presets (config/*.yaml) keep 320 x 320.
  int input_width = 320;
  int input_height = 0;
  // Minimum class score (objectness x class probability). OpenCV's [yolo] layer already zeroes
  // scores below 0.2 (its default `thresh`), so values below 0.2 act as 0.2 (checked: no box
  // below 0.206 with 0.01); Create() warns.
  float confidence_threshold = 0.3f;
  // IoU above which the lower-scoring box of the same class is suppressed.
  float nms_threshold = 0.4f;
  // Canonical class names (after aliasing) that are dynamic.
  std::vector<std::string> dynamic_classes = {"person"};
  // Name in the names file -> canonical name.
  std::map<std::string, std::string> class_aliases = {{"body", "person"}};
  // false: Detect returns only dynamic-class boxes. true: all classes above the threshold.
  bool report_all_classes = false;
  // > 0: cv::setNumThreads(num_threads) at creation (process-wide, see above). 0: leave as is.
  // 1 by default: the detector runs beside extraction and tracking on a thread of its own, and
  // OpenCV's two-thread pool only added CPU time (0.92-0.98x the CPU per frame with one thread,
  // detections identical; BENCHMARKS.md).
  int num_threads = 1;

  void Check() const;
};

// Options for a model shipped in `models_dir` (default ModelsDir()), by name:
//   "yolo-fastest-1.1", "yolo-fastest-1.1-xl"  (dir yolo-fastest-1.1_coco)
//   "yolo-fastest-1.1_body" (alias "body")     (dir yolo-fastest-1.1_body)
//   "yolov3-tiny"                              (dir yolov3-tiny; weights from the Darknet release)
//   "CYTI" (alias "crowd-slam-CYTI")           (dir
//   crowd-slam-CYTI-yolov3-tiny-crowdhuman_cfg-only)
// Any other name: <models_dir>/<name>/ with exactly one .cfg, the .weights of the same stem and
// one .names file. Throws InputError when the model directory or its cfg is not found. The
// returned options have the model's input width and input_height 0 (the image's aspect ratio);
// a generic model takes both from its cfg. Files are validated by Create().
DetectorOptions DetectorOptionsForModel(const std::string& name,
                                        const std::string& models_dir = "");

// The network input size for an image of `image_size` (input_height 0: from its aspect ratio).
cv::Size DetectorInputSize(const DetectorOptions& options, const cv::Size& image_size);

// What a Darknet cfg declares: the number of float parameters its .weights file must hold after
// the header (biases, batch-norm scales/means/variances and kernels of every [convolutional]
// layer, in file order) and the number of classes of its [yolo]/[region] layers (-1 if none).
struct DarknetCfgInfo {
  // One [convolutional] layer as its weights are stored: biases (filters), then for
  // batch_normalize scales, rolling means, rolling variances (filters each), then the kernels
  // (filters * input_channels / groups * size * size).
  struct ConvLayer {
    int filters = 0;
    int64_t kernel_values = 0;  // input_channels / groups * size * size per filter
    bool batch_normalize = false;
  };
  std::vector<ConvLayer> conv_layers;
  int64_t num_parameters = 0;
  int num_classes = -1;
  int num_conv_layers = 0;
  int input_width = 0, input_height = 0, input_channels = 3;
};
// Throws InputError "<cfg>:<line>: ..." when the cfg cannot be parsed or uses a layer type whose
// channel count is unknown.
DarknetCfgInfo ParseDarknetCfg(const std::string& cfg_path);

class YoloDetector {
 public:
  // Validates the files (exists, cfg parses, weights size matches the cfg, names count matches
  // the cfg classes, a dynamic class is present) and loads the network. Throws InvalidOptions
  // for bad options and InputError naming the offending file.
  static std::unique_ptr<YoloDetector> Create(const DetectorOptions& options);
  ~YoloDetector();
  YoloDetector(const YoloDetector&) = delete;
  YoloDetector& operator=(const YoloDetector&) = delete;

  // Detections on a CV_8UC3 BGR image (boxes clipped to the image), sorted by score.
  // Throws InputError on an empty or non-8UC3 image.
  std::vector<Detection> Detect(const cv::Mat& bgr);

  const DetectorOptions& options() const { return options_; }
  // Class names as read from the names file (before aliasing).
  const std::vector<std::string>& class_names() const { return class_names_; }
  bool IsDynamicClass(int class_id) const;

 private:
  explicit YoloDetector(const DetectorOptions& options);
  // Canonical names (after the aliases) and which classes are dynamic; InputError naming the
  // names file when none of the wanted dynamic classes is among them.
  void ClassifyClasses();
  struct Impl;
  DetectorOptions options_;
  std::vector<std::string> class_names_;
  std::vector<std::string> canonical_names_;
  std::vector<char> is_dynamic_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dygslam
