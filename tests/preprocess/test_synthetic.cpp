// Synthetic terrain + rivers (tools/synthetic.h): determinism, size, river topology (exact
// crossing check on the 1 mm grid), junctions, locks, altitudes.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "greedytin.h"
#include "grid.h"
#include "synthetic.h"

using namespace unilod;

namespace {

SyntheticOptions options(std::size_t points, std::uint64_t seed, bool lockBorder = false) {
    SyntheticOptions o;
    o.targetPoints = points;
    o.seed = seed;
    o.lockBorder = lockBorder;
    return o;
}

bool samePoints(const PointSet& a, const PointSet& b) {
    if (a.points.size() != b.points.size() || a.rivers != b.rivers) return false;
    for (std::size_t i = 0; i < a.points.size(); ++i) {
        const Point& p = a.points[i];
        const Point& q = b.points[i];
        if (std::bit_cast<std::uint64_t>(p.x) != std::bit_cast<std::uint64_t>(q.x) ||
            std::bit_cast<std::uint64_t>(p.y) != std::bit_cast<std::uint64_t>(q.y) ||
            std::bit_cast<std::uint64_t>(p.z) != std::bit_cast<std::uint64_t>(q.z) ||
            p.kind != q.kind || p.locked != q.locked) {
            return false;
        }
    }
    return true;
}

// Is p on the closed segment ab, given that the three are collinear?
bool withinBox(const GridPoint& p, const GridPoint& a, const GridPoint& b) {
    return p.x >= std::min(a.x, b.x) && p.x <= std::max(a.x, b.x) && p.y >= std::min(a.y, b.y) &&
           p.y <= std::max(a.y, b.y);
}
bool onSegment(const GridPoint& p, const GridPoint& a, const GridPoint& b) {
    return orient2d(a, b, p) == 0 && withinBox(p, a, b);
}

// Exact test: do the closed segments share a point other than a common endpoint id?
bool conflict(PointId a, PointId b, PointId c, PointId d, const std::vector<GridPoint>& g) {
    const bool ac = a == c, ad = a == d, bc = b == c, bd = b == d;
    const int shared = ac + ad + bc + bd;
    if (shared >= 2) return true;  // the same segment twice
    if (shared == 1) {
        // Segments sharing an endpoint meet elsewhere only by overlapping collinearly.
        const PointId s1 = (ac || ad) ? b : a;  // the free end of the first
        const PointId s2 = (ac || bc) ? d : c;  // the free end of the second
        const PointId p = (ac || ad) ? a : b;   // the shared one
        return onSegment(g[s1], g[p], g[s2]) || onSegment(g[s2], g[p], g[s1]);
    }
    const int o1 = orient2d(g[a], g[b], g[c]), o2 = orient2d(g[a], g[b], g[d]);
    const int o3 = orient2d(g[c], g[d], g[a]), o4 = orient2d(g[c], g[d], g[b]);
    if (o1 * o2 < 0 && o3 * o4 < 0) return true;
    return (o1 == 0 && withinBox(g[c], g[a], g[b])) || (o2 == 0 && withinBox(g[d], g[a], g[b])) ||
           (o3 == 0 && withinBox(g[a], g[c], g[d])) || (o4 == 0 && withinBox(g[b], g[c], g[d]));
}

// Number of conflicting segment pairs over all river segments (sweep over x).
std::size_t countCrossings(const PointSet& set) {
    const Quantizer q = Quantizer::forPoints(set.points);
    std::vector<GridPoint> g(set.points.size());
    for (std::size_t i = 0; i < g.size(); ++i)
        g[i] = q(set.points[i]);
    struct S {
        PointId a, b;
        std::int64_t x0, x1, y0, y1;
    };
    std::vector<S> segs;
    for (const Polyline& line : set.rivers) {
        for (std::size_t i = 0; i + 1 < line.size(); ++i) {
            const GridPoint& p = g[line[i]];
            const GridPoint& r = g[line[i + 1]];
            segs.push_back({line[i], line[i + 1], std::min(p.x, r.x), std::max(p.x, r.x),
                            std::min(p.y, r.y), std::max(p.y, r.y)});
        }
    }
    std::sort(segs.begin(), segs.end(), [](const S& s, const S& t) { return s.x0 < t.x0; });
    std::size_t crossings = 0;
    for (std::size_t i = 0; i < segs.size(); ++i) {
        for (std::size_t j = i + 1; j < segs.size() && segs[j].x0 <= segs[i].x1; ++j) {
            if (segs[j].y0 > segs[i].y1 || segs[j].y1 < segs[i].y0) continue;
            crossings += conflict(segs[i].a, segs[i].b, segs[j].a, segs[j].b, g);
        }
    }
    return crossings;
}

std::size_t countRiverPoints(const PointSet& set) {
    return static_cast<std::size_t>(
        std::count_if(set.points.begin(), set.points.end(),
                      [](const Point& p) { return p.kind == PointKind::River; }));
}

}  // namespace

