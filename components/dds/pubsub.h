// Typed DataWriter / DataReader wrappers (RAII) over a shared Participant.
//   auto w = Writer<msg::RgbdFramePubSubType>(participant, topics::kRgbdFrame,
//   TopicKind::kRgbdFrame); w.Write(frame); Reader<msg::CameraPosePubSubType> r(participant,
//   topics::kCameraPose, TopicKind::kCameraPose,
//       [](msg::CameraPose&& pose) { ... });   // called on the DDS listener thread
// Callbacks must be short (enqueue + notify); the components do their work on their own threads.
#pragma once

#include <memory>
#include <string>

#include "components/dds/endpoint.h"
#include "components/dds/participant.h"
#include "components/dds/qos.h"

namespace dygslam::dds {

template <class PubSubType>
class Writer : public TypedWriter<PubSubType> {
 public:
  Writer(std::shared_ptr<Participant> participant, const std::string& topic, TopicKind kind)
      : TypedWriter<PubSubType>(participant, *participant, participant->publisher(), topic,
                                WriterQos(kind)) {}
};

template <class PubSubType>
class Reader : public TypedReader<PubSubType> {
 public:
  using Callback = typename TypedReader<PubSubType>::Callback;
  using CallbackWithWriter = typename TypedReader<PubSubType>::CallbackWithWriter;
  Reader(std::shared_ptr<Participant> participant, const std::string& topic, TopicKind kind,
         Callback callback)
      : TypedReader<PubSubType>(participant, *participant, participant->subscriber(), topic,
                                ReaderQos(kind), std::move(callback)) {}
  Reader(std::shared_ptr<Participant> participant, const std::string& topic, TopicKind kind,
         CallbackWithWriter callback)
      : TypedReader<PubSubType>(participant, *participant, participant->subscriber(), topic,
                                ReaderQos(kind), std::move(callback)) {}
};

}  // namespace dygslam::dds
