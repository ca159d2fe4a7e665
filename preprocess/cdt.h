// River-constrained Delaunay triangulation of one block (paper §3.3; DESIGN.md "River-constrained
// Delaunay and deletion"): every river segment is a constraint edge, every other edge is locally
// Delaunay. The mesh operations here (cavity re-triangulation, segment insertion, edge flips)
// are shared by the construction and by the deletion sequence (deletion.h).
//
// Grid. The block's points are quantised to a fixed grid of `gridUnit` metres (default 1 mm)
// relative to the centre of their bounding box; all predicates run exactly on these integers
// (predicates.h). A block whose half extent exceeds 2^28 - 1 grid units (268 km at 1 mm) is
// rejected. Points that land on the same grid point are merged: the lowest point id wins and
// becomes the vertex (`representative` maps every point id to its vertex; a merged vertex is
// locked when any of its points is locked), river polylines are rewritten to representatives.
//
// Domain. Without boundary rings (PointSet::boundaries empty) the convex hull of the block's
// points; the outside is closed by ghost triangles that share the vertex at infinity (kGhost),
// so every triangle has three neighbours, and hull vertices are never deleted (deletion.h).
// With boundary rings (issue 17: the valid data of a DEM with nodata, holes, a concave outline)
// the domain is the region the rings enclose: every ring edge is a constraint edge whose
// direction is recorded (`boundary`: the domain on its left), four frame vertices (ids
// frameFirst .. frameFirst + 3, locked, outside every ring) make every point an interior vertex
// of the mesh, and each triangle carries a side bit (exterior()): set from the ring edges it
// touches and carried across every other edge (assignSides). Exterior triangles are part of the
// mesh (they keep re-triangulation local and exact) but of no level: collectTriangles, the
// deletion records and the model error leave them out. A ring vertex may be deleted (the greedy
// order; deletion.h), which inserts the ring edge A-C as for a river.
//
// Constraints. Every river segment is inserted after all points. A vertex lying exactly on a
// segment splits it (the vertex joins the river, `rivers` holds the split polylines). Two river
// segments crossing each other, or the same segment given twice (overlap), are data errors.
//
// Data layout (no per-triangle heap allocation): triangle t owns slots 3t..3t+2 of `tv` (vertex
// ids, counter-clockwise), `tn` (neighbour half-edges) and bit i of `tc` (constraint flags).
// Half-edge h = 3t + i is the edge of t opposite its vertex i, from tv[3t + (i+1)%3] to
// tv[3t + (i+2)%3]; tn[h] is the twin half-edge in the neighbouring triangle. Free triangle slots
// have tv[3t] == kNone and are reused last-in first-out (deterministic).
#pragma once

#include <cstdint>
#include <string>
#include <unordered_set>
#include <vector>

#include "points.h"
#include "predicates.h"

namespace unilod {

// A triangle as three vertex ids, counter-clockwise, rotated so that the smallest id comes first
// (a canonical form: equal triangles compare equal).
struct TriangleTriple {
    PointId v[3] = {0, 0, 0};
    auto operator<=>(const TriangleTriple&) const = default;
};
static_assert(sizeof(TriangleTriple) == 12);
TriangleTriple canonicalTriangle(PointId a, PointId b, PointId c);

// A river edge (constraint edge) as two vertex ids, a < b.
struct RiverEdge {
    PointId a = 0, b = 0;
    auto operator<=>(const RiverEdge&) const = default;
};
static_assert(sizeof(RiverEdge) == 8);
inline RiverEdge makeRiverEdge(PointId a, PointId b) {
    return a < b ? RiverEdge{a, b} : RiverEdge{b, a};
}

struct CdtOptions {
    double gridUnit = 1e-3;  // metres per grid unit
};

class Cdt {
public:
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
    static constexpr PointId kGhost = 0xFFFFFFFEu;  // the vertex at infinity

    // --- Grid frame: grid = round((metres - origin) / gridUnit).
    double originX = 0, originY = 0, gridUnit = 1e-3;

