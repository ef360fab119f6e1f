// The component shells' reader of the StreamStatus topic: each sample parsed into a
// ComponentStatus (components/protocol.h) and handed over with the raw message (for the fields a
// status kind adds, e.g. END_OF_STREAM's frame count); a malformed one is logged as
// "<component>: ignored status: <why>" and dropped. Called on the DDS listener thread.
#pragma once

#include <functional>
#include <memory>
#include <utility>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/protocol.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"

namespace dygslam {

class StatusReader {
 public:
  static constexpr size_t kMalformedSaid = 3;  // malformed samples warned one by one, then totalled
  using Callback = std::function<void(const ComponentStatus& status, const msg::StreamStatus& m)>;
  // With the GUID of the status sample's writer (RunWriters::Announce tells a rival frame
  // source's statuses from the run's by it).
  using CallbackWithWriter = std::function<void(const ComponentStatus& status,
                                                const msg::StreamStatus& m, const WriterGuid& w)>;

  // `self`: the component that reads (names it in the log).
  StatusReader(std::shared_ptr<dds::Participant> participant, ComponentKind self, Callback callback)
      : StatusReader(
            std::move(participant), self,
            CallbackWithWriter([cb = std::move(callback)](const ComponentStatus& status,
                                                          const msg::StreamStatus& m,
                                                          const WriterGuid&) { cb(status, m); })) {}
  StatusReader(std::shared_ptr<dds::Participant> participant, ComponentKind self,
               CallbackWithWriter callback)
      : self_(self),
        malformed_(std::make_unique<RepeatedWarning>(kMalformedSaid)),
        reader_(std::move(participant), dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus,
                [self, malformed = malformed_.get(), callback = std::move(callback)](
                    msg::StreamStatus&& m, const WriterGuid& writer) {
                  ComponentStatus status;
                  try {
                    status = StatusFromMsg(m);
                  } catch (const InputError& e) {
                    // A peer may send any number of these: the first few are said, the total
                    // at the end.
                    if (malformed->Say()) {
                      LOG_WARNING << ToString(self) << ": ignored status: " << e.what();
                    }
                    return;
                  }
                  callback(status, m, writer);
                }) {}
  ~StatusReader() {
    if (malformed_->suppressed() > 0) {
      LOG_WARNING << ToString(self_) << ": ignored " << malformed_->count()
                  << " malformed status samples in all (the first " << kMalformedSaid
                  << " said above)";
    }
  }
  StatusReader(const StatusReader&) = delete;
  StatusReader& operator=(const StatusReader&) = delete;

  int matched() const { return reader_.matched(); }
  // Whether the status writer `writer` (a component's, from its statuses) is still matched.
  bool IsMatched(const WriterGuid& writer) const { return reader_.IsMatched(writer); }
  // Status samples that were not understood (malformed), so far.
  size_t malformed() const { return malformed_->count(); }

 private:
  ComponentKind self_;
  std::unique_ptr<RepeatedWarning> malformed_;  // outlives reader_'s callbacks (declared first)
  dds::Reader<msg::StreamStatusPubSubType> reader_;
};

}  // namespace dygslam
