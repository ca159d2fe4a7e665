// The invariant checker catches hand-made violations (paper §3.3 invariants; checker.h).
#include <gtest/gtest.h>

#include "cdt.h"
#include "cdt_fixtures.h"
#include "checker.h"

namespace unilod {
namespace {

using testing::BlockSpec;
using testing::makeBlock;

class CheckerTest : public ::testing::Test {
protected:
    void SetUp() override {
        BlockSpec spec;
        spec.seed = 77;
        spec.points = 400;
        set = makeBlock(spec);
        std::string error;
        ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
        ref = captureCheckReference(cdt);
        std::string message;
        ASSERT_TRUE(checkCdt(cdt, ref, nullptr, message)) << message;
    }
    // Fails the test unless the checker rejects the mesh with a message containing `what`.
    void expectViolation(const std::vector<RiverEdge>* edges, const std::string& what) {
        std::string message;
        EXPECT_FALSE(checkCdt(cdt, ref, edges, message));
        EXPECT_NE(message.find(what), std::string::npos) << message;
    }
    // An interior edge between two real triangles: constrained or not, as asked.
    std::uint32_t interiorEdge(bool constrained) const {
        for (std::uint32_t h = 0; h < cdt.tv.size(); ++h) {
            if (!cdt.triangleAlive(h / 3) || cdt.isGhost(h / 3) || cdt.isGhost(cdt.tn[h] / 3))
                continue;
            if (cdt.isConstrained(h) != constrained) continue;
            const PointId a = cdt.tv[h], d = cdt.tv[cdt.tn[h]];
            const PointId b = cdt.origin(h), c = cdt.destination(h);
            // Strictly convex quadrilateral and strictly Delaunay edge: its flip is not.
            if (cdt.orient(a, d, b) * cdt.orient(a, d, c) >= 0) continue;
            if (incircle(cdt.gx[a], cdt.gy[a], cdt.gx[b], cdt.gy[b], cdt.gx[c], cdt.gy[c],
                         cdt.gx[d], cdt.gy[d]) >= 0)
                continue;
            return h;
        }
        return Cdt::kNone;
    }
    PointSet set;
    Cdt cdt;
    CheckReference ref;
};

TEST_F(CheckerTest, FlippedTriangle) {
    // Reflect one vertex of an interior triangle over its opposite edge: the triangle turns
    // clockwise while the adjacency stays consistent.
    const std::uint32_t h = interiorEdge(false);
    ASSERT_NE(h, Cdt::kNone);
    const PointId a = cdt.tv[h], b = cdt.origin(h), c = cdt.destination(h);
    cdt.gx[a] = cdt.gx[b] + cdt.gx[c] - cdt.gx[a];
    cdt.gy[a] = cdt.gy[b] + cdt.gy[c] - cdt.gy[a];
    expectViolation(nullptr, "not counter-clockwise");
}

TEST_F(CheckerTest, BrokenAdjacency) {
    const std::uint32_t h = interiorEdge(false);
    ASSERT_NE(h, Cdt::kNone);
    cdt.tn[h] = (cdt.tn[h] / 3) * 3 + (cdt.tn[h] + 1) % 3;
    expectViolation(nullptr, "inconsistent adjacency");
}

TEST_F(CheckerTest, MissingRiverEdge) {
    const std::vector<RiverEdge> edges = collectRiverEdges(cdt);
    const std::uint32_t h = cdt.findEdge(edges[5].a, edges[5].b);
    ASSERT_NE(h, Cdt::kNone);
    cdt.setConstrained(h, false);
    --cdt.constraintEdgeCount;
    expectViolation(&edges, "is not marked as a constraint");
    // From the mesh alone, the river lost an edge: its chain between junctions is broken.
    expectViolation(nullptr, "river");
    // The river edge flipped away: no longer an edge at all.
    if (cdt.orient(cdt.tv[h], cdt.tv[cdt.tn[h]], cdt.origin(h)) *
            cdt.orient(cdt.tv[h], cdt.tv[cdt.tn[h]], cdt.destination(h)) <
        0) {
        cdt.flip(h);
        expectViolation(&edges, "is not an edge of the triangulation");
    }
}

TEST_F(CheckerTest, CrossingRiverEdges) {
    // Add the other diagonal of a river edge's quadrilateral as a river edge: they cross.
    std::vector<RiverEdge> edges = collectRiverEdges(cdt);
    std::uint32_t h = Cdt::kNone;
    for (const RiverEdge& e : edges) {
        const std::uint32_t g = cdt.findEdge(e.a, e.b);
        const PointId a = cdt.tv[g], d = cdt.tv[cdt.tn[g]];
        if (a != Cdt::kGhost && d != Cdt::kGhost &&
            cdt.orient(a, d, e.a) * cdt.orient(a, d, e.b) < 0) {
            h = g;
            break;
        }
    }
    ASSERT_NE(h, Cdt::kNone);
    edges.push_back(makeRiverEdge(cdt.tv[h], cdt.tv[cdt.tn[h]]));
    std::sort(edges.begin(), edges.end());
    expectViolation(&edges, "cross");
}

TEST_F(CheckerTest, NonDelaunayEdge) {
    const std::uint32_t h = interiorEdge(false);
    ASSERT_NE(h, Cdt::kNone);
    cdt.flip(h);
    expectViolation(nullptr, "not locally Delaunay");
}

TEST_F(CheckerTest, DeletedLockedPoint) {
    // Remove a locked interior vertex (a river junction is locked): the checker notices.
    PointId locked = Cdt::kNone;
    std::vector<PointId> link;
    std::vector<std::uint32_t> tris;
    for (PointId v : ref.lockedVertices) {
        if (cdt.star(v, link, tris)) {
            locked = v;
            break;
        }
    }
    ASSERT_NE(locked, Cdt::kNone);
    cdt.removeVertex(locked);
    expectViolation(nullptr, "locked point");
}

TEST_F(CheckerTest, AreaMismatch) {
    CheckReference wrong = ref;
    wrong.doubleHullArea += 2;
    std::string message;
    EXPECT_FALSE(checkCdt(cdt, wrong, nullptr, message));
    EXPECT_NE(message.find("gap or overlap"), std::string::npos) << message;
}

}  // namespace
}  // namespace unilod