    // --- Per point id (the vertex id of a point is its point id).
    std::vector<std::int32_t> gx, gy;
    std::vector<PointId> representative;        // point id -> vertex id it was merged into
    std::vector<std::uint32_t> vertexTriangle;  // an alive triangle at v; kNone: not a vertex
    std::vector<std::uint8_t> locked;           // 1: never deleted

    // --- Per triangle.
    std::vector<PointId> tv;
    std::vector<std::uint32_t> tn;
    std::vector<std::uint8_t> tc;
    std::vector<std::uint32_t> stamp;  // step that created the triangle (journal, deletion.h)
    std::vector<std::uint32_t> freeSlots;

    // --- Domain (above). Directed ring edges u -> w (the domain on the left) as edgeKey(u, w).
    std::unordered_set<std::uint64_t> boundary;
    // Ring edges a river runs along (a river on a block border line, the DEM's edge or a nodata
    // outline: streams traced along a raster row do), as edgeKey(min, max): river edges as well
    // (collectRiverEdges). Their ends are locked, so no step ever removes such an edge.
    std::unordered_set<std::uint64_t> riverOnBoundary;
    bool isRiverOnBoundary(PointId u, PointId w) const {
        return !riverOnBoundary.empty() &&
               riverOnBoundary.count(edgeKey(std::min(u, w), std::max(u, w))) != 0;
    }
    PointId frameFirst = kGhost;  // first frame vertex id; kGhost: no frame
    static std::uint64_t edgeKey(PointId u, PointId w) { return (std::uint64_t(u) << 32) | w; }
    bool boundaryDirected(PointId u, PointId w) const {
        return !boundary.empty() && boundary.count(edgeKey(u, w)) != 0;
    }
    bool isBoundaryEdge(PointId u, PointId w) const {
        return boundaryDirected(u, w) || boundaryDirected(w, u);
    }
    bool isFrame(PointId v) const { return v >= frameFirst && v != kGhost && v != kNone; }
    static constexpr std::uint8_t kExterior = 8;  // tc bit: the triangle is outside the domain
    bool exterior(std::uint32_t t) const { return (tc[t] & kExterior) != 0; }
    // Whether t is a triangle of the domain (alive, no ghost vertex, not exterior).
    bool inDomain(std::uint32_t t) const { return triangleAlive(t) && !isGhost(t) && !exterior(t); }
    // Sets the side bit of the alive triangles in `slots` (a ghost triangle is exterior): from a
    // ring edge of the triangle (its direction says the side), else from a neighbour across a
    // non-ring edge that is not in `slots`, else carried across non-ring edges within `slots`.
    void assignSides(const std::vector<std::uint32_t>& slots);
    // Sets the side bit of the alive triangles in `slots` to `exterior`: what assignSides gives
    // when every one of them lies on one side, reached from a triangle of that side across
    // non-ring edges only (the hole of a vertex with no ring edge, and flips from it).
    void setSides(const std::vector<std::uint32_t>& slots, bool exterior);
    // Boundary rings as built (representatives, split at vertices on their edges).
    std::vector<Polyline> boundaryRings;

    std::uint32_t vertexCount = 0;          // alive vertices
    std::uint32_t realTriangleCount = 0;    // alive triangles without the ghost vertex
    std::uint32_t constraintEdgeCount = 0;  // river edges
    std::uint32_t mergedPoints = 0;         // points merged into another (duplicates on the grid)
    std::vector<Polyline> rivers;           // river polylines as built (split, representatives)

    // --- Queries.
    std::uint32_t triangleSlots() const { return static_cast<std::uint32_t>(tv.size() / 3); }
    bool triangleAlive(std::uint32_t t) const { return tv[3 * t] != kNone; }
    bool isGhost(std::uint32_t t) const {
        return tv[3 * t] == kGhost || tv[3 * t + 1] == kGhost || tv[3 * t + 2] == kGhost;
    }
    bool isVertex(PointId v) const { return vertexTriangle[v] != kNone; }
    bool isConstrained(std::uint32_t h) const { return (tc[h / 3] >> (h % 3)) & 1u; }
    PointId origin(std::uint32_t h) const { return tv[h - h % 3 + (h % 3 + 1) % 3]; }
    PointId destination(std::uint32_t h) const { return tv[h - h % 3 + (h % 3 + 2) % 3]; }
    std::int64_t orient(PointId a, PointId b, PointId c) const {
        return orient2d(gx[a], gy[a], gx[b], gy[b], gx[c], gy[c]);
    }
    // Half-edge from a to b, or kNone when a-b is not an edge.
    std::uint32_t findEdge(PointId a, PointId b) const;
    // Metres of a vertex's grid position.
    double gridToX(std::int64_t g) const { return originX + static_cast<double>(g) * gridUnit; }
    double gridToY(std::int64_t g) const { return originY + static_cast<double>(g) * gridUnit; }

