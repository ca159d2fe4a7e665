// Invariant checker for the river-constrained Delaunay triangulation (paper §3.3; DESIGN.md
// "Invariants that must hold after every deletion step"). Shipped in the library so that tests,
// the pipeline's debug mode and bug reports all use one definition of "valid":
//   1. valid triangulation of the domain: consistent adjacency (twins point back, share the
//      reversed edge, agree on the constraint flag), every real triangle counter-clockwise,
//      ghost triangles have one vertex at infinity, the vertex -> triangle pointers are right,
//      the surface is a sphere (Euler), and the real triangles' areas sum exactly to the area of
//      the convex hull captured from the full triangulation (with positive orientation and
//      consistent adjacency this excludes gaps and overlaps);
//   2. locked points are vertices;
//   3. no two river edges cross or overlap (exact segment tests), every river edge is a
//      constraint edge of the mesh and there are no other constraint edges;
//   4. river structure: the same junction vertices (river degree != 2) as the reference, and
//      every reference chain between two junctions is still exactly one chain between the same
//      junctions, through a subsequence of its original vertices in the original order;
//   5. constrained Delaunay: every non-constraint edge between two real triangles is locally
//      Delaunay (exact in-circle <= 0).
// Each check returns the first violation as a precise message.
#pragma once

#include <string>
#include <vector>

#include "cdt.h"

namespace unilod {

struct RiverReference {
    std::vector<PointId> junctions;  // sorted; vertices of river degree 1 or >= 3
    // Chains between junctions, junction first and last; a closed loop without junction is
    // stored with its first vertex repeated at the end.
    std::vector<std::vector<PointId>> chains;
};

struct CheckReference {
    RiverReference rivers;
    std::vector<PointId> lockedVertices;  // sorted
    Int128 doubleHullArea = 0;            // twice the domain area in grid units^2
};

// Captures the reference from a triangulation assumed valid (the full one, before deletions).
CheckReference captureCheckReference(const Cdt& cdt);
RiverReference captureRiverReference(const Cdt& cdt, const std::vector<RiverEdge>& edges);

// Checks all invariants. `riverEdges`: the river edges the caller expects (for instance rebuilt
// from the topology-change records); nullptr takes the constraint edges of the mesh itself.
bool checkCdt(const Cdt& cdt, const CheckReference& ref, const std::vector<RiverEdge>* riverEdges,
              std::string& message);

}  // namespace unilod
