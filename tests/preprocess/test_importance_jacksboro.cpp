// The improved 3D_DP on the bundled Jacksboro DEM + GRASS river network (paper §2.2.3): with BAI,
// the river points of tight meanders on low, flat ground rank higher in the importance order
// than with plain 3D_DP.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <numeric>

#include "bai.h"
#include "dem.h"
#include "importance.h"
#include "pointset.h"
#include "rivers.h"

using namespace unilod;

namespace {

struct Jacksboro {
    PointSet set;
    Jacksboro() {
        DemGrid dem;
        RiverLines rivers;
        std::string err;
        const std::string dir = UNILOD_ASSETS_DIR;
        EXPECT_TRUE(loadDem(dir + "/jacksboro_dem.tif", {}, dem, err)) << err;
        EXPECT_TRUE(loadRivers(dir + "/jacksboro_rivers_grass.geojson", {}, dem.wkt, rivers, err))
            << err;
        PointSetOptions opt;
        opt.riverClearance = 1.0;
        set = buildPointSet(dem, rivers, opt);
    }
};

// Position of every point in the deletion order, scaled to [0, 1] (1 = deleted last).
std::vector<double> ranks(const ImportanceResult& r, std::size_t n) {
    std::vector<double> rank(n, -1);
    for (std::size_t i = 0; i < r.order.size(); ++i) {
        rank[r.order[i]] = double(i) / double(r.order.size() - 1);
    }
    return rank;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

}  // namespace

TEST(ImportanceJacksboro, BaiRaisesTightLowlandMeanders) {
    const Jacksboro data;
    const PointSet& set = data.set;
    ASSERT_GT(set.points.size(), 100000u);
    ASSERT_GT(set.rivers.size(), 100u);

    ImportanceOptions on, off;
    off.useBai = false;
    ImportanceResult withBai, plain;
    std::string err;
    ASSERT_TRUE(computeImportance(set, on, withBai, err)) << err;
    ASSERT_TRUE(computeImportance(set, off, plain, err)) << err;

    // Tight meanders on low, flat ground: bends in the flat class (mean altitude < 500 m) whose
    // BAI exceeds a lone semicircle's (pi/4 ~ 0.785).
    const BaiTable table = BaiTable::paperDefault();
    const int row = table.findRow(kDefaultBaiRow);
    const Quantizer q = Quantizer::forPoints(set.points);
    std::vector<char> meander(set.points.size(), 0);
    int bends = 0;
    for (const Polyline& line : set.rivers) {
        for (const Bend& b : computeBends(set.points, line, q, table, row)) {
            if (b.meanZ >= 500 || b.bai <= 0.785) continue;
            ++bends;
            for (std::uint32_t k = b.first + 1; k < b.last; ++k)
                meander[line[k]] = 1;
        }
    }
    const auto rankOn = ranks(withBai, set.points.size()),
               rankOff = ranks(plain, set.points.size());
    std::vector<double> on_, off_;
    int higher = 0;
    for (PointId i = 0; i < set.points.size(); ++i) {
        if (!meander[i] || set.points[i].locked) continue;
        on_.push_back(rankOn[i]);
        off_.push_back(rankOff[i]);
        higher += rankOn[i] > rankOff[i];
    }
    ASSERT_GT(bends, 100);
    ASSERT_GT(on_.size(), 100u);
    const double meanOn = std::accumulate(on_.begin(), on_.end(), 0.0) / double(on_.size());
    const double meanOff = std::accumulate(off_.begin(), off_.end(), 0.0) / double(off_.size());
    const double fraction = double(higher) / double(on_.size());
    std::printf(
        "tight lowland meanders: %d bends, %zu points; mean rank %.3f -> %.3f, median %.3f -> "
        "%.3f; %.1f%% rank higher\n",
        bends, on_.size(), meanOff, meanOn, median(off_), median(on_), 100 * fraction);
    EXPECT_GT(meanOn, meanOff + 0.1);
    EXPECT_GT(median(on_), median(off_));
    EXPECT_GT(fraction, 0.75);
}