    // --- Journal of one deletion step (deletion.h): triangles that existed before the step and
    // were destroyed during it, and the slots created during it.
    void beginJournal(std::uint32_t step);
    void endJournal() { journaling_ = false; }
    std::vector<std::uint32_t> journalRemovedSlots;
    std::vector<TriangleTriple> journalRemoved;
    std::vector<std::uint32_t> journalCreated;  // may hold a slot twice, or dead slots

    // --- Trial (undo log; deletion.h's greedy order): after beginTrial() every mesh operation
    // saves what it overwrites (a triangle slot's vertices, neighbours, flags and stamp once per
    // slot, a vertex's triangle once per vertex, the free-slot list's tail, the counters), so
    // that rollbackTrial() restores the mesh exactly, bit for bit (later operations then reuse
    // the same slots: determinism), and commitTrial() keeps the changes.
    void beginTrial();
    void rollbackTrial();
    void commitTrial() { trial_ = false; }
    bool inTrial() const { return trial_; }

    // --- Mesh operations.
    std::uint32_t createTriangle(PointId a, PointId b, PointId c);
    void destroyTriangle(std::uint32_t t);
    void link(std::uint32_t h, std::uint32_t g) {
        if (trial_) {
            saveTriangle(h / 3);
            saveTriangle(g / 3);
        }
        tn[h] = g;
        tn[g] = h;
    }
    void setConstrained(std::uint32_t h, bool on);
    // Flips the edge of h (both triangles real, h not constrained, the quadrilateral convex).
    void flip(std::uint32_t h);
    // Flips every edge on the stack (and the edges it uncovers) that is not locally Delaunay.
    void legalize(std::vector<std::uint32_t>& stack);
    // legalize on every edge of these triangles.
    void legalizeTriangles(const std::vector<std::uint32_t>& triangles);
    // Before a vertex's star `triangles` (star()) is re-triangulated: outer_ and cons_ of its
    // link's edges; returns whether a constraint edge meets the vertex.
    bool takeHole(const std::vector<std::uint32_t>& triangles);
    // v's star `triangles` replaced by the plan_ of its link `ring` (takeHole first).
    void replaceStar(PointId v, const std::vector<PointId>& ring,
                     const std::vector<std::uint32_t>& triangles);
    // The constrained Delaunay triangulation of the hole an interior vertex leaves: its link
    // `poly` (vertex ids, counter-clockwise, star-shaped around the vertex) is ear-clipped, then
    // the diagonals are flipped until each is locally Delaunay (Lawson). The polygon's own edges
    // are never flipped and need not be: the circumcircle of the triangle beyond each held no
    // vertex inside, so no hole triangle's apex is inside it. `triangles` receives 3 indices into
    // `poly` per triangle, counter-clockwise. Deterministic and read-only on the mesh: the greedy
    // order's key (deletion.h) and removeVertex both use it, so they make the same triangles.
    void planHole(const std::vector<PointId>& poly, std::vector<std::uint32_t>& triangles);

    // Walk of the segment a -> b from a.
    enum class TraceEnd : std::uint8_t { Reached, Vertex, Constraint };
    struct Trace {
        TraceEnd end = TraceEnd::Reached;
        PointId vertex = kNone;              // Vertex: the vertex met on the open segment
        std::uint32_t edge = kNone;          // Constraint: the crossed constraint half-edge
        std::vector<std::uint32_t> crossed;  // crossed half-edges, in order, up to the end
    };
    void traceSegment(PointId a, PointId b, Trace& trace) const;

