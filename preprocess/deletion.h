// The deletion sequence over the river-constrained Delaunay triangulation (paper §3.3), with
// topology-change records and the model error of every step (paper §3.2; DESIGN.md
// "Topology-change records").
//
// Points are deleted in the given order (the importance order, ascending). Deleting vertex X
// removes its star and re-triangulates the hole so that the mesh is again constrained Delaunay
// (cdt.h). A river vertex X between A and C is deleted only when the new river edge A-C keeps
// the network's topology, decided exactly before anything changes: A-C must not cross or touch a
// river edge, must not pass through any vertex but X, and must not already be a river edge.
// Then X is removed (its star re-triangulated by ear clipping + Lawson flips) and A-C inserted as
// a constraint: when A-C leaves X's old star, the edges it crosses are flipped away (the cavity
// grows by the triangles A-C crosses) and the Delaunay property is restored around it (cdt.h).
//
// Refusals (the vertex stays for good, listed in `kept`):
//   Locked   - a locked point (block border, river end or junction; the caller locks them);
//   Hull     - a vertex on the convex hull (deleting it would change the domain);
//   RiverEnd - a vertex with 1 or >= 3 river edges that is not locked (its deletion would
//              change the junction structure).
// Deferral rule: a river vertex whose A-C fails the test is deferred and retried right after
// the deletion of any vertex of its blocker set: A, C and the endpoints of the first river edge
// A-C hits (or the vertex A-C passes through). Nothing else can unblock it (the blocking edge or
// vertex stays as long as its endpoints do), so the rule is exact and costs nothing while
// blocked. Retries run in order position, before the next vertex of the order; a retried vertex
// that fails again is deferred again with its new blockers. Vertices still deferred when the
// order is exhausted are kept (reason Deferred). Order entries that are merged duplicates
// (Cdt::representative[id] != id) are skipped: their vertex is the representative.
//
// Greedy order (runGreedyDeletion, issue 15; the default of `unilod build`): instead of a given
// order, every step deletes the candidate whose deletion causes the smallest model error. The key
// of a vertex X is evaluated by deleting X for real on a trial (cdt.h beginTrial) and rolling
// back: the largest vertical distance between the original points under the changed triangles
// and the re-triangulated surface (the `max` metric's own quantity), and for a river vertex
// between A and C the larger of that and the river deviation of A-C (below), multiplied by the
// BAI factor (C * BAI + 1, paper Eq. 2) so that bends go later. Ties: lower tieRank(id) first,
// a scattered order: ids follow the raster, and a flat area (a lake, the sea at 0 m, where every
// key is 0) deleted row by row grew triangles spanning the rows already deleted, whose original
// points every later step re-located: quadratic (a flat 300 x 300 DEM as one block 120 s, 600 x
// 600 with 256-cell blocks 139 s; MEASURED.md, thirty-fifth session). In a scattered order the
// triangles grow evenly, as in a random deletion order.
// After a step the keys of every vertex of a created triangle are evaluated again (their stars
// changed); a vertex at the top of the queue is deleted only when its deletion, done for real,
// causes exactly its key (otherwise it goes back with the new key: the key of a river vertex
// whose A-C leaves its star also depends on triangles outside the star). A vertex on the convex
// hull between two hull neighbours on one straight line (a straight raster edge) is a candidate
// too: deleting it leaves the domain as it is (cdt.h removeHullVertex); other hull vertices,
// locked and river-end vertices are refused as above; a river vertex whose A-C is blocked waits, as
// above, for the deletion of one of its blockers and is then evaluated again.
//
// River deviation: the largest 3D distance from the original river vertices between A and C
// (along the river as built, X included) to the segment A-C. A 3D distance bounds the
// horizontal one and makes the on-screen bound of the drawn river provable (engine/lod/lod.h).
//
// `max` error of a step (both orders): max(vertical error of the re-evaluated points, the river
// deviation of the new edge A-C), stored as a running maximum over the steps, so one h_lim bounds
// the terrain and the rivers.
//
// Records: one DeletionStep per successful deletion; the triangles (canonical vertex triples)
// and river edges removed and added by step s are the ranges [offset[s], offset[s+1]) of the
// flat arrays, so a file writer can store every array as it is. A triangle that is destroyed and
// re-created identically within a step appears in neither list.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include "bai.h"
#include "cdt.h"
#include "modelerror.h"

namespace unilod {

struct DeletionStep {
    PointId vertex = 0;                // the vertex removed by this step
    std::uint32_t trianglesAlive = 0;  // real triangles after the step
    std::uint32_t riverEdgesAlive = 0;
};
static_assert(sizeof(DeletionStep) == 12);

enum class KeptReason : std::uint8_t { Locked = 0, Hull = 1, RiverEnd = 2, Deferred = 3 };
struct KeptVertex {
    PointId id = 0;
    KeptReason reason = KeptReason::Locked;
};

// The original river points a built river edge stands for (issue 18's tree nodes start from
// their children's coarsest rivers): those deleted between its ends, in order, with absolute
// x, y, z, and a slack bounding the distance of any not listed (0 when all are).
struct RiverCover {
    double slack = 0;
    std::vector<std::array<double, 3>> points;
};

struct DeletionRecords {
    std::vector<DeletionStep> steps;
    // Size steps.size() + 1, first entry 0.
    std::vector<std::uint32_t> removedTriangleOffset, addedTriangleOffset;
    std::vector<std::uint32_t> removedEdgeOffset, addedEdgeOffset;
    std::vector<TriangleTriple> removedTriangles, addedTriangles;
    std::vector<RiverEdge> removedEdges, addedEdges;
    // Model error after each step, running maxima (non-decreasing). Empty when not computed.
    std::vector<double> errorMax, errorPaper;
    // The river part of errorMax: the running maximum of the river deviations alone (with the
    // `max` metric; format::Block::errorRiver). errorMax = max(running vertical maximum, this).
    std::vector<double> errorRiver;
    // The `max` error each step causes itself (before the running maximum): for the greedy order
    // the deleted vertex's key without the BAI factor. Empty when `max` is not computed.
    std::vector<double> stepErrorMax;
    double initialErrorMax = 0, initialErrorPaper = 0;  // before the first step
    double initialErrorRiver = 0;
    std::vector<KeptVertex> kept;        // refused or never-deletable vertices of the order
    std::uint32_t deferrals = 0;         // deferred attempts (a vertex may be deferred often)
    std::uint32_t deferredVertices = 0;  // distinct vertices deferred at least once
    std::uint32_t mergedSkipped = 0;     // order entries skipped as merged duplicates
    // Greedy order: after the last step, every alive river edge (a < b, sorted) with the original
    // river points it stands for: what a tree node's river chains start from
    // (DeletionOptions::riverCover).
    std::vector<std::pair<RiverEdge, RiverCover>> riverCover;

