#include "core/dynamic/yolo_detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "core/dynamic/detection_worker.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

// Path of the `index`-th image entry (0-based, comments skipped) of <dataset>/rgb.txt.
std::string RgbEntry(const std::string& dataset, int index) {
  std::ifstream in(dataset + "/rgb.txt");
  std::string line;
  int k = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (k++ == index) {
      std::istringstream ss(line);
      std::string stamp, rel;
      ss >> stamp >> rel;
      return dataset + "/" + rel;
    }
  }
  return "";
}

void ExpectThrowsNaming(const std::function<void()>& fn, const std::string& needle,
                        const std::string& also = "") {
  try {
    fn();
    ADD_FAILURE() << "no exception; expected one naming " << needle;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    if (!also.empty()) {
      EXPECT_NE(std::string(e.what()).find(also), std::string::npos) << e.what();
    }
    std::printf("  error: %s\n", e.what());
  }
}

TEST(DarknetCfg, ExpectedWeightSizesMatchShippedFiles) {
  DYGSLAM_REQUIRE_MODELS(models);
  for (const char* name : {"yolo-fastest-1.1", "yolo-fastest-1.1-xl", "yolo-fastest-1.1_body"}) {
    const DetectorOptions o = DetectorOptionsForModel(name, models);
    const DarknetCfgInfo info = ParseDarknetCfg(o.cfg_path);
    const int64_t size = static_cast<int64_t>(fs::file_size(o.weights_path));
    // Header of 16 or 20 bytes.
    EXPECT_TRUE(size == 20 + 4 * info.num_parameters || size == 16 + 4 * info.num_parameters)
        << name << ": file " << size << " params " << info.num_parameters;
  }
  // YOLOv3-tiny: the official weights file has 35,434,956 bytes (20-byte header).
  const DarknetCfgInfo tiny =
      ParseDarknetCfg(DetectorOptionsForModel("yolov3-tiny", models).cfg_path);
  EXPECT_EQ(20 + 4 * tiny.num_parameters, 35434956);
  EXPECT_EQ(tiny.num_classes, 80);
  EXPECT_EQ(tiny.num_conv_layers, 13);
  const DarknetCfgInfo cyti = ParseDarknetCfg(DetectorOptionsForModel("CYTI", models).cfg_path);
  EXPECT_EQ(cyti.num_classes, 1);
  EXPECT_EQ(cyti.input_width, 160);
}

TEST(DarknetCfg, MalformedCfgNamesFileAndLine) {
  const std::string dir = testing::MakeTempDir("cfg");
  const std::string cfg = dir + "/bad.cfg";
  { std::ofstream(cfg) << "[net]\nwidth=320\n[convolutional]\nfilters=abc\n"; }
  ExpectThrowsNaming([&] { ParseDarknetCfg(cfg); }, cfg + ":3");
  { std::ofstream(cfg) << "[net]\n[convolutional]\nfilters=8\n[mystery]\n"; }
  ExpectThrowsNaming([&] { ParseDarknetCfg(cfg); }, cfg + ":4", "mystery");
  { std::ofstream(cfg) << ""; }
  ExpectThrowsNaming([&] { ParseDarknetCfg(cfg); }, cfg);
  ExpectThrowsNaming([&] { ParseDarknetCfg(dir + "/absent.cfg"); }, dir + "/absent.cfg",
                     "not found");
}

// input_height 0: the width's share of the image's aspect ratio, rounded up to a multiple of 32.
TEST(YoloDetectorOptions, InputSizeFollowsTheImagesAspectRatio) {
  DetectorOptions o;
  o.input_width = 320;
  o.input_height = 0;
  EXPECT_EQ(DetectorInputSize(o, {640, 480}), cv::Size(320, 256));   // 240 -> 256
  EXPECT_EQ(DetectorInputSize(o, {1280, 720}), cv::Size(320, 192));  // 180 -> 192
  EXPECT_EQ(DetectorInputSize(o, {480, 640}), cv::Size(320, 448));   // 426.7 -> 448
  EXPECT_EQ(DetectorInputSize(o, {320, 320}), cv::Size(320, 320));
  o.input_width = 160;
  EXPECT_EQ(DetectorInputSize(o, {640, 480}), cv::Size(160, 128));  // 120 -> 128
  o.input_height = 320;                                             // given: used as is
  EXPECT_EQ(DetectorInputSize(o, {640, 480}), cv::Size(160, 320));
}

