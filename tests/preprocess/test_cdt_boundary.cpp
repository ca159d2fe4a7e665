// Regression: a river that leaves and re-enters a block through the same border line. Deleting
// its interior vertex X would insert A-C along the hull (the border), through the border
// vertices between A and C; the segment walk from a hull vertex must see those collinear
// vertices (it asserted before), and the deletion must be refused without breaking anything.
#include <gtest/gtest.h>

#include "cdt.h"
#include "checker.h"
#include "deletion.h"

using namespace unilod;

TEST(CdtBoundary, RiverAlongTheHullIsDeferredNotCrashed) {
    PointSet set;
    for (int i = 0; i <= 10; ++i) {
        for (int j = 0; j <= 10; ++j) {
            const bool border = i == 0 || j == 0 || i == 10 || j == 10;
            set.points.push_back({i * 10.0, j * 10.0, 100.0 + i + 0.5 * j, PointKind::Dem, border});
        }
    }
    const auto add = [&](double x, double y, bool locked) {
        set.points.push_back({x, y, 90.0, PointKind::River, locked});
        return static_cast<PointId>(set.points.size() - 1);
    };
    const PointId a = add(0, 35, true), x = add(25, 52, false), c = add(0, 65, true);
    set.rivers.push_back({a, x, c});

    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    const CheckReference ref = captureCheckReference(cdt);
    DeletionRecords records;
    DeletionOptions options;
    ASSERT_TRUE(runDeletion(set, cdt, {x}, options, records, error)) << error;
    EXPECT_TRUE(records.steps.empty());
    ASSERT_EQ(records.kept.size(), 1u);
    EXPECT_EQ(records.kept[0].id, x);
    EXPECT_TRUE(cdt.isVertex(x));
    ASSERT_TRUE(checkCdt(cdt, ref, nullptr, error)) << error;

    // The same walk from the other end, and a walk that reaches a hull neighbour directly.
    Cdt::Trace trace;
    cdt.traceSegment(c, a, trace);
    EXPECT_EQ(trace.end, Cdt::TraceEnd::Vertex);
    cdt.traceSegment(a, c, trace);
    EXPECT_EQ(trace.end, Cdt::TraceEnd::Vertex);
}