TEST(Synthetic, SameSeedSamePoints) {
    const PointSet a = generateSyntheticTerrain(options(30000, 7));
    const PointSet b = generateSyntheticTerrain(options(30000, 7));
    ASSERT_FALSE(a.points.empty());
    EXPECT_TRUE(samePoints(a, b));
}

TEST(Synthetic, DifferentSeedDifferentPoints) {
    const PointSet a = generateSyntheticTerrain(options(30000, 7));
    const PointSet b = generateSyntheticTerrain(options(30000, 8));
    EXPECT_FALSE(samePoints(a, b));
    // Not only the rivers: the terrain differs too.
    std::size_t differentZ = 0;
    for (std::size_t i = 0; i < std::min(a.points.size(), b.points.size()) / 2; ++i) {
        differentZ += a.points[i].z != b.points[i].z;
    }
    EXPECT_GT(differentZ, a.points.size() / 4);
}

TEST(Synthetic, PointCountNearTarget) {
    for (std::size_t target : {1000, 5000, 40000, 250000}) {
        const PointSet set = generateSyntheticTerrain(options(target, 3));
        const double n = static_cast<double>(set.points.size());
        EXPECT_GT(n, 0.9 * static_cast<double>(target)) << target;
        EXPECT_LT(n, 1.1 * static_cast<double>(target)) << target;
        EXPECT_GT(countRiverPoints(set), 0u) << target;
    }
}

TEST(Synthetic, RiversNeverCross) {
    // Small and medium sizes; without the generator's clearance check, the 400k cases of seeds 2
    // and 7 do contain crossings, so this would notice the check going wrong.
    const std::pair<std::size_t, std::uint64_t> cases[] = {{3000, 1},  {60000, 1},  {60000, 2},
                                                           {60000, 3}, {400000, 2}, {400000, 7}};
    for (auto [points, seed] : cases) {
        const PointSet set = generateSyntheticTerrain(options(points, seed));
        ASSERT_GT(set.rivers.size(), 2u);
        EXPECT_EQ(countCrossings(set), 0u) << points << " points, seed " << seed;
    }
}

TEST(Synthetic, CrossingCheckDetectsCrossings) {
    // The checker itself: a crossing X, a T touching an interior, and a collinear overlap.
    PointSet set;
    for (auto [x, y] : std::vector<std::pair<double, double>>{
             {0, 0}, {10, 10}, {0, 10}, {10, 0}, {20, 0}, {30, 0}, {25, 0}, {25, 5}}) {
        set.points.push_back({x, y, 0, PointKind::River, false});
    }
    set.rivers = {{0, 1}, {2, 3}};
    EXPECT_EQ(countCrossings(set), 1u);
    set.rivers = {{4, 5}, {7, 6}};  // T: (25,5)-(25,0) ends on the interior of (20,0)-(30,0)
    EXPECT_EQ(countCrossings(set), 1u);
    set.rivers = {{4, 6, 5}, {4, 5}};  // shares ends but overlaps collinearly
    EXPECT_GT(countCrossings(set), 0u);
    set.rivers = {{4, 6}, {6, 7}};  // a proper junction
    EXPECT_EQ(countCrossings(set), 0u);
}

