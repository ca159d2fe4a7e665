// View-dependent selective refinement of one block's deletion records (issues 15 and 18:
// the per-entry tolerance of a stored level holds a whole 64-cell leaf to the tolerance of its
// nearest column; bench_order --view measured that granularity at 1.5-1.9x the triangles of a
// per-point view-dependent TIN on the bundled fly-over).
//
// The paper records every deletion step's topology change (removed and added triangles and river
// edges). Read as a Multi-Triangulation (De Floriani, Magillo and Puppo, "Efficient
// implementation of multi-triangulations", IEEE Visualization 1998; the same idea as Hoppe's
// view-dependent progressive meshes, SIGGRAPH 1997), step k depends on step j < k when k removes a
// triangle that j created. Any set D of steps closed under that relation gives a conforming
// triangulation of the block: apply D's steps in ascending order; each finds every triangle it
// removes alive (their creators are in D, their destroyer is the step itself) and replaces them by
// triangles with the same outer boundary. The alive triangles are those whose creator is in D (or
// that are at full resolution) and whose destroyer is not. The block's outer border and its
// locked points never change, so a refined block meets its neighbours as its stored levels do.
//
// The error of a step is its OWN realised error, not the running maximum the stored levels keep:
// computed here from the block's own data (the original points are the block's vertices, as
// `unilod check --errors` takes them): vertical, the largest |z - plane| of an original point in
// (or on) one of the created triangles (located exactly on the grid positions); river, the largest
// 3D distance from the original river vertices an added river edge stands for to that edge. A
// triangle alive in a refined mesh was created by a step of D (or is original), so every original
// point's vertical deviation, and every original river vertex's distance to its drawn river edge,
// is bounded by the error of a step in D: refine() takes a step only when its error fits the
// tolerance of the step's own box (lod/cut.h nodeTolerances of a box holding its created
// triangles, the original points under them and the river vertices its edges stand for), or the
// box is off screen. So the P-pixel bound of the cut holds for every original point on screen,
// with per-step instead of per-entry granularity.
//
// A step that moves the block's outline (blocks.h "Domain": an outline vertex deleted, its
// created triangles do not have the outer boundary of those it removes) also has a horizontal
// error: the largest distance from the original points outside the domain there (those the
// removed outline edges stood for, and those it leaves outside) to its new outline edges, part of
// the river part as in the build (both are horizontal displacements, bounded without sin(phi)).
//
// A tree node (issue 18) is refined too, but its original points are its leaves', not its own
// vertices, so its steps take the stored running maximum instead (errorMax / errorRiver after the
// step): a triangle or river edge created by step k is alive in the sequential state after k,
// whose error bounds every original point under it (and every original river point it stands
// for), and those points lie within that error of it, so the step's box is its created
// triangles' grown by the error on every side. A node's step that moves its outline is never
// taken beyond the prefix (where the original points its new outline stands for lie is not
// known without the leaves), nor is any step that depends on it.
//
// Not refined (init() says why; the engine keeps the stored levels for them): blocks without
// grid positions, tree nodes without `max` errors, and records that are not pure replacements.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cut.h"
#include "ulod.h"

namespace unilod::engine {

struct RefinedMesh {
    std::vector<format::Triangle> triangles;  // counter-clockwise, vertex indices of the block
    std::vector<format::Edge> riverEdges;     // a < b
    std::uint32_t stepsDone = 0;
    std::vector<std::uint8_t> done;  // scratch: which steps were taken (index step + 1)
};

class Refinement {
public:
    // From a whole block (Reader::readBlock: validated). False with the reason when the block is
    // not refined (above); the object is then empty.
    bool init(const format::Block& block, std::string& why);

    // The refined mesh for `view`: step k is done when every step it depends on is done and its
    // box is off screen (nodeVisible false) or its errors fit nodeTolerances(view, box) (vertical
    // part against `vertical`, river part against `river`; a block with rivers is `horizontal`,
    // as lod/cut.h LodNode). `out` is overwritten.
    // `prefix`: the steps [0, prefix) are taken without a test: the step of the stored level the
    // cut chose for the block (its error fits the block's tolerance, which bounds every point
    // of the block; a step box's tolerance is not below its block's, so those steps would be
    // taken anyway). The engine passes it; with prefix = steps() the result is the last state.
    void refine(const ViewSpec& view, RefinedMesh& out, std::uint32_t prefix = 0) const;

    // `block` (the one init() read) with the refined mesh appended as one more stored level,
    // for code that reads levels (export, tests): its triangles and river edges after the
    // block's index data, vertexCount every vertex (the alive ones are no prefix), its step a
    // new last entry of errorMax / errorRiver holding the largest own errors of the steps taken
    // (which the appended entries need not be ordered with). Returns the level's index.
    std::size_t appendAsLevel(const RefinedMesh& mesh, format::Block& block) const;

    std::size_t steps() const { return steps_.size(); }
    // Heap bytes held (the engine caps what its resident refinements hold).
    std::size_t memoryBytes() const;
    std::uint32_t fullTriangles() const { return fullTriangles_; }
    // The realised errors of step k (metres): vertical (with the river part: max of both) and
    // river part.
    float stepError(std::size_t k) const { return steps_[k].error; }
    float stepRiverError(std::size_t k) const { return steps_[k].river; }
    // Whether step k moves the outline (an outline vertex deleted).
    bool stepMovesOutline(std::size_t k) const { return steps_[k].movesOutline; }

private:
    struct Step {
        double boxMin[3], boxMax[3];
        float error = 0, river = 0;
        bool movesOutline = false;
        bool blocked = false;  // never taken beyond the prefix (a node's outline move)
        std::uint32_t parentFirst = 0, parentCount = 0;
    };
    std::vector<Step> steps_;
    std::vector<std::uint32_t> parents_;  // step index + 1
    // Every triangle and river edge of the records, in the order they were created, with its
    // destroyer (step index + 1; steps + 1: never destroyed). Those created by step index + 1 = c
    // (0: full resolution) are [created*_[c], created*_[c + 1]).
    std::vector<format::Triangle> triangles_;
    std::vector<std::uint32_t> triangleDestroyer_;
    std::vector<format::Edge> edges_;
    std::vector<std::uint32_t> edgeDestroyer_;
    std::vector<std::uint32_t> createdTriangles_, createdEdges_;
    // Per stored level (ascending steps): the triangles and river edges it draws (table indices).
    std::vector<std::uint32_t> levelSteps_;
    std::vector<std::vector<std::uint32_t>> levelTriangles_, levelEdges_;
    std::uint32_t fullTriangles_ = 0;
    bool horizontal_ = false;
};

}  // namespace unilod::engine
