// OctoMap files (.bt binary, .ot full): atomic writers and a checked reader for any OcTree, the
// formats the builder writes and octovis / octomap_server read.
#pragma once

#include <iosfwd>
#include <memory>
#include <string>

namespace octomap {
class OcTree;
}  // namespace octomap

namespace dygslam {

// The .bt stream of `tree`: the bytes of OcTree::writeBinaryConst (header, then the node data),
// without the progress line ("Writing N nodes to output stream... done.") that the library
// prints to stderr on every binary write, which would interleave with a running mapper's log.
void WriteOctoMapBinaryStream(const octomap::OcTree& tree, std::ostream& out);
void WriteOctoMapBinary(const octomap::OcTree& tree, const std::string& path);
void WriteOctoMapFull(const octomap::OcTree& tree, const std::string& path);
// Reads .bt (binary) or .ot (full); the format is taken from the file header, not the suffix.
// Throws InputError naming the file if it is missing, unreadable or not an OcTree.
std::unique_ptr<octomap::OcTree> ReadOctoMap(const std::string& path);

}  // namespace dygslam
