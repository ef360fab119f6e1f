#include "components/sample_order.h"

#include <gtest/gtest.h>

#include <atomic>
#include <vector>

namespace dygslam {
namespace {

WriterGuid Guid(uint8_t id) {
  WriterGuid g{};
  g[15] = id;
  return g;
}

TEST(SequenceTracker, DropsRepeatsAndCountsJumpsPerWriter) {
  SequenceTracker t;
  EXPECT_TRUE(t.Accept(Guid(1), 40));  // a late joiner starts anywhere: nothing missed
  EXPECT_TRUE(t.Accept(Guid(1), 41));
  EXPECT_TRUE(t.Accept(Guid(2), 1));  // another writer has its own numbers
  EXPECT_FALSE(t.Accept(Guid(1), 41));
  EXPECT_FALSE(t.Accept(Guid(1), 30));  // history delivered again after a re-match
  EXPECT_EQ(t.duplicates(), 2u);
  EXPECT_EQ(t.missed(), 0u);
  EXPECT_TRUE(t.Accept(Guid(1), 45));  // 42, 43, 44 never came
  EXPECT_TRUE(t.Accept(Guid(2), 3));   // 2 never came
  EXPECT_EQ(t.missed(), 4u);
}

TEST(OrderedSender, KeepsOrderAndRetriesWhatTheWriterRefused) {
  std::vector<int> written;
  std::atomic<int> refuse_next{3};
  size_t episodes = 0;
  OrderedSender<int> sender(
      [&](const int& m) {
        if (refuse_next > 0) {
          --refuse_next;
          return false;
        }
        written.push_back(m);
        return true;
      },
      100, std::chrono::milliseconds(1), [&](size_t) { ++episodes; });
  for (int i = 0; i < 10; ++i) sender.Send(i);
  EXPECT_EQ(sender.Finish(std::chrono::seconds(10)), 0u);
  ASSERT_EQ(written.size(), 10u);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(written[i], i);
  EXPECT_EQ(sender.refusals(), 3u);
  EXPECT_EQ(episodes, 1u);  // one warning for three refusals of the same message
}

TEST(OrderedSender, CountsWhatAWriterNeverAcceptedAndBoundsWhatWaits) {
  std::atomic<bool> accept{false};
  OrderedSender<int> sender([&](const int&) { return accept.load(); }, 4,
                            std::chrono::milliseconds(1));
  for (int i = 0; i < 6; ++i) sender.Send(i);  // 4 wait, 2 over the bound
  EXPECT_EQ(sender.Finish(std::chrono::milliseconds(50)), 6u);
  sender.Send(7);  // after Finish: not delivered either
  EXPECT_EQ(sender.Finish(std::chrono::milliseconds(0)), 7u);
}

TEST(OrderedSender, DeliversEverythingOnceTheReaderCatchesUp) {
  std::atomic<bool> accept{false};
  std::atomic<int> written{0};
  OrderedSender<int> sender(
      [&](const int&) {
        if (!accept) return false;
        ++written;
        return true;
      },
      100, std::chrono::milliseconds(1));
  for (int i = 0; i < 20; ++i) sender.Send(i);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(written.load(), 0);
  accept = true;
  EXPECT_EQ(sender.Finish(std::chrono::seconds(10)), 0u);
  EXPECT_EQ(written.load(), 20);
}

}  // namespace
}  // namespace dygslam
