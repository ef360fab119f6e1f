#include "bridge/ros2_graph.h"

#include <gtest/gtest.h>

#include <cstring>

#include "core/base/error.h"

namespace dygslam::ros2 {
namespace {

uint32_t U32At(const std::vector<uint8_t>& b, size_t offset) {
  uint32_t v = 0;
  std::memcpy(&v, b.data() + offset, 4);  // little endian host (x86-64 / arm64)
  return v;
}

// The CDR layout of ParticipantEntitiesInfo written out by hand for one node with one reader and
// one writer: offsets count from the start of the sample (4-byte encapsulation header first;
// alignment is relative to the body, i.e. offset - 4).
TEST(RosGraph, ParticipantEntitiesInfoLayoutPerDistribution) {
  RosParticipantEntities info;
  for (int i = 0; i < 16; ++i) info.participant[i] = static_cast<uint8_t>(i + 1);
  RosNodeEntities node;
  node.node_namespace = "/";
  node.node_name = "dygslam";
  Guid reader{}, writer{};
  reader.fill(0xaa);
  writer.fill(0xbb);
  node.readers = {reader};
  node.writers = {writer};
  info.nodes = {node};

  struct Layout {
    RosDistro distro;
    size_t gid, node_count, ns, name, readers, writers, total;
  };
  // Jazzy: gid 16 -> count at 4+16; ns "/" (4 + 2) ends at 30, name length aligned to 32.
  // Humble: gid 24 -> count at 4+24; ns ends at 38, name length aligned to 40.
  for (const Layout& l : {Layout{RosDistro::kJazzy, 16, 20, 24, 32, 44, 64, 84},
                          Layout{RosDistro::kHumble, 24, 28, 32, 40, 52, 80, 108}}) {
    const std::vector<uint8_t> b = EncodeParticipantEntitiesInfo(info, l.distro);
    SCOPED_TRACE(RosDistroName(l.distro));
    ASSERT_EQ(b.size(), l.total);
    EXPECT_EQ(b[0], 0x00);  // CDR_LE
    EXPECT_EQ(b[1], 0x01);
    for (size_t i = 0; i < l.gid; ++i) EXPECT_EQ(b[4 + i], i < 16 ? i + 1 : 0) << i;
    EXPECT_EQ(U32At(b, l.node_count), 1u);
    EXPECT_EQ(U32At(b, l.ns), 2u);
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(&b[l.ns + 4])), "/");
    EXPECT_EQ(U32At(b, l.name), 8u);
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(&b[l.name + 4])), "dygslam");
    EXPECT_EQ(U32At(b, l.readers), 1u);
    for (size_t i = 0; i < l.gid; ++i) EXPECT_EQ(b[l.readers + 4 + i], i < 16 ? 0xaa : 0) << i;
    EXPECT_EQ(U32At(b, l.writers), 1u);
    for (size_t i = 0; i < l.gid; ++i) EXPECT_EQ(b[l.writers + 4 + i], i < 16 ? 0xbb : 0) << i;
  }
}

TEST(RosGraph, DistroNodeNameAndNamespaceChecks) {
  EXPECT_EQ(ParseRosDistro("humble", "d"), RosDistro::kHumble);
  EXPECT_EQ(ParseRosDistro("jazzy", "d"), RosDistro::kJazzy);
  EXPECT_EQ(GidSize(ParseRosDistro("iron", "d")), 16u);
  EXPECT_EQ(GidSize(RosDistro::kHumble), 24u);
  try {
    ParseRosDistro("foxy", "--ros-distro");
    FAIL();
  } catch (const InvalidOptions& e) {
    EXPECT_NE(std::string(e.what()).find("--ros-distro"), std::string::npos);
  }
  EXPECT_NO_THROW(CheckNodeName("dygslam", "n"));
  EXPECT_NO_THROW(CheckNodeName("_slam2", "n"));
  for (const std::string& bad :
       std::vector<std::string>{"", "2slam", "my-node", "a/b", std::string(256, 'a')}) {
    EXPECT_THROW(CheckNodeName(bad, "--node-name"), InvalidOptions) << bad;
  }
  EXPECT_NO_THROW(CheckNodeNamespace("/", "ns"));
  EXPECT_NO_THROW(CheckNodeNamespace("/robot1/perception", "ns"));
  for (const std::string& bad :
       std::vector<std::string>{"", "robot", "/robot/", "//a", "/1robot", "/a b"}) {
    EXPECT_THROW(CheckNodeNamespace(bad, "--node-namespace"), InvalidOptions) << bad;
  }
}

}  // namespace
}  // namespace dygslam::ros2