// The shipped models: their trained width, the height from the image (Bonn / TUM: 320 x 256).
TEST(YoloDetectorFiles, KnownModelsTakeTheHeightFromTheImage) {
  DYGSLAM_REQUIRE_MODELS(models);
  EXPECT_EQ(DetectorInputSize(DetectorOptionsForModel("yolo-fastest-1.1", models), {640, 480}),
            cv::Size(320, 256));
  EXPECT_EQ(DetectorInputSize(DetectorOptionsForModel("yolov3-tiny", models), {640, 480}),
            cv::Size(416, 320));
}

TEST(YoloDetectorOptions, Check) {
  DetectorOptions o;
  o.cfg_path = "a.cfg";
  o.weights_path = "a.weights";
  o.names_path = "a.names";
  EXPECT_NO_THROW(o.Check());
  o.input_width = 300;
  EXPECT_THROW(o.Check(), InvalidOptions);
  o.input_width = 320;
  o.input_height = 0;  // from the image's aspect ratio
  EXPECT_NO_THROW(o.Check());
  o.input_height = 100;
  EXPECT_THROW(o.Check(), InvalidOptions);
  o.input_height = 0;
  o.confidence_threshold = 0;
  EXPECT_THROW(o.Check(), InvalidOptions);
  o.confidence_threshold = 0.3f;
  o.dynamic_classes.clear();
  EXPECT_THROW(o.Check(), InvalidOptions);
  EXPECT_THROW(DetectorOptionsForModel("no-such-model", testing::MakeTempDir("models")),
               InputError);
}

class ShippedModels : public ::testing::TestWithParam<const char*> {};

TEST_P(ShippedModels, PeopleFrameHasPersonEmptyFrameHasNone) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  DetectorOptions o = DetectorOptionsForModel(GetParam(), models);
  auto detector = YoloDetector::Create(o);
  const cv::Mat people = cv::imread(RgbEntry(dataset, 250), cv::IMREAD_COLOR);
  const cv::Mat empty = cv::imread(RgbEntry(dataset, 10), cv::IMREAD_COLOR);
  ASSERT_FALSE(people.empty());
  ASSERT_FALSE(empty.empty());
  const std::vector<Detection> on_people = detector->Detect(people);
  const std::vector<Detection> on_empty = detector->Detect(empty);
  std::printf("%s: %zu boxes on entry 250, %zu on entry 10\n", GetParam(), on_people.size(),
              on_empty.size());
  for (const Detection& d : on_people)
    std::printf("  %s %.2f [%.0f %.0f %.0f %.0f]\n", d.label.c_str(), d.score, d.box.x, d.box.y,
                d.box.width, d.box.height);
  ASSERT_GE(on_people.size(), 1u);
  EXPECT_TRUE(on_empty.empty());
  for (const Detection& d : on_people) {
    EXPECT_EQ(d.label, "person");  // "body" is aliased to "person"
    EXPECT_TRUE(detector->IsDynamicClass(d.class_id));
    EXPECT_GE(d.box.x, 0.f);
    EXPECT_GE(d.box.y, 0.f);
    EXPECT_LE(d.box.x + d.box.width, people.cols + 1e-3f);
    EXPECT_LE(d.box.y + d.box.height, people.rows + 1e-3f);
    // Person-shaped and of plausible size for a person 1-4 m away.
    EXPECT_GT(d.box.height, 60.f);
    EXPECT_GE(d.score, o.confidence_threshold);
  }
  // 416 input also works (anchors scale with the input).
  o.input_width = o.input_height = 416;
  auto detector416 = YoloDetector::Create(o);
  EXPECT_GE(detector416->Detect(people).size(), 1u);
}

INSTANTIATE_TEST_SUITE_P(Dynamic, ShippedModels,
                         ::testing::Values("yolo-fastest-1.1", "yolo-fastest-1.1-xl",
                                           "yolo-fastest-1.1_body"),
                         [](const ::testing::TestParamInfo<const char*>& info) {
                           std::string s = info.param;
                           for (char& c : s)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return s;
                         });