TEST(Synthetic, JunctionsSharedAndLocked) {
    const SyntheticOptions o = options(50000, 5);
    const SyntheticData data = generateSyntheticData(o);
    const PointSet set = generateSyntheticTerrain(o);
    const std::size_t tributaries = data.rivers.size() - static_cast<std::size_t>(data.mainRivers);
    ASSERT_GT(data.mainRivers, 0);
    ASSERT_GT(tributaries, 0u);
    ASSERT_EQ(set.rivers.size(), data.rivers.size());  // nothing split or dropped

    std::map<PointId, std::set<std::size_t>> usedBy;
    for (std::size_t l = 0; l < set.rivers.size(); ++l) {
        for (PointId id : set.rivers[l])
            usedBy[id].insert(l);
    }
    std::size_t shared = 0;
    for (const auto& [id, lines] : usedBy) {
        if (lines.size() > 1) {
            ++shared;
            EXPECT_TRUE(set.points[id].locked);
        }
    }
    EXPECT_EQ(shared, tributaries);  // one junction per tributary
    // Every tributary ends on a main river's interior vertex.
    for (std::size_t l = static_cast<std::size_t>(data.mainRivers); l < set.rivers.size(); ++l) {
        const auto& lines = usedBy[set.rivers[l].back()];
        EXPECT_EQ(lines.size(), 2u);
        EXPECT_LT(*lines.begin(), static_cast<std::size_t>(data.mainRivers));
    }
    // Endpoints locked; other river points not (no border lock here).
    std::set<PointId> ends;
    for (const Polyline& line : set.rivers) {
        EXPECT_TRUE(set.points[line.front()].locked);
        EXPECT_TRUE(set.points[line.back()].locked);
        ends.insert(line.front());
        ends.insert(line.back());
    }
    for (std::size_t i = 0; i < set.points.size(); ++i) {
        const Point& p = set.points[i];
        const bool junction =
            usedBy.count(static_cast<PointId>(i)) && usedBy[static_cast<PointId>(i)].size() > 1;
        if (p.kind == PointKind::Dem || (!ends.count(static_cast<PointId>(i)) && !junction)) {
            EXPECT_FALSE(p.locked) << i;
        }
    }
}

TEST(Synthetic, LockBorderLocksTheGridBorder) {
    const SyntheticOptions o = options(20000, 9, true);
    const SyntheticData data = generateSyntheticData(o);
    const PointSet set = generateSyntheticTerrain(o);
    const DemGrid& dem = data.dem;
    const double half = 0.5 * o.cellSize;
    const double xMin = dem.originX, xMax = dem.centreX(dem.width - 1);
    const double yMax = dem.originY, yMin = dem.centreY(dem.height - 1);
    std::size_t border = 0;
    for (const Point& p : set.points) {
        if (p.kind != PointKind::Dem) continue;
        const bool onBorder = std::abs(p.x - xMin) < half || std::abs(p.x - xMax) < half ||
                              std::abs(p.y - yMin) < half || std::abs(p.y - yMax) < half;
        EXPECT_EQ(p.locked, onBorder);
        border += onBorder;
    }
    EXPECT_EQ(border, static_cast<std::size_t>(2 * dem.width + 2 * dem.height - 4));
}

TEST(Synthetic, GeometryAndAltitudes) {
    const SyntheticOptions o = options(80000, 11);
    const SyntheticData data = generateSyntheticData(o);
    const PointSet set = generateSyntheticTerrain(o);
    const DemGrid& dem = data.dem;

    // Altitudes: 0..~2000 m with large lowlands and real mountains.
    std::size_t low = 0, high = 0;
    float zMin = 1e9f, zMax = -1e9f;
    for (float z : dem.z) {
        ASSERT_TRUE(std::isfinite(z));
        zMin = std::min(zMin, z);
        zMax = std::max(zMax, z);
        low += z < 500;
        high += z > 1000;
    }
    EXPECT_GE(zMin, 0.0f);
    EXPECT_LT(zMin, 200.0f);
    EXPECT_GT(zMax, 1400.0f);
    EXPECT_LE(zMax, 2000.0f);
    EXPECT_GT(low, dem.z.size() / 4);
    EXPECT_GT(high, dem.z.size() / 20);

    // River vertices as generated: 0.5..1 cell apart; in the point set, z = bilinear DEM
    // altitude. (Dropping DEM points next to rivers, and the river vertices added where they
    // are passed, is buildPointSet's riverClearance, tested in test_pointset.)
    for (const RiverLine& line : data.rivers) {
        for (std::size_t i = 0; i + 1 < line.size(); ++i) {
            const XY& a = line[i];
            const XY& b = line[i + 1];
            const double d = std::hypot(b.x - a.x, b.y - a.y) / o.cellSize;
            EXPECT_GE(d, 0.5 - 1e-9);
            EXPECT_LE(d, 1.0 + 1e-9);
        }
    }
    for (const Point& p : set.points) {
        if (p.kind != PointKind::River) continue;
        EXPECT_EQ(p.z, dem.sample(p.x, p.y));
    }
}

