// dygslam synth OUT_DIR [--frames N] [--objects K] [--seed S] [--noise] [--fps F] ...
// Writes a synthetic dynamic RGB-D sequence in TUM layout (tools/synth/synthetic_sequence.h).
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "tools/synth/sequence_folder.h"
#include "tools/synth/synthetic_sequence.h"

namespace dygslam::cli {
namespace {

int RunSynth(const std::vector<std::string>& args) {
  ArgParser p(
      "synth",
      "OUT_DIR [--frames N] [--objects K] [--seed S] [--noise] [--fps F] [--objects-from FRAME]\n"
      "              [--max-depth M] [--supersampling N] [--quiet]",
      R"(Renders a synthetic dynamic RGB-D sequence with exact ground truth: a textured 6 x 5 x 3 m
room with furniture, a camera moving like a handheld one (~0.3 m/s, ~25 deg/s), and K
person-sized textured boxes walking back and forth in front of it (~1 m/s). Writes TUM layout:
rgb/, depth/ (16-bit, /5000 = m), rgb.txt, depth.txt (stamps offset ~4 ms), groundtruth.txt,
mask/ + mask.txt (255 = moving object), detections.txt (ground-truth person boxes
't x y w h class score'), objects.txt (object poses per frame) and camera.yaml (ORB-SLAM2
keys). The same seed gives byte-identical files.)");
  p.AddPositional(
      "OUT_DIR",
      "output folder (created if needed); a folder that holds any of the files the\n"
      "sequence is made of (rgb.txt, rgb/, camera.yaml, ...) is refused unless --replace");
  p.AddFlag("replace", "replace the dataset files an earlier synth (or anyone) left in OUT_DIR");
  p.AddOption("frames", "N", "number of frames", "100");
  p.AddOption("objects", "K", "moving objects (people), 0..4", "2");
  p.AddOption("seed", "S", "random seed (textures, object lanes/speeds/phases, noise)", "1");
  p.AddFlag("noise", "Kinect-like depth noise (std 0.0015 z^2) and colour noise (std 2)");
  p.AddOption("fps", "F", "frame rate", "30");
  p.AddOption("objects-from", "FRAME", "objects appear at this frame (before: static scene only)",
              "0");
  p.AddOption("max-depth", "M", "depth beyond M metres reads 0 (invalid); 0 = no limit", "0");
  p.AddOption("supersampling", "N", "N x N colour samples per pixel (1..4)", "2");
  p.AddOption("room", "X,Y,Z", "room size in metres (at least 5,4,2.5)", "6,5,3");
  p.AddOption(
      "loop-path", "A,B",
      "camera goes round a rounded rectangle with these half sizes (m), looking out at the walls\n"
      "                (e.g. --room 29,17,3 --loop-path 12.5,6.5: a 61 m closed path); 0,0 = "
      "the default handheld sway",
      "0,0");
  p.AddOption("loop-corner", "R",
              "corner radius of the loop path (m; = the smaller half size: a stadium)", "1.5");
  p.AddOption("speed", "V", "camera speed on the loop path (m/s)", "1");
  p.AddFlag(
      "loop-inward",
      "look inwards at a pillar in the middle of the loop (its corners are the centres of\n"
      "                the corner arcs: the surface in view is always the corner radius away)");
  p.AddOption("texels", "T", "texture resolution (texels per metre, 50..1000; lower for big rooms)",
              "250");
  p.AddFlag("quiet", "no progress line");
  if (!p.Parse(args)) return p.exit_code();

  SyntheticOptions options;
  int64_t seed = 0;
  if (!p.GetInt("frames", 1, 1000000, &options.num_frames) ||
      !p.GetInt("objects", 0, 4, &options.num_moving_objects) ||
      !p.GetInt("seed", 0, std::numeric_limits<int64_t>::max(), &seed) ||
      !p.GetInt("objects-from", 0, 1000000, &options.objects_start_frame) ||
      !p.GetInt("supersampling", 1, 4, &options.supersampling) ||
      !p.GetNumber("fps", 0, 1000, &options.sensor.fps) ||
      !p.GetNumber("max-depth", 0, 1000, &options.max_depth) ||
      !p.GetNumber("loop-corner", 0, 50, &options.loop_corner_radius) ||
      !p.GetNumber("speed", 0, 5, &options.loop_speed) ||
      !p.GetNumber("texels", 50, 1000, &options.texels_per_metre))
    return p.exit_code();
  options.seed = static_cast<uint64_t>(seed);
  std::vector<double> room, loop;
  if (!p.GetNumberList("room", 3, "X,Y,Z in metres", &room) ||
      !p.GetNumberList("loop-path", 2, "A,B in metres", &loop))
    return p.exit_code();
  options.room_size = Eigen::Vector3d(room[0], room[1], room[2]);
  options.loop_semi_axes = Eigen::Vector2d(loop[0], loop[1]);
  options.loop_inward = p.Flag("loop-inward");
  if (p.Flag("noise")) {
    options.depth_noise = true;
    options.rgb_noise_sigma = 2.0;
  }
  // A value out of range is a usage error naming the option as typed (not the options struct's
  // field and its C++ check).
  try {
    options.Check();
  } catch (const InvalidOptions& e) {
    const std::string message = e.what();
    struct Field {
      const char* field;   // as SyntheticOptions::Check names it
      const char* option;  // the command line's
      const char* expected;
    };
    static const Field kFields[] = {
        {"num_moving_objects", "objects", "0..4 moving objects"},
        {"Camera.fps", "fps", "a frame rate > 0 (frames per second)"},
        {"depth_stamp_offset", "fps", "a frame rate of at most ~100 frames per second"},
        {"room_size", "room", "X,Y,Z of at least 5,4,2.5 and at most 50 m each"},
        {"camera_height", "room", "a room at least 2.5 m high"},
        {"supersampling", "supersampling", "1..4"},
        {"texels_per_metre", "texels", "50..1000 texels per metre"},
        {"loop_semi_axes", "loop-path",
         "A,B both 0, or both > 0 with the path at least 1 m inside the walls of --room"},
        {"loop_corner_radius", "loop-corner", "a radius > 0 (m)"},
        {"loop_speed", "speed", "0 < V <= 5 m/s"},
        {"loop_inward", "loop-corner",
         "with --loop-inward, a radius at least 0.25 m below both halves of --loop-path"},
        {"min_depth/max_depth", "max-depth", "0 (no limit) or a depth > 0 (m)"},
        {"objects_start_frame", "objects-from", "a frame number >= 0"},
    };
    for (const Field& f : kFields) {
      if (message.rfind(std::string("invalid option ") + f.field, 0) == 0) {
        return p.UsageError(std::string("--") + f.option + ": out of range, got '" +
                            EchoValue(p.Get(f.option)) + "' (expected " + f.expected + ")");
      }
    }
    throw;
  }

  const std::string out_dir = p.Positional("OUT_DIR");
  if (const std::string images = DatasetImageFolderOf(out_dir); !images.empty())
    return p.UsageError("OUT_DIR '" + EchoValue(out_dir) + "' lies in the image folder '" +
                        EchoValue(images) +
                        "' of a dataset: the sequence would be mixed with its images; choose "
                        "another folder");
  if (const std::string recovered = RecoverInterruptedReplace(out_dir); !recovered.empty())
    std::fprintf(stderr, "synth: %s\n", recovered.c_str());
  // A dataset in OUT_DIR (a recorded sequence, the user's ground truth) is never overwritten
  // without being asked to; with --replace, only its files are.
  if (const std::string why =
          p.Flag("replace") ? FindUnreplaceableFile(out_dir) : FindDatasetFiles(out_dir);
      !why.empty())
    return p.UsageError(why);
  if (const std::string why = FindForeignStaging(out_dir); !why.empty()) return p.UsageError(why);
  RenderIntoPlace(out_dir, options, p.Flag("quiet"));
  return 0;
}

const CommandRegistrar kRegistrar({"synth", "generate a synthetic dynamic RGB-D sequence",
                                   RunSynth});

}  // namespace
}  // namespace dygslam::cli