TEST(YoloDetectorFiles, MissingAndCorruptFilesNameTheFile) {
  DYGSLAM_REQUIRE_MODELS(models);
  const DetectorOptions good = DetectorOptionsForModel("yolo-fastest-1.1_body", models);
  const std::string dir = testing::MakeTempDir("det_files");

  DetectorOptions o = good;
  o.cfg_path = dir + "/missing.cfg";
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.cfg_path, "not found");

  o = good;
  o.weights_path = dir + "/missing.weights";
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.weights_path, "not found");

  o = good;
  o.names_path = dir + "/missing.names";
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.names_path, "not found");

  // Truncated weights.
  {
    std::ifstream in(good.weights_path, std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir + "/half.weights", std::ios::binary).write(bytes.data(), bytes.size() / 2);
    std::ofstream(dir + "/tiny.weights", std::ios::binary).write(bytes.data(), 7);
  }
  o = good;
  o.weights_path = dir + "/half.weights";
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.weights_path, "truncated");
  o.weights_path = dir + "/tiny.weights";
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.weights_path, "header");

  // Weights of another model (COCO Yolo-Fastest weights with the body cfg).
  o = good;
  o.weights_path = DetectorOptionsForModel("yolo-fastest-1.1-xl", models).weights_path;
  EXPECT_THROW(YoloDetector::Create(o), InputError);

  // Names without the dynamic class; names count not matching the cfg.
  {
    std::ofstream(dir + "/dog.names") << "dog\n";
    std::ofstream(dir + "/two.names") << "body\nperson\n";
  }
  o = good;
  o.names_path = dir + "/dog.names";
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.names_path, "person");
  o.names_path = dir + "/two.names";
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.names_path, "declares 1");
  // Without the alias, "body" is not a person.
  o = good;
  o.class_aliases.clear();
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.names_path, "person");

  // Corrupt cfg (garbage bytes).
  { std::ofstream(dir + "/garbage.cfg", std::ios::binary) << "\x01\x02 not a cfg \xff"; }
  o = good;
  o.cfg_path = dir + "/garbage.cfg";
  ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.cfg_path);
}

// YOLOv3-tiny / CYTI, the paper's detector (its weights are not available offline): the network
// built from the real cfg runs the whole decode path with generated weights whose output is known.
// Every kernel is 0 and every batch-norm layer outputs 0, so each detection head (the convs without
// batch norm, linear, in front of the [yolo] layers) outputs its biases in every cell: tx = ty = tw
// = th = 0 (box of exactly the anchor's size at the cell centre), objectness `objectness_logit`,
// +8 for the class `person` and -8 for the others.
void WriteGeneratedWeights(const std::string& path, const DarknetCfgInfo& info, int person_class,
                           float objectness_logit) {
  std::ofstream out(path, std::ios::binary);
  const int32_t header[3] = {0, 2, 0};
  const uint64_t seen = 0;
  out.write(reinterpret_cast<const char*>(header), sizeof(header));
  out.write(reinterpret_cast<const char*>(&seen), sizeof(seen));
  auto write = [&](const std::vector<float>& v) {
    out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * 4));
  };
  for (const DarknetCfgInfo::ConvLayer& layer : info.conv_layers) {
    const size_t n = static_cast<size_t>(layer.filters);
    std::vector<float> biases(n, 0.f);
    if (!layer.batch_normalize) {  // a detection head: per anchor tx ty tw th obj class...
      const int per_anchor = 5 + info.num_classes;
      ASSERT_EQ(layer.filters % per_anchor, 0);
      for (size_t c = 0; c < n; ++c) {
        const int k = static_cast<int>(c) % per_anchor;
        if (k == 4) biases[c] = objectness_logit;
        if (k >= 5) biases[c] = (k - 5 == person_class) ? 8.f : -8.f;
      }
    }
    write(biases);
    if (layer.batch_normalize) {
      write(std::vector<float>(n, 0.f));  // scales: the layer outputs its bias (0)
      write(std::vector<float>(n, 0.f));  // rolling means
      write(std::vector<float>(n, 1.f));  // rolling variances
    }
    write(std::vector<float>(n * static_cast<size_t>(layer.kernel_values), 0.f));
  }
}

