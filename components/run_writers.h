// Which DDS writers belong to this run. On plain DDS (no --security) every local process on the
// domain can join the run's partition (or "*") and publish into it: a forged `Trajectory` would be
// written as trajectory.txt, forged poses and keyframes would enter the outputs and the map. The
// recorder and the mapper therefore accept data samples only from the participant that announced
// itself as the producing component ("slam") on the status topic; samples of any other participant
// are dropped and counted, and the component's summary says how many. Samples that arrive before
// the announcement wait for it (DDS keeps order per writer only). This is a guard against mistakes
// and casual injection, not authentication: a participant that announces "slam" before the real one
// takes its place (the real slam's samples are then the ones dropped and counted). DDS Security
// (--security) is the authentication.
//
//   RunWriters writers;
//   writers.Announce(status.source(), guid);              // every status sample
//   switch (writers.Check("slam", guid)) { ... }           // every data sample
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>

namespace dygslam {

// A DDS writer's GUID: 12-byte participant prefix, 4-byte entity id (SampleInfo's
// publication_handle).
using WriterGuid = std::array<uint8_t, 16>;

class RunWriters {
 public:
  enum class Verdict { kAccept, kReject, kWait };

  // A status sample from `writer` naming `source`: the first participant to announce a source
  // owns it for the rest of the run.
  void Announce(const std::string& source, const WriterGuid& writer) {
    owners_.emplace(source, Prefix(writer));
  }
  bool Known(const std::string& source) const { return owners_.count(source) > 0; }
  // kAccept: written by the participant that announced `source`; kReject: by another one;
  // kWait: nobody has announced `source` yet.
  Verdict Check(const std::string& source, const WriterGuid& writer) const {
    const auto it = owners_.find(source);
    if (it == owners_.end()) return Verdict::kWait;
    return it->second == Prefix(writer) ? Verdict::kAccept : Verdict::kReject;
  }

 private:
  using ParticipantPrefix = std::array<uint8_t, 12>;
  static ParticipantPrefix Prefix(const WriterGuid& writer) {
    ParticipantPrefix p{};
    for (size_t i = 0; i < p.size(); ++i) p[i] = writer[i];
    return p;
  }
  std::map<std::string, ParticipantPrefix> owners_;
};

}  // namespace dygslam