    // Inserts the constraint a-b (a != b). Vertices on the segment split it: `path` receives
    // a, the vertices met, b. Returns false with `error` set when the segment crosses a
    // constraint or overlaps one. `river`: a river segment, which may run along ring edges
    // (riverOnBoundary; their ends are locked).
    bool insertSegment(PointId a, PointId b, std::vector<PointId>& path, std::string& error,
                       bool river = false);

    // Removes the interior vertex v (no ghost triangle at v) and re-triangulates its star so that
    // the mesh is again constrained Delaunay. Constraint edges at v disappear (the caller keeps
    // the river bookkeeping).
    void removeVertex(PointId v);
    // The same with v's star as returned by star() (unchanged since).
    void removeVertex(PointId v, const std::vector<PointId>& link,
                      const std::vector<std::uint32_t>& triangles);
    // Removes v (its star as returned by star()) and makes link[ia] - link[ic] a constraint edge,
    // where that segment is a diagonal of the hole or one of its edges (the caller knows: no link
    // vertex but those two in the closed triangle (link[ia], v, link[ic]), or v strictly between
    // them on one line). A diagonal splits the hole into two polygons, each re-triangulated by
    // planHole; the edge is constrained before the Delaunay flips after the removal. The same
    // constrained Delaunay triangulation as removeVertex and insertSegment(link[ia], link[ic]),
    // without the flips across the new edge and back, which cost the square of the star's size
    // (a ring step next to a frame vertex that meets the whole outline of a strip).
    void removeVertexWithDiagonal(PointId v, const std::vector<PointId>& link,
                                  const std::vector<std::uint32_t>& triangles, std::uint32_t ia,
                                  std::uint32_t ic);
    // Whether v lies strictly between a and c on one line.
    bool strictlyBetween(PointId a, PointId v, PointId c) const {
        return orient(a, v, c) == 0 && a != c &&
               betweenCollinear(gx[a], gy[a], gx[c], gy[c], gx[v], gy[v]);
    }
    // The star of v: link vertices counter-clockwise and, for each, the triangle (v, link[i],
    // link[i+1]) half-edge index of v. Returns false when v is on the hull (a ghost triangle).
    bool star(PointId v, std::vector<PointId>& link, std::vector<std::uint32_t>& triangles) const;
    // A hull vertex v between its hull neighbours A and C on one straight line (exactly
    // collinear, so deleting v leaves the domain as it is), with no river edge at v: its real
    // triangles' link counter-clockwise from C to A (the hole polygon, closed by the new hull
    // edge A -> C) and their half-edges of v. False otherwise.
    bool straightHullStar(PointId v, std::vector<PointId>& link,
                          std::vector<std::uint32_t>& triangles) const;
    // Removes such a vertex: the hole is re-triangulated by planHole (the same plan as an
    // interior vertex's), the two ghost triangles at v become one across A -> C.
    void removeHullVertex(PointId v, const std::vector<PointId>& link,
                          const std::vector<std::uint32_t>& triangles);

    // Inserts a point p (not a vertex, not on a vertex) by Bowyer-Watson. The cavity never grows
    // across a constraint edge, so the mesh stays constrained Delaunay (greedytin.h inserts
    // points among river constraints). A point exactly on a constraint edge u-w splits it: u-p
    // and p-w become constraint edges, and the split edge is returned ({kNone, kNone}: none).
    // `hint`: an alive triangle near p to start the point location from (greedytin.h passes the
    // triangle whose bucket holds p); kNone: the last triangle created.
    struct SplitEdge {
        PointId u = kNone, w = kNone;
    };
    SplitEdge insertPoint(PointId p, std::uint32_t hint = kNone);
    // Walks from the alive triangle `start` to a real triangle containing p (closed), or to a
    // ghost triangle when p lies outside the hull.
    std::uint32_t locateFrom(PointId p, std::uint32_t start) const {
        return locateGridFrom(gx[p], gy[p], start);
    }
    // The same for a grid position that need not be a point of the set.
    std::uint32_t locateGridFrom(std::int64_t x, std::int64_t y, std::uint32_t start) const;

private:
    std::uint32_t locate(PointId p) const { return locateFrom(p, lastTriangle_); }
    void saveTriangle(std::uint32_t t) {
        if (t < trialSlots_ && triangleMark_[t] != trialId_) saveTriangleSlow(t);
    }
    void saveTriangleSlow(std::uint32_t t);
    // The plan_ of planHole(ring) as new triangles (created_), then linked: polygon edge i
    // (ring[i] -> ring[i + 1]) to outer_[i] with constraint flag cons_[i], a diagonal to its twin.
    void createPlanned(const std::vector<PointId>& ring);
    void linkPlanned();
    void setVertexTriangle(PointId v, std::uint32_t t) {
        if (trial_ && vertexMark_[v] != trialId_) {
            vertexMark_[v] = trialId_;
            savedVertices_.push_back({v, vertexTriangle[v]});
        }
        vertexTriangle[v] = t;
    }

