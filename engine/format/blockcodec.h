// The compact block encoding of .ulod (since version 3, issue 19; version 4 adds the errorRiver
// array to the errors stream). A built block is stored as integers and records without
// redundancy, each stream compressed with zstd; the decoder rebuilds exactly the in-memory Block
// the builder made (ulod.h), so every reader path (validateBlock, `check`, the engine) is
// unchanged. README.md beside this file gives the byte layout.
//
// What is stored and what is derived:
// - vertices: exact grid integers (x, y) and z as an integer multiple of the file's z quantum, in
//   spatial order (row by row), plus the permutation to the retention order; float x, y are the
//   grid position times kGridUnit, float z the integer times the quantum;
// - the full-resolution mesh (triangles and river edges) in spatial vertex numbering;
// - per deletion step, only what the mesh does not imply: the triangles and river edges alive at
//   the step's vertex are removed (its star); the step stores the removals beyond the star (an A-C
//   constraint insertion), then the added triangles and edges as small indices into the step's
//   hole vertices (an escape value names any other vertex);
// - errors of both metrics as multiples of the z quantum (rounded up: quantizeError), delta coded
//   (mostly 0 or 1 per step);
// - the level steps; every level's index data and counts are derived again (lodlayout.h), as are
//   the steps' vertex and alive counts and the record offsets.
// A block that is not in this canonical form (hand-made, foreign), or a tiny one whose streams
// would cost more than its arrays, is stored raw instead (BlockEncoding::kRaw). The encoder proves
// the form as it goes: it replays the records on the decoder's structure, checks that every
// removal set, triangulation, count, vertex position and error is what the decoder will derive,
// and lays the levels out from its replay and compares them with the stored ones.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ulod.h"

namespace unilod::format {

enum class BlockEncoding : std::uint32_t { kRaw = 0, kCompact = 1 };
// A stored block is its header (kBlockHeaderBytes), then a compact block's payload of the size
// in the header's word at kBlockPayloadSizeOffset (ulod.cpp BlockHeader; tools read payloads).
inline constexpr std::size_t kBlockHeaderBytes = 152, kBlockPayloadSizeOffset = 144;

// z rounded to the nearest multiple of q (q > 0).
double quantizeZ(double z, double q);

// An error as stored: the smallest multiple of q >= e (exact as a float below 2^24 q; above, the
// float e rounds up to, which the compact encoding does not take). Monotone in e.
float quantizeError(double e, double q);

// The counts a decoder is given (the block header's, bounded by the reader before decoding):
// the decoded block must have exactly these sizes.
struct BlockCounts {
    std::uint32_t vertices = 0, steps = 0, levels = 0;
    std::uint32_t removedTriangles = 0, addedTriangles = 0, removedEdges = 0, addedEdges = 0;
    std::uint32_t terrainTriangles = 0, riverEdges = 0;
    bool errorMax = false, errorPaper = false, errorRiver = false;
};
BlockCounts countsOf(const Block& block);

// Compact encoding of a validated block's arrays (not its position, box or tree links, which the
// block header holds). Returns false with `why` when the block is not in canonical form;
// otherwise decodeCompact returns exactly these arrays (the round-trip tests check it on built
// models).
bool encodeCompact(const Block& block, double zQuantum, std::vector<unsigned char>& out,
                   std::string& why);

// Decodes `size` bytes into the arrays of `block`. Never reads outside the bytes and never
// allocates beyond what `counts` allows; returns false with `error` on any inconsistency. The
// result still needs validateBlock.
bool decodeCompact(const unsigned char* data, std::size_t size, const BlockCounts& counts,
                   double zQuantum, Block& block, std::string& error);

// The streams of a compact payload with their decoded and stored sizes (benchmarks: where the
// bytes go). Returns false on a damaged payload.
struct StreamSize {
    const char* name;
    std::uint64_t decoded = 0, stored = 0;
};
bool compactStreamSizes(const unsigned char* data, std::size_t size, std::vector<StreamSize>& out);

// True when the arrays of two blocks are equal bit for bit.
bool sameArrays(const Block& a, const Block& b);

}  // namespace unilod::format
