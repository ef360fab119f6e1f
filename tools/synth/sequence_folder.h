// The folder `dygslam synth` renders a sequence into: what may not be replaced in it, and the
// render itself, staged inside the folder and moved into place only when complete.
#pragma once

#include <string>

#include "tools/synth/synthetic_sequence.h"

namespace dygslam {

// Without --replace: why OUT_DIR may not be written (it holds a dataset's files), "" if it may.
std::string FindDatasetFiles(const std::string& out_dir);

// With --replace: the image folders rgb/, depth/, mask/ are replaced whole, so each must hold
// nothing but images (a user's notes or a nested dataset inside rgb/ are not a sequence's files).
// Why one may not be replaced, "" when all may.
std::string FindUnreplaceableFile(const std::string& out_dir);

// Why OUT_DIR/.synth-partial may not be used as the staging folder (it exists and is not an
// unfinished synth render: no marker), "" when it may.
std::string FindForeignStaging(const std::string& out_dir);

// A synth --replace killed while it moved its render in (OUT_DIR/.synth-previous left): puts one
// whole sequence back, the replaced one, or the new one when all of it was in place. Returns what
// it did ("" when there was nothing to do); throws InputError for a .synth-previous that is not
// synth's.
std::string RecoverInterruptedReplace(const std::string& out_dir);

// Renders into a staging folder inside OUT_DIR (the same file system: the files move in by
// rename) and moves the files into place only when complete: a render stopped midway (Ctrl-C,
// SIGTERM, a full disk) leaves OUT_DIR's sequence as it was and removes its unfinished render
// (StopSignalError, InputError); one killed while moving in is put right by
// RecoverInterruptedReplace. Progress on stderr unless `quiet`; a summary line on stdout.
void RenderIntoPlace(const std::string& out_dir, const SyntheticOptions& options, bool quiet);

}  // namespace dygslam