    // Trial state (beginTrial).
    bool trial_ = false;
    std::uint32_t trialId_ = 0, trialSlots_ = 0, trialFreeLow_ = 0;
    std::vector<std::uint32_t> triangleMark_, vertexMark_;
    struct SavedTriangle {
        std::uint32_t t;
        PointId v[3];
        std::uint32_t n[3];
        std::uint32_t stamp;
        std::uint8_t c;
    };
    std::vector<SavedTriangle> savedTriangles_;
    std::vector<std::pair<PointId, std::uint32_t>> savedVertices_;
    std::vector<std::uint32_t> savedFreePopped_;
    std::uint32_t savedCounts_[4] = {0, 0, 0, 0};
    std::uint32_t savedLastTriangle_ = 0;

    bool journaling_ = false;
    std::uint32_t step_ = 0;
    std::uint32_t lastTriangle_ = 0;
    // Scratch buffers reused across operations.
    std::vector<std::uint32_t> cavity_, boundary_, legal_, created_, mark_, touched_, sideQueue_;
    std::vector<std::pair<PointId, PointId>> queue_;
    std::uint32_t markStamp_ = 0;
    std::vector<PointId> poly_;
    std::vector<std::uint32_t> outer_, starTris_;
    std::vector<std::uint8_t> cons_;
    std::vector<std::uint32_t> plan_, planNbr_;
    // removeVertexWithDiagonal's scratch: one side's polygon, its plan, the joined neighbours.
    std::vector<PointId> splitSide_;
    std::vector<std::uint32_t> splitPlan_, splitNbr_;
    // planHole's scratch: the outline's links, the plan half-edge across each outline edge and
    // the polygon's grid coordinates, indexed by polygon position; the flip stack (its size is
    // its capacity).
    std::vector<std::uint32_t> earPrev_, earNext_, across_, planStack_;
    std::vector<std::int64_t> holeX_, holeY_;
    Trace trace_;
    struct FanEdge {  // Bowyer-Watson cavity boundary edge (u, w)
        PointId u, w;
        std::uint32_t outer;
        bool cons;
        std::uint32_t t;
    };
    std::vector<FanEdge> fan_;
};

// Builds the constrained Delaunay triangulation of the block's points with every river segment
// and every boundary ring edge as a constraint (with rings: the frame and the side bits above). Returns false with `error` naming the problem: fewer than 3 distinct points,
// all points collinear, a non-finite coordinate, a block too large for the exact grid, a river
// point id out of range, crossing or overlapping river segments.
bool buildCdt(const PointSet& set, const CdtOptions& options, Cdt& cdt, std::string& error);

// The Delaunay triangulation of the corners of the convex hull of the block's points only
// (points on a hull edge between corners are left out), for greedy insertion (greedytin.h):
// every point is quantised and merged exactly as by buildCdt, so any other representative can
// be added later with insertPoint. Rivers are not inserted (set.rivers is ignored). Same errors
// as buildCdt.
bool buildHullCdt(const PointSet& set, const CdtOptions& options, Cdt& cdt, std::string& error);

// The alive real triangles in canonical form, sorted.
std::vector<TriangleTriple> collectTriangles(const Cdt& cdt);
// The river (constraint) edges, sorted.
std::vector<RiverEdge> collectRiverEdges(const Cdt& cdt);

}  // namespace unilod