TEST(Synthetic, ExplicitRiverCount) {
    SyntheticOptions o = options(40000, 2);
    o.rivers = 3;
    const SyntheticData data = generateSyntheticData(o);
    EXPECT_EQ(data.mainRivers, 3);
}

// Bit-identical output on every platform and compiler: a checksum of a small point set, taken
// when the generator was written. A deliberate change of the generator updates the constant; any
// other change (a libm call, FMA contraction, a std distribution, iteration order) breaks it.
// The default roughness (0.75) and the smooth terrain of earlier versions (0.5, the constant taken
// when the generator was written: only the octave amplitude ratio changed since). Taken again on
// 2026-11-30, when the point set assembly (not the generator) began to add a river vertex where a
// river passes a DEM point the clearance drops (pointset.h addVerticesAtDroppedCells): 15 more
// points, the DEM and the lines unchanged.
constexpr std::size_t kGoldenPoints = 20068;
constexpr std::uint64_t kGoldenHash = 0x21945f000171e660ull;
constexpr std::uint64_t kGoldenHashSmooth = 0xa3561dd0f43491cfull;

std::uint64_t checksum(const PointSet& set) {
    std::uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a, 64 bit
    auto mix = [&h](std::uint64_t v) {
        for (int i = 0; i < 8; ++i) {
            h ^= (v >> (8 * i)) & 0xff;
            h *= 0x100000001b3ull;
        }
    };
    for (const Point& p : set.points) {
        mix(std::bit_cast<std::uint64_t>(p.x));
        mix(std::bit_cast<std::uint64_t>(p.y));
        mix(std::bit_cast<std::uint64_t>(p.z));
        mix(static_cast<std::uint64_t>(p.kind) * 2 + p.locked);
    }
    for (const Polyline& line : set.rivers) {
        mix(line.size());
        for (PointId id : line)
            mix(id);
    }
    return h;
}

TEST(Synthetic, GoldenChecksum) {
    const PointSet set = generateSyntheticTerrain(options(20000, 42, true));
    EXPECT_EQ(set.points.size(), kGoldenPoints);
    EXPECT_EQ(checksum(set), kGoldenHash) << std::hex << "0x" << checksum(set);
    SyntheticOptions smooth = options(20000, 42, true);
    smooth.roughness = 0.5;
    const PointSet old = generateSyntheticTerrain(smooth);
    EXPECT_EQ(old.points.size(), kGoldenPoints);
    EXPECT_EQ(checksum(old), kGoldenHashSmooth) << std::hex << "0x" << checksum(old);
}

// Roughness is what its name says: a greedy TIN of the rougher terrain needs more triangles for
// the same vertical error (the benchmarks' baseline, preprocess/greedytin.h).
TEST(Synthetic, RougherTerrainNeedsMoreTriangles) {
    std::vector<std::uint64_t> previous;
    for (double roughness : {0.5, 0.65, 0.8}) {
        SyntheticOptions o = options(60000, 3);
        o.roughness = roughness;
        const PointSet set = generateSyntheticTerrain(o);
        std::vector<std::uint64_t> triangles;
        std::string error;
        ASSERT_TRUE(greedyTinTriangles(set, {5.0, 20.0}, triangles, error)) << error;
        if (!previous.empty()) {
            EXPECT_GT(triangles[0], previous[0] * 3 / 2) << roughness;
            EXPECT_GT(triangles[1], previous[1] * 3 / 2) << roughness;
        }
        previous = triangles;
    }
}
