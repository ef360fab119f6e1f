// dygslam synth OUT_DIR: a synthetic dynamic RGB-D sequence in TUM layout (tools/synth).
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

// The options of `dygslam synth`; those bound to a field of `o` are read by ReadBound().
void DefineSynthOptions(ArgParser* parser, SyntheticOptions* o) {
  ArgParser& p = *parser;
  p.AddPositional(
      "OUT_DIR",
      "output folder (created if needed); a folder that holds any of the files the\n"
      "sequence is made of (rgb.txt, rgb/, camera.yaml, ...) is refused unless --replace");
  p.AddFlag("replace", "replace the dataset files an earlier synth (or anyone) left in OUT_DIR");
  p.Bind("frames", "N", "number of frames", &o->num_frames, 1, 1000000);
  p.Bind("objects", "K", "moving objects (people), 0..4", &o->num_moving_objects, 0, 4);
  p.AddOption("seed", "S", "random seed (textures, object lanes/speeds/phases, noise)", "1");
  p.AddFlag("noise", "Kinect-like depth noise (std 0.0015 z^2) and colour noise (std 2)");
  p.Bind("fps", "F", "frame rate", &o->sensor.fps, 0, 1000);
  p.Bind("objects-from", "FRAME", "objects appear at this frame (before: static scene only)",
         &o->objects_start_frame, 0, 1000000);
  p.Bind("max-depth", "M", "depth beyond M metres reads 0 (invalid); 0 = no limit", &o->max_depth,
         0, 1000);
  p.Bind("supersampling", "N", "N x N colour samples per pixel (1..4)", &o->supersampling, 1, 4);
  p.AddOption("room", "X,Y,Z", "room size in metres (at least 5,4,2.5)", "6,5,3");
  p.AddOption(
      "loop-path", "A,B",
      "camera goes round a rounded rectangle with these half sizes (m), looking out at the walls\n"
      "                (e.g. --room 29,17,3 --loop-path 12.5,6.5: a 61 m closed path); 0,0 = "
      "the default handheld sway",
      "0,0");
  p.Bind("loop-corner", "R",
         "corner radius of the loop path (m; = the smaller half size: a stadium)",
         &o->loop_corner_radius, 0, 50);
  p.Bind("speed", "V", "camera speed on the loop path (m/s)", &o->loop_speed, 0, 5);
  p.AddFlag(
      "loop-inward",
      "look inwards at a pillar in the middle of the loop (its corners are the centres of\n"
      "                the corner arcs: the surface in view is always the corner radius away)");
  p.Bind("texels", "T", "texture resolution (texels per metre, 50..1000; lower for big rooms)",
         &o->texels_per_metre, 50, 1000);
  p.Bind("occluder", "C",
         "a person walking with the camera close in front of it covers this share of the\n"
         "                image (0.1..0.98; 0 = none) for --occluder-frames frames",
         &o->occluder_coverage, 0, 0.98);
  p.Bind("occluder-from", "FRAME", "the occluder starts sliding into view at this frame",
         &o->occluder_start_frame, 0, 1000000);
  p.Bind("occluder-frames", "N", "frames the occluder covers its full share (after sliding in)",
         &o->occluder_frames, 1, 1000000);
  p.AddFlag("occluder-undetected", "the occluder is never in detections.txt (a missed person)");
  p.AddFlag("quiet", "no progress line");
}

// The options' Check(), a value out of range a usage error naming the option as typed: 0 or 2.
int CheckSynthOptions(ArgParser& p, const SyntheticOptions& options) {
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
        {"occluder_coverage", "occluder", "0, or a share of the image in 0.1..0.98"},
    };
    for (const Field& f : kFields) {
      if (message.rfind(std::string("invalid option ") + f.field, 0) == 0) {
        return p.UsageError(std::string("--") + f.option + ": out of range, got '" +
                            EchoValue(p.Get(f.option)) + "' (expected " + f.expected + ")");
      }
    }
    throw;
  }

  return 0;
}

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
  SyntheticOptions options;
  DefineSynthOptions(&p, &options);
  if (!p.Parse(args)) return p.exit_code();

  int64_t seed = 0;
  if (!p.ReadBound() || !p.GetInt("seed", 0, std::numeric_limits<int64_t>::max(), &seed))
    return p.exit_code();
  options.seed = static_cast<uint64_t>(seed);
  std::vector<double> room, loop;
  if (!p.GetNumberList("room", 3, "X,Y,Z in metres", &room) ||
      !p.GetNumberList("loop-path", 2, "A,B in metres", &loop))
    return p.exit_code();
  options.room_size = Eigen::Vector3d(room[0], room[1], room[2]);
  options.loop_semi_axes = Eigen::Vector2d(loop[0], loop[1]);
  options.loop_inward = p.Flag("loop-inward");
  options.occluder_undetected = p.Flag("occluder-undetected");
  if (p.Flag("noise")) {
    options.depth_noise = true;
    options.rgb_noise_sigma = 2.0;
  }
  if (const int code = CheckSynthOptions(p, options); code != 0) return code;
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