TEST(YoloDetectorFiles, Yolov3TinyCfgDecodesKnownOutputs) {
  DYGSLAM_REQUIRE_MODELS(models);
  const std::string dir = testing::MakeTempDir("tiny");
  // The anchors of both cfgs (pixels at the network input).
  const std::vector<cv::Size2f> anchors = {{10, 14}, {23, 27},   {37, 58},
                                           {81, 82}, {135, 169}, {344, 319}};
  for (const char* name : {"yolov3-tiny", "CYTI"}) {
    SCOPED_TRACE(name);
    DetectorOptions o = DetectorOptionsForModel(name, models);
    // The real weights are absent here: the error names the file.
    if (!fs::exists(o.weights_path)) {
      ExpectThrowsNaming([&] { YoloDetector::Create(o); }, o.weights_path, "not found");
    }
    const DarknetCfgInfo info = ParseDarknetCfg(o.cfg_path);
    ASSERT_EQ(info.conv_layers.size(), static_cast<size_t>(info.num_conv_layers));
    int64_t counted = 0;
    for (const auto& l : info.conv_layers)
      counted += int64_t{l.filters} * ((l.batch_normalize ? 4 : 1) + l.kernel_values);
    EXPECT_EQ(counted, info.num_parameters);
    int person = -1;
    {
      std::ifstream names(o.names_path);
      std::string line;
      for (int id = 0; std::getline(names, line); ++id)
        if (line == "person") person = id;
    }
    ASSERT_GE(person, 0);
    cv::Mat image(480, 640, CV_8UC3);
    cv::randu(image, 0, 255);

    // Objectness logit -8 (score 3e-4): nothing is detected.
    o.weights_path = dir + "/" + name + "_none.weights";
    WriteGeneratedWeights(o.weights_path, info, person, -8.f);
    EXPECT_TRUE(YoloDetector::Create(o)->Detect(image).empty());

    // Objectness +8: person boxes of exactly the anchors' sizes, scaled from the network input
    // to the image (plain resize), centred on cell centres.
    o.weights_path = dir + "/" + name + "_all.weights";
    WriteGeneratedWeights(o.weights_path, info, person, 8.f);
    auto detector = YoloDetector::Create(o);
    EXPECT_EQ(static_cast<int>(detector->class_names().size()), info.num_classes);
    const std::vector<Detection> dets = detector->Detect(image);
    ASSERT_FALSE(dets.empty());
    const cv::Size input = DetectorInputSize(o, image.size());
    const float sx = 640.f / static_cast<float>(input.width);
    const float sy = 480.f / static_cast<float>(input.height);
    int anchor_sized = 0;
    for (const Detection& d : dets) {
      EXPECT_EQ(d.class_id, person);
      EXPECT_TRUE(detector->IsDynamicClass(d.class_id));
      EXPECT_GT(d.score, 0.99f);
      EXPECT_GE(d.box.x, 0.f);
      EXPECT_GE(d.box.y, 0.f);
      EXPECT_LE(d.box.x + d.box.width, 640.f + 1e-3f);
      EXPECT_LE(d.box.y + d.box.height, 480.f + 1e-3f);
      const bool clipped = d.box.x <= 1e-3f || d.box.y <= 1e-3f ||
                           d.box.x + d.box.width >= 640.f - 1e-3f ||
                           d.box.y + d.box.height >= 480.f - 1e-3f;
      bool matches = false;
      for (const cv::Size2f& a : anchors)
        matches |= std::abs(d.box.width - a.width * sx) < 1.f &&
                   std::abs(d.box.height - a.height * sy) < 1.f;
      if (!clipped) {
        EXPECT_TRUE(matches) << d.box.x << " " << d.box.y << " " << d.box.width << "x"
                             << d.box.height;
      }
      anchor_sized += matches ? 1 : 0;
    }
    EXPECT_GE(anchor_sized, 1);
    std::printf("%s with generated weights: %zu person boxes, %d of anchor size\n", name,
                dets.size(), anchor_sized);
  }
}

TEST(YoloDetectorFiles, BadImage) {
  DYGSLAM_REQUIRE_MODELS(models);
  auto detector = YoloDetector::Create(DetectorOptionsForModel("yolo-fastest-1.1", models));
  EXPECT_THROW(detector->Detect(cv::Mat()), InputError);
  EXPECT_THROW(detector->Detect(cv::Mat(10, 10, CV_8UC1)), InputError);
}

}  // namespace
}  // namespace dygslam

namespace dygslam {
namespace {

// The worker gives the same boxes as calling the detector directly, in submission order, and
// hands the detector's errors to the caller through the ticket.
TEST(DetectionWorker, SameBoxesInOrderAndErrorsReachTheCaller) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const DetectorOptions o = DetectorOptionsForModel("yolo-fastest-1.1", models);
  auto direct = YoloDetector::Create(o);
  std::vector<cv::Mat> images;
  for (int entry : {10, 150, 250, 300})
    images.push_back(cv::imread(RgbEntry(dataset, entry), cv::IMREAD_COLOR));
  DetectionWorker worker(YoloDetector::Create(o));
  std::vector<DetectionWorker::Ticket> tickets;
  for (const cv::Mat& im : images) tickets.push_back(worker.Submit(im));
  DetectionWorker::Ticket bad = worker.Submit(cv::Mat());  // empty image: the detector throws
  size_t total = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    const std::vector<Detection> got = tickets[i].result.get();
    const std::vector<Detection> want = direct->Detect(images[i]);
    ASSERT_EQ(got.size(), want.size()) << "image " << i;
    for (size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(got[k].box, want[k].box);
      EXPECT_FLOAT_EQ(got[k].score, want[k].score);
    }
    EXPECT_GT(*tickets[i].detect_ms, 0.0);
    total += got.size();
  }
  EXPECT_GE(total, 2u) << "people frames should give boxes";
  EXPECT_THROW(bad.result.get(), InputError);
}

}  // namespace
}  // namespace dygslam