    std::size_t memoryBytes() const;
};

struct DeletionOptions {
    bool maxError = true;    // compute the `max` metric
    bool paperError = true;  // compute the `paper` metric
    // Stop after this many steps (the Cdt is left at that step; `kept` then lists only the
    // refusals met so far and no Deferred entries).
    std::uint32_t maxSteps = std::numeric_limits<std::uint32_t>::max();
    // Greedy order: stop once the alive triangles are this many or fewer (0: run to the end);
    // like maxSteps, `kept` then lists no Deferred entries. (The tree's hand-over does not stop
    // the deletion: handoverTriangles below.)
    std::uint32_t stopTriangles = 0;
    // Greedy order: stop before a step whose key (the error it causes, times its BAI factor)
    // exceeds this. Infinity: no such stop. (A tree node's hand-over error is handoverKey.)
    double stopKey = std::numeric_limits<double>::infinity();
    // Greedy order: the hand-over of issue 18's tree (nodebuild.h), decoupled from the stop. The
    // first time the alive triangles are `handoverTriangles` or fewer (0: never by count) or the
    // next step's key exceeds `handoverKey`, or at the end if neither comes first, `onHandover`
    // is called once with the state at that step (the Cdt and the records so far, `riverCover`
    // filled in as at the end); the deletion then goes on to its own stop. A block or node keeps
    // simplifying for its own drawing past the state its parent starts from.
    std::uint32_t handoverTriangles = 0;
    double handoverKey = std::numeric_limits<double>::infinity();
    // The key rule hands over only at this many alive triangles or fewer (nodebuild.h
    // kHandoffShare: terrain rougher than the hand-over error handed every state over whole).
    std::uint32_t handoverKeyTriangles = std::numeric_limits<std::uint32_t>::max();
    std::function<void()> onHandover;
    // Called after every step with the step count (tests run the checker here).
    std::function<void(std::uint32_t)> afterStep;
    // Original points beyond the set's, counted in the `max` metric only (modelerror.h
    // ExtraSamples: a tree node's original points, a block's DEM points dropped by the river
    // clearance). Must outlive the call.
    ExtraSamples* extraSamples = nullptr;
    bool releaseExtraSamples = false;  // hand them over once placed (ModelError::init release)
    // Issue 18's tree nodes (nodebuild.h), whose points are their children's coarsest vertices:
    // `errorFloor` is the error the running `max` starts from (the children's largest final
    // error: errors stay monotone up the tree). A chain as built is the children's coarsest, so
    // each of its edges stands for original points deleted below: `riverCover` (by
    // Cdt::edgeKey(min, max) of the built river edge: the child's DeletionRecords::riverCover)
    // lists them, and a river deviation is measured against them as a block's is against its
    // own deleted river vertices; an edge without one (outline edges, river edges the
    // triangulation split) gets `chainSlack` added instead (the original chain lies within it).
    // `riverFloor`: the same for the river part (the children's largest final river part).
    double errorFloor = 0, chainSlack = 0, riverFloor = 0;
    const std::unordered_map<std::uint64_t, RiverCover>* riverCover = nullptr;
};

// The greedy order's tie-break rank of vertex v: a bijection of the 32-bit ids (a total order)
// that scatters consecutive ids (the finaliser of a multiplicative hash, after C. Wellons'
// "lowbias32": xor-shifts and odd multipliers, each invertible modulo 2^32).
std::uint32_t tieRank(PointId v);

// Runs the deletion sequence on `cdt` (built from `set` by buildCdt, no deletion yet).
// Returns false with `error` for an invalid order (id out of range or repeated).
bool runDeletion(const PointSet& set, Cdt& cdt, const std::vector<PointId>& order,
                 const DeletionOptions& options, DeletionRecords& records, std::string& error);

// Runs the greedy deletion sequence (above) on `cdt`: the order is the records' step vertices.
// `keys`: how a river vertex's error becomes its key (bai.h BaiKeys; empty: the error itself).
// Needs the `max` metric (options.maxError). Returns false with `error` on bad input.
bool runGreedyDeletion(const PointSet& set, Cdt& cdt, const BaiKeys& keys,
                       const DeletionOptions& options, DeletionRecords& records,
                       std::string& error);

// Applies steps 1..k of the records to the triangles / river edges of the full triangulation
// (collectTriangles / collectRiverEdges before the deletion) and returns the sorted result.
std::vector<TriangleTriple> replayTriangles(const std::vector<TriangleTriple>& initial,
                                            const DeletionRecords& records, std::uint32_t k);
std::vector<RiverEdge> replayRiverEdges(const std::vector<RiverEdge>& initial,
                                        const DeletionRecords& records, std::uint32_t k);

}  // namespace unilod
