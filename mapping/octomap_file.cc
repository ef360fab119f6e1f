// OctoMap files: the .bt (max-likelihood, binary) and .ot (full, with probabilities) formats the
// octomap library reads, written atomically and read back with their shape checked (a truncated
// or crafted file is an error naming the file, never a crash or a partial tree).
#include "mapping/octomap_file.h"

#include <octomap/AbstractOcTree.h>
#include <octomap/OcTree.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/io/file_util.h"

namespace dygslam {

void WriteOctoMapBinaryStream(const octomap::OcTree& tree, std::ostream& out) {
  // The header AbstractOccupancyOcTree::writeBinaryConst writes, then the nodes depth first.
  out << "# Octomap OcTree binary file\n"
      << "# (feel free to add / change comments, but leave the first line as it is!)\n#\n";
  out << "id " << tree.getTreeType() << "\n";
  out << "size " << tree.size() << "\n";
  out << "res " << tree.getResolution() << "\n";
  out << "data\n";
  if (tree.getRoot() != nullptr) tree.writeBinaryNode(out, tree.getRoot());
}

void WriteOctoMapBinary(const octomap::OcTree& tree, const std::string& path) {
  std::ostringstream out(std::ios::binary);
  WriteOctoMapBinaryStream(tree, out);
  if (!out) throw InputError(path, 0, "cannot serialise the OcTree (.bt)");
  WriteFileAtomically(path, out.str());
}

void WriteOctoMapFull(const octomap::OcTree& tree, const std::string& path) {
  std::ostringstream out(std::ios::binary);
  if (!tree.write(out)) throw InputError(path, 0, "cannot serialise the OcTree (.ot)");
  WriteFileAtomically(path, out.str());
}

namespace {

// What an OctoMap file's text header says: the node count ("size N", -1 if none) and where the
// node data starts (after the "data" line; -1 if the header has none within 32 lines).
struct OctoMapHeader {
  std::string id;  // the tree type ("id OcTree")
  long long size = -1;
  std::streamoff data_at = -1;
};

OctoMapHeader ReadOctoMapHeader(std::istream& in) {
  OctoMapHeader header;
  std::string line;
  for (int k = 0; k < 32 && std::getline(in, line); ++k) {
    if (line == "data") {
      header.data_at = in.tellg();
      break;
    }
    if (line.rfind("id ", 0) == 0) header.id = line.substr(3);
    if (line.rfind("size ", 0) == 0) {
      try {
        header.size = std::stoll(line.substr(5));
      } catch (const std::exception&) {
        header.size = -1;
      }
    }
  }
  in.clear();
  in.seekg(0);
  return header;
}

// OctoMap's trees have 16 levels below the root; its readers recurse once per level a file
// declares, without a limit, so a crafted chain of a million nested nodes overflowed the stack.
constexpr int kOctoMapMaxDepth = 16;

// Walks the node data of an OctoMap file without recursion, in the order OctoMap's reader takes
// it, before that reader sees the file: nodes nested deeper than the tree's 16 levels, data that
// ends before the last node, and a node count other than the header's are errors naming the file.
//   .bt (binary): per inner node 2 bytes, 2 bits per child (11: the child has children, its own
//                 record follows depth-first; 01 / 10: an occupied / free leaf; 00: no child).
//   .ot (full):   per node its value (a 4-byte float for an OcTree) and 1 byte of child bits; each
//                 set bit is a child whose record follows depth-first.
void CheckOctoMapShape(const std::string& path, std::istream& in, const OctoMapHeader& header,
                       bool binary, const char* kind) {
  if (header.data_at < 0) {
    throw InputError(path, 0, std::string("malformed ") + kind + ": no 'data' line in the header");
  }
  // Other tree types' nodes hold more than a float (a ColorOcTree's also a colour).
  if (!header.id.empty() && header.id != "OcTree") {
    throw InputError(path, 0,
                     "OctoMap file holds a " + EchoValue(header.id) + ", expected an OcTree");
  }
  // An empty tree ("size 0") has no node data; OctoMap's readers then read none either.
  if (header.size == 0) return;
  in.clear();
  in.seekg(header.data_at);
  std::vector<char> chunk(1 << 16);
  size_t have = 0, at = 0;
  long long records = 0;
  const size_t record_size = binary ? 2 : 5;
  // The next node record's bytes, or nullptr where the data ends.
  auto next_record = [&]() -> const unsigned char* {
    if (have - at < record_size) {
      std::copy(chunk.begin() + static_cast<std::ptrdiff_t>(at),
                chunk.begin() + static_cast<std::ptrdiff_t>(have), chunk.begin());
      have -= at;
      at = 0;
      in.read(chunk.data() + have, static_cast<std::streamsize>(chunk.size() - have));
      have += static_cast<size_t>(in.gcount());
      if (have < record_size) return nullptr;
    }
    const auto* record = reinterpret_cast<const unsigned char*>(chunk.data() + at);
    at += record_size;
    ++records;
    return record;
  };
  auto fail = [&](const std::string& what) {
    throw InputError(path, 0,
                     std::string("truncated or corrupt ") + kind + ": " + what + " (the header " +
                         "declares " + std::to_string(header.size) + " nodes)");
  };
  // Per open node: its depth and how many of its children still have a record to come.
  struct Open {
    int depth;
    int pending;
  };
  std::vector<Open> open;
  long long nodes = 0;
  auto too_deep = [&]() {
    fail("nodes are nested deeper than the tree's " + std::to_string(kOctoMapMaxDepth) +
         " levels (node record " + std::to_string(records) + ")");
  };
  // Reads one node's record at `depth` and opens it; throws where the data ends.
  auto read_node = [&](int depth) {
    const unsigned char* record = next_record();
    if (record == nullptr) fail("the data ends after " + std::to_string(records) + " node records");
    if (depth > kOctoMapMaxDepth) too_deep();
    int pending = 0;
    ++nodes;
    if (binary) {
      for (int b = 0; b < 2; ++b) {
        for (int i = 0; i < 4; ++i) {
          const int code = (record[b] >> (2 * i)) & 3;
          if (code != 0 && depth + 1 > kOctoMapMaxDepth) too_deep();
          if (code == 3)
            ++pending;  // its record follows
          else if (code != 0)
            ++nodes;  // a leaf, no record of its own
        }
      }
    } else {
      const unsigned char bits = record[4];
      for (int i = 0; i < 8; ++i) pending += (bits >> i) & 1;
    }
    open.push_back({depth, pending});
  };
  read_node(0);
  while (!open.empty()) {
    Open& top = open.back();
    if (top.pending == 0) {
      open.pop_back();
      continue;
    }
    --top.pending;
    read_node(top.depth + 1);
  }
  if (header.size >= 0 && nodes != header.size) {
    fail("the data holds " + std::to_string(nodes) + " nodes");
  }
  in.clear();
  in.seekg(0);
}

// OctoMap's readers take what they can: a truncated file gives a smaller tree and no error. The
// stream must have delivered every byte asked for, and the tree must hold the declared nodes.
void CheckOctoMapComplete(const std::string& path, const std::istream& in, long long declared,
                          size_t read, const char* kind) {
  if (in.fail() || (declared >= 0 && static_cast<long long>(read) != declared)) {
    throw InputError(path, 0,
                     std::string("truncated or corrupt ") + kind + ": the header declares " +
                         std::to_string(declared) + " nodes, " + std::to_string(read) +
                         " were read before the data " + (in.fail() ? "ended" : "ran out"));
  }
}

}  // namespace

std::unique_ptr<octomap::OcTree> ReadOctoMap(const std::string& path) {
  // A binary input is read from a regular file only: a FIFO nobody writes into would block the
  // open forever, and the reader seeks back to the start.
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path, 0, "OctoMap file not found");
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path, 0,
                     "OctoMap file is not a regular file (a FIFO, a device or a folder); OctoMaps "
                     "are read from regular files");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open OctoMap file");
  // The first line, at most 64 bytes (a file without a line end is not read whole).
  std::string header;
  for (char c; header.size() < 64 && in.get(c) && c != '\n';) header += c;
  in.clear();
  in.seekg(0);
  if (header.rfind("# Octomap OcTree binary file", 0) == 0) {
    const OctoMapHeader file_header = ReadOctoMapHeader(in);
    const long long declared = file_header.size;
    CheckOctoMapShape(path, in, file_header, /*binary=*/true, "binary OctoMap (.bt)");
    auto tree = std::make_unique<octomap::OcTree>(0.1);
    if (!tree->readBinary(in))
      throw InputError(path, 0,
                       "truncated or corrupt binary OctoMap (.bt): the nodes its header declares "
                       "could not be read");
    CheckOctoMapComplete(path, in, declared, tree->size(), "binary OctoMap (.bt)");
    return tree;
  }
  if (header.rfind("# Octomap OcTree file", 0) == 0) {
    const OctoMapHeader file_header = ReadOctoMapHeader(in);
    const long long declared = file_header.size;
    // OctoMap's .ot reader recurses on each node's child bits; past the end of the stream it read
    // an uninitialised byte as those bits and recursed until the stack overflowed (ASan,
    // reliability/OctoMapFiles.TruncatedOctoMapIsAnError), and a crafted chain of nested nodes
    // did the same (reliability/OctoMapFiles.DeeplyNestedOctoMapIsAnError): the walk checks both.
    CheckOctoMapShape(path, in, file_header, /*binary=*/false, "OctoMap (.ot)");
    std::unique_ptr<octomap::AbstractOcTree> abstract(octomap::AbstractOcTree::read(in));
    if (!abstract) throw InputError(path, 0, "malformed OctoMap (.ot)");
    auto* tree = dynamic_cast<octomap::OcTree*>(abstract.get());
    if (tree == nullptr) {
      throw InputError(
          path, 0,
          "OctoMap file holds a " + EchoValue(abstract->getTreeType()) + ", expected an OcTree");
    }
    CheckOctoMapComplete(path, in, declared, tree->size(), "OctoMap (.ot)");
    abstract.release();
    return std::unique_ptr<octomap::OcTree>(tree);
  }
  throw InputError(path, 1, "not an OctoMap file (header '" + EchoValue(header, 40) + "')");
}

}  // namespace dygslam
