#include "run/realtime_report.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

std::vector<ResultLatency> Latencies(const std::vector<double>& ms) {
  std::vector<ResultLatency> out;
  for (size_t i = 0; i < ms.size(); ++i)
    out.push_back({Timestamp::FromNanoseconds(1548339823897980000LL + 33333333LL * i), ms[i]});
  return out;
}

// The per-result rows survive the file: where a paced run's latency built up can be read back
// beside frames.csv (the quantiles alone hide it).
TEST(RealtimeReport, KeepsEachResultsStampAndLatencyThroughTheFile) {
  const RealtimeReport made =
      MakeRealtimeReport(1.0, 6, Latencies({31.25, 18.5, 240.125, 95.0, 20.0}), 100.0);
  EXPECT_EQ(made.results, 5u);
  EXPECT_EQ(made.dropped(), 1u);
  EXPECT_EQ(made.late, 1u);  // 240 ms > 100 ms
  EXPECT_DOUBLE_EQ(made.latency_median_ms, 31.25);
  EXPECT_DOUBLE_EQ(made.latency_p99_ms, 240.125);
  const std::string path = testing::MakeTempDir("realtime_report") + "/realtime.txt";
  WriteRealtimeReport(path, made);
  const std::string text = testing::ReadAll(path);
  EXPECT_NE(text.find("\nlatency 1548339823.897980 31.250\n"), std::string::npos) << text;
  const RealtimeReport read = ReadRealtimeReport(path);
  EXPECT_EQ(read.frames, 6u);
  EXPECT_EQ(read.results, 5u);
  EXPECT_EQ(read.late, 1u);
  ASSERT_EQ(read.latencies.size(), 5u);
  for (size_t i = 0; i < read.latencies.size(); ++i) {
    EXPECT_EQ(read.latencies[i].stamp, made.latencies[i].stamp) << i;
    EXPECT_DOUBLE_EQ(read.latencies[i].ms, made.latencies[i].ms) << i;
  }
}

TEST(RealtimeReport, AMalformedLatencyRowNamesTheFileAndLine) {
  const std::string dir = testing::MakeTempDir("realtime_report_bad");
  const std::vector<std::string> bad = {
      "latency 1548339823.897980", "latency 15483x9823.897980 31.2", "latency 1548339823.897980 -4",
      "latency 1548339823.897980 nan", "latency 1548339823.897980 31.2 7"};
  for (const std::string& row : bad) {
    const std::string path = dir + "/realtime.txt";
    std::ofstream(path) << "rate 1\nframes 2\nresults 2\nlatency 1548339823.864646 30.0\n"
                        << row << "\n";
    try {
      ReadRealtimeReport(path);
      ADD_FAILURE() << "read: " << row;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path + ":5: expected 'latency <stamp> <milliseconds>'"),
                std::string::npos)
          << e.what();
    }
  }
}

// A very long paced run keeps the first kMaxLatencyRows rows; its counts and quantiles still
// cover every result.
TEST(RealtimeReport, KeepsABoundedNumberOfRowsAndCountsEveryResult) {
  std::vector<double> ms(kMaxLatencyRows + 10, 10.0);
  ms.back() = 500.0;
  const RealtimeReport r = MakeRealtimeReport(1.0, ms.size(), Latencies(ms), 100.0);
  EXPECT_EQ(r.results, kMaxLatencyRows + 10);
  EXPECT_EQ(r.latencies.size(), kMaxLatencyRows);
  EXPECT_EQ(r.late, 1u);
}

}  // namespace
}  // namespace dygslam
