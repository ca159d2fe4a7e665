// River network cleaning (preprocess/rivercleaning.h): each step on hand-made lines, then the
// planarity contract checked by brute force with exact predicates on real, synthetic and random
// networks, and the CDT accepting a network it rejected before cleaning.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <ostream>
#include <string>

#include "cdt.h"
#include "dem.h"
#include "pointset.h"
#include "rivercleaning.h"
#include "rivers.h"
#include "synthetic.h"
#include "testutil.h"

using namespace unilod;

namespace unilod {
// Readable failure messages.
void PrintTo(const XY& p, std::ostream* os) {
    *os << "(" << p.x << ", " << p.y << ")";
}
}  // namespace unilod

namespace {

__extension__ typedef __int128 I128;

// Cell centres every 10 m from (0, 0) to (100, 100), north-up; z = x + y.
DemGrid makeDem() {
    DemGrid dem;
    dem.width = dem.height = 11;
    dem.originX = 0;
    dem.originY = 100;
    dem.cellX = 10;
    dem.cellY = -10;
    for (int r = 0; r < dem.height; ++r)
        for (int c = 0; c < dem.width; ++c)
            dem.z.push_back(static_cast<float>(dem.centreX(c) + dem.centreY(r)));
    return dem;
}

RiverLines clean(const RiverLines& in, RiverCleaningStats& stats, double tol = 0.5,
                 double minLength = 0) {
    RiverCleaningOptions o;
    o.snapTolerance = tol;
    o.minRiverLength = minLength;
    return cleanRivers(in, makeDem(), o, stats);
}

// --- Independent planarity checker: brute force over segment pairs (pruned by x extent only),
// exact integer predicates on the 1 mm grid relative to the bounding-box minimum.
struct Q {
    std::int64_t x, y;
    bool operator==(const Q&) const = default;
};
I128 orient(Q a, Q b, Q c) {
    return I128(b.x - a.x) * (c.y - a.y) - I128(b.y - a.y) * (c.x - a.x);
}
bool onSegment(Q a, Q b, Q p) {  // p on closed segment ab, given collinear
    return std::min(a.x, b.x) <= p.x && p.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= p.y &&
           p.y <= std::max(a.y, b.y);
}
bool intersects(Q a, Q b, Q c, Q d) {
    const I128 o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a),
               o4 = orient(c, d, b);
    auto sg = [](I128 v) { return v > 0 ? 1 : (v < 0 ? -1 : 0); };
    if (sg(o1) * sg(o2) < 0 && sg(o3) * sg(o4) < 0) return true;
    return (o1 == 0 && onSegment(a, b, c)) || (o2 == 0 && onSegment(a, b, d)) ||
           (o3 == 0 && onSegment(c, d, a)) || (o4 == 0 && onSegment(c, d, b));
}
// p within 1 grid unit of the open segment ab (p not an endpoint).
bool nearInterior(Q a, Q b, Q p) {
    if (p == a || p == b) return false;
    const double dx = double(b.x - a.x), dy = double(b.y - a.y);
    const double len2 = dx * dx + dy * dy;
    const double t = (double(p.x - a.x) * dx + double(p.y - a.y) * dy) / len2;
    if (t <= 0 || t >= 1) return false;
    return std::abs(double(orient(a, b, p))) / std::sqrt(len2) <= 1.0 + 1e-9;
}

// Number of violations of the cleanRivers contract.
std::size_t violations(const RiverLines& lines, std::string* first = nullptr) {
    double ox = std::numeric_limits<double>::infinity(), oy = ox;
    for (const RiverLine& l : lines)
        for (const XY& p : l) {
            ox = std::min(ox, p.x);
            oy = std::min(oy, p.y);
        }
    struct Seg {
        Q a, b;
        std::size_t line;
    };
    std::vector<Seg> segs;
    std::size_t bad = 0;
    auto report = [&](const std::string& what) {
        if (bad++ == 0 && first != nullptr) *first = what;
    };
    for (std::size_t i = 0; i < lines.size(); ++i) {
        if (lines[i].size() < 2) report("line with < 2 vertices");
        for (std::size_t k = 0; k + 1 < lines[i].size(); ++k) {
            const XY p = lines[i][k], q = lines[i][k + 1];
            const Q a{std::llround((p.x - ox) * 1000), std::llround((p.y - oy) * 1000)};
            const Q b{std::llround((q.x - ox) * 1000), std::llround((q.y - oy) * 1000)};
            if (a == b) report("zero-length segment in line " + std::to_string(i));
            segs.push_back({a, b, i});
        }
    }
    std::sort(segs.begin(), segs.end(), [](const Seg& s, const Seg& t) {
        return std::min(s.a.x, s.b.x) < std::min(t.a.x, t.b.x);
    });
    for (std::size_t i = 0; i < segs.size(); ++i) {
        const std::int64_t maxX = std::max(segs[i].a.x, segs[i].b.x) + 1;
        for (std::size_t j = i + 1; j < segs.size(); ++j) {
            if (std::min(segs[j].a.x, segs[j].b.x) > maxX) break;
            const Q a = segs[i].a, b = segs[i].b, c = segs[j].a, d = segs[j].b;
            if (nearInterior(a, b, c) || nearInterior(a, b, d) || nearInterior(c, d, a) ||
                nearInterior(c, d, b)) {
                report("vertex within 1 mm of a segment interior, lines " +
                       std::to_string(segs[i].line) + " " + std::to_string(segs[j].line));
                continue;
            }
            if (!intersects(a, b, c, d)) continue;
            // Allowed: exactly one shared endpoint and no collinear overlap beyond it.
            const bool ac = a == c, ad = a == d, bc = b == c, bd = b == d;
            const int shared = ac + ad + bc + bd;
            bool ok = shared == 1;
            if (ok) {
                const Q p = (ac || ad) ? a : b;
                const Q u = p == a ? b : a, v = p == c ? d : c;
                if (orient(p, u, v) == 0 &&
                    I128(u.x - p.x) * (v.x - p.x) + I128(u.y - p.y) * (v.y - p.y) > 0)
                    ok = false;
            }
            if (!ok) {
                report("segments meet not at a shared endpoint, lines " +
                       std::to_string(segs[i].line) + " " + std::to_string(segs[j].line));
            }
        }
    }
    return bad;
}

// A few hundred random polylines inside (lo, hi)^2 with long random steps: they cross a lot,
// touch, repeat vertices, and some cross themselves.
RiverLines spaghetti(std::uint64_t seed, int lines, double lo, double hi) {
    test::Rng rng(seed);
    RiverLines out;
    for (int i = 0; i < lines; ++i) {
        RiverLine l;
        const int n = 2 + static_cast<int>(rng.below(10));
        for (int k = 0; k < n; ++k)
            l.push_back({rng.uniform(lo, hi), rng.uniform(lo, hi)});
        // Some exact coincidences: a vertex of an earlier line, a repeated vertex.
        if (!out.empty() && rng.below(4) == 0) {
            const RiverLine& o = out[rng.below(static_cast<std::uint32_t>(out.size()))];
            l.back() = o[rng.below(static_cast<std::uint32_t>(o.size()))];
        }
        if (rng.below(8) == 0) l.insert(l.begin() + 1, l[1]);
        out.push_back(std::move(l));
    }
    return out;
}

}  // namespace

TEST(RiverCleaning, CrossingGetsOneSharedVertex) {
    // Policy: the two lines stay two lines, each with the exact crossing point inserted.
    const RiverLines in = {{{10, 10}, {90, 50}}, {{20, 80}, {60, 0}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s);
    ASSERT_EQ(out.size(), 2u);
    ASSERT_EQ(out[0].size(), 3u);
    ASSERT_EQ(out[1].size(), 3u);
    EXPECT_EQ(out[0][1], (XY{46, 28}));
    EXPECT_EQ(out[1][1], (XY{46, 28}));
    EXPECT_EQ(out[0][0], (XY{10, 10}));
    EXPECT_EQ(out[1][2], (XY{60, 0}));
    EXPECT_EQ(s.crossingsSplit, 1u);
    EXPECT_EQ(violations(in), 1u);
    EXPECT_EQ(violations(out), 0u);
}

TEST(RiverCleaning, EndpointSnapsOntoSegment) {
    const RiverLines in = {{{10, 50}, {90, 50}}, {{50, 90}, {50, 50.3}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s, 0.5);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(s.snappedToSegment, 1u);
    ASSERT_EQ(out[0].size(), 3u);
    EXPECT_EQ(out[0][1], (XY{50, 50}));
    EXPECT_EQ(out[1].back(), (XY{50, 50}));
    EXPECT_EQ(violations(out), 0u);
}

TEST(RiverCleaning, EndpointSnapsOntoVertex) {
    const RiverLines in = {{{10, 50}, {30, 50}, {90, 50}}, {{30.2, 90}, {30.2, 50.1}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s, 0.5);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(s.snappedToVertex, 1u);
    EXPECT_EQ(s.snappedToSegment, 0u);
    EXPECT_EQ(out[0], in[0]);
    EXPECT_EQ(out[1].back(), (XY{30, 50}));
}

TEST(RiverCleaning, EndpointBeyondToleranceStays) {
    const RiverLines in = {{{10, 50}, {90, 50}}, {{50, 90}, {50, 50.6}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s, 0.5);
    EXPECT_EQ(out, in);
    EXPECT_EQ(s.snappedToSegment + s.snappedToVertex, 0u);
    // Zero tolerance: no snapping, but an endpoint exactly on a segment is still a junction.
    const RiverLines onIt = {{{10, 50}, {90, 50}}, {{50, 90}, {50, 50}}};
    const RiverLines t = clean(onIt, s, 0);
    ASSERT_EQ(t[0].size(), 3u);
    EXPECT_EQ(t[0][1], (XY{50, 50}));
    EXPECT_EQ(s.touchesSplit, 1u);
}

TEST(RiverCleaning, NearDegenerateGeometryBecomesShared) {
    // Without snapping: a vertex 0.8 mm off a segment is inserted into it (the exact CDT would
    // otherwise see a vertex almost on a constraint), and two endpoints 1 mm apart are merged.
    RiverCleaningStats s;
    const RiverLines near = clean({{{10, 50}, {90, 50}}, {{50, 90}, {50, 50.0008}}}, s, 0);
    ASSERT_EQ(near.size(), 2u);
    ASSERT_EQ(near[0].size(), 3u);
    EXPECT_EQ(near[0][1], near[1].back());
    EXPECT_EQ(near[0][1], (XY{50, 50.001}));
    EXPECT_EQ(s.touchesSplit, 1u);
    const RiverLines ends = clean({{{10, 50}, {50, 50}}, {{50.001, 50.001}, {90, 20}}}, s, 0);
    ASSERT_EQ(ends.size(), 2u);
    EXPECT_EQ(ends[0].back(), ends[1].front());
    EXPECT_EQ(s.verticesMerged, 1u);
    EXPECT_EQ(violations(near) + violations(ends), 0u);
}

TEST(RiverCleaning, SelfCrossingIsSplit) {
    const RiverLines in = {{{10, 10}, {90, 90}, {90, 10}, {10, 90}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s);
    EXPECT_EQ(s.selfCrossings, 1u);
    ASSERT_EQ(out.size(), 3u);
    EXPECT_EQ(out[0], (RiverLine{{10, 10}, {50, 50}}));
    EXPECT_EQ(out[1], (RiverLine{{50, 50}, {90, 90}, {90, 10}, {50, 50}}));
    EXPECT_EQ(out[2], (RiverLine{{50, 50}, {10, 90}}));
    EXPECT_EQ(violations(out), 0u);
}

TEST(RiverCleaning, DuplicatesAndZeroLengthSegments) {
    const RiverLines in = {{{10, 10}, {10, 10}, {20, 20}, {20.0004, 20.0002}, {30, 10}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s);
    EXPECT_EQ(s.duplicateVertices, 1u);
    EXPECT_EQ(s.zeroLengthSegments, 1u);
    EXPECT_EQ(out, (RiverLines{{{10, 10}, {20, 20}, {30, 10}}}));
    // A line that collapses to one point is dropped.
    const RiverLines dot = clean({{{40, 40}, {40, 40}, {40.0002, 40}}}, s);
    EXPECT_TRUE(dot.empty());
}

TEST(RiverCleaning, ThreeDimensionalInputWithRepeatedPoints) {
    // Lines converted from 3D data often repeat each (x, y) with a different z.
    const RiverLines in = {{{10, 10}, {10, 10}, {30, 30}, {30, 30}, {50, 10}, {50, 10}},
                           {{50, 10}, {50, 10}, {70, 30}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s);
    EXPECT_EQ(s.duplicateVertices, 4u);
    EXPECT_EQ(out, (RiverLines{{{10, 10}, {30, 30}, {50, 10}}, {{50, 10}, {70, 30}}}));
}

TEST(RiverCleaning, CollinearOverlapKeptOnce) {
    // Policy: the overlap stays in the earlier line; the later line loses the overlapped piece.
    const RiverLines in = {{{10, 50}, {60, 50}}, {{40, 50}, {90, 50}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s, 0);
    EXPECT_EQ(out, (RiverLines{{{10, 50}, {40, 50}, {60, 50}}, {{60, 50}, {90, 50}}}));
    EXPECT_EQ(s.overlapsDropped, 1u);
    EXPECT_EQ(violations(out), 0u);
    // A line retracing its own segment.
    const RiverLines back = clean({{{10, 10}, {50, 10}, {30, 10}, {30, 40}}}, s, 0);
    EXPECT_EQ(back, (RiverLines{{{10, 10}, {30, 10}, {50, 10}}, {{30, 10}, {30, 40}}}));
    EXPECT_EQ(violations(back), 0u);
}

TEST(RiverCleaning, ClippedToTheValidDem) {
    DemGrid dem = makeDem();
    dem.z[2 * 11 + 8] = std::numeric_limits<float>::quiet_NaN();  // cell centred at (80, 80)
    const RiverLines in = {
        {{200, 200}, {300, 300}},                             // outside: dropped
        {{10, 50}, {50, 50}, {150, 50}, {90, 60}, {80, 70}},  // leaves and re-enters
        {{60, 90}, {70, 85}, {85, 80}, {90, 75}, {95, 70}},   // touches the nodata cell
    };
    RiverCleaningStats s;
    const RiverLines out = cleanRivers(in, dem, {}, s);
    // The second line is cut where it leaves the DEM (x = 100, the last column of centres) and
    // continues from where it comes back; the third ends at the edge of the nodata cell's
    // squares (70 < x < 90 and 70 < y < 90 interpolate it), which (70, 85) and (90, 75) are on.
    EXPECT_EQ(out, (RiverLines{{{10, 50}, {50, 50}, {100, 50}},
                               {{100, 58.333}, {90, 60}, {80, 70}},
                               {{60, 90}, {70, 85}},
                               {{90, 75}, {95, 70}}}));
    // (85, 80) interpolates between the centres (80, 80) (nodata) and (90, 80).
    EXPECT_EQ(s.verticesOutsideDem, 2u + 1u + 1u);
    EXPECT_EQ(s.segmentsCut, 4u);
    EXPECT_EQ(violations(out), 0u);
}

// Segments over a void are cut at its edge, not dropped with their vertices: a 2-vertex river
// across a nodata lake keeps both banks' parts, a segment whose ends are both off the DEM keeps
// the part that crosses it, and one from a vertex in the lake keeps the part up to the shore.
TEST(RiverCleaning, SegmentsCutAtTheEdgeOfAVoid) {
    DemGrid dem = makeDem();
    for (int r = 4; r <= 6; ++r)  // centres x, y in [40, 60]: nodata
        for (int c = 4; c <= 6; ++c)
            dem.z[std::size_t(r) * 11 + std::size_t(c)] = std::numeric_limits<float>::quiet_NaN();
    // Interpolation is NaN for 30 < x < 70 and 30 < y < 70.
    const RiverLines in = {
        {{5, 50}, {95, 50}},     // across the lake
        {{-50, 20}, {150, 20}},  // both ends off the DEM, across it
        {{50, 50}, {50, 95}},    // from the middle of the lake to the north
    };
    RiverCleaningStats s;
    const RiverLines out = cleanRivers(in, dem, {}, s);
    EXPECT_EQ(out, (RiverLines{{{5, 50}, {30, 50}},
                               {{70, 50}, {95, 50}},
                               {{0, 20}, {100, 20}},
                               {{50, 70}, {50, 95}}}));
    EXPECT_EQ(s.verticesOutsideDem, 3u);
    EXPECT_EQ(s.segmentsCut, 3u);
    EXPECT_EQ(violations(out), 0u);
}

TEST(RiverCleaning, ShortLinesDropped) {
    const RiverLines in = {
        {{10, 10}, {13, 10}}, {{20, 20}, {30, 20}}, {{40, 40}, {42, 40}, {45, 40}}};
    RiverCleaningStats s;
    const RiverLines out = clean(in, s, 0.5, 5.0);
    EXPECT_EQ(out, (RiverLines{{{20, 20}, {30, 20}}, {{40, 40}, {42, 40}, {45, 40}}}));
    EXPECT_EQ(s.shortLinesDropped, 1u);
    EXPECT_EQ(s.outputLines, 2u);
    EXPECT_EQ(s.outputVertices, 5u);
}

TEST(RiverCleaning, RandomSpaghettiBecomesPlanarAndDeterministic) {
    const RiverLines in = spaghetti(7, 80, 1, 99);
    EXPECT_GT(violations(in), 100u);
    RiverCleaningStats s;
    const RiverLines out = clean(in, s);
    std::string first;
    EXPECT_EQ(violations(out, &first), 0u) << first;
    EXPECT_GT(s.crossingsSplit, 500u);
    EXPECT_EQ(s.unresolvedDropped, 0u) << describe(s);
    EXPECT_FALSE(describe(s).empty());
    RiverCleaningStats s2;
    EXPECT_TRUE(clean(in, s2) == out);  // bit-identical
    EXPECT_EQ(s2.crossingsSplit, s.crossingsSplit);
    // Without snapping (which may still find endpoints near other lines), cleaning is idempotent.
    RiverCleaningStats s3;
    EXPECT_TRUE(clean(out, s3, 0) == out) << describe(s3);
}

TEST(RiverCleaning, RandomSpaghettiManySeeds) {
    for (std::uint64_t seed = 100; seed < 110; ++seed) {
        RiverCleaningStats s;
        const RiverLines out = clean(spaghetti(seed, 40, 1, 99), s, 2.0);
        std::string first;
        EXPECT_EQ(violations(out, &first), 0u) << "seed " << seed << ": " << first;
    }
}

TEST(RiverCleaning, JacksboroNetworksArePlanar) {
    DemGrid dem;
    std::string err;
    const std::string dir = UNILOD_ASSETS_DIR;
    ASSERT_TRUE(loadDem(dir + "/jacksboro_dem.tif", {}, dem, err)) << err;
    RiverLines grass, gshhg;
    ASSERT_TRUE(loadRivers(dir + "/jacksboro_rivers_grass.geojson", {}, dem.wkt, grass, err))
        << err;
    ASSERT_TRUE(loadRivers(dir + "/jacksboro_rivers_gshhg.geojson", {}, dem.wkt, gshhg, err))
        << err;
    RiverLines both = grass;
    both.insert(both.end(), gshhg.begin(), gshhg.end());
    RiverCleaningOptions o;
    o.snapTolerance = 0.7;  // ~1 % of the cell size
    for (const RiverLines* in : {&grass, &gshhg, &both}) {
        RiverCleaningStats s;
        const RiverLines out = cleanRivers(*in, dem, o, s);
        std::string first;
        EXPECT_EQ(violations(out, &first), 0u) << first;
        EXPECT_GT(out.size(), 0u);
        EXPECT_EQ(s.unresolvedDropped, 0u) << describe(s);
        // Every vertex lies on the valid DEM.
        for (const RiverLine& l : out)
            for (const XY& p : l)
                ASSERT_TRUE(std::isfinite(dem.sample(p.x, p.y)));
    }
    // The GRASS network is already clean apart from the clip: its junctions survive.
    RiverCleaningStats s;
    const RiverLines out = cleanRivers(grass, dem, o, s);
    EXPECT_EQ(s.crossingsSplit, 0u) << describe(s);
    EXPECT_GE(out.size(), grass.size() / 2);
}

TEST(RiverCleaning, SyntheticNetworkKeepsItsJunctions) {
    SyntheticOptions so;
    so.targetPoints = 20000;
    so.seed = 3;
    const SyntheticData data = generateSyntheticData(so);
    ASSERT_GT(data.rivers.size(), 2u);
    RiverCleaningStats s;
    RiverCleaningOptions o;
    o.snapTolerance = 0.3;
    const RiverLines out = cleanRivers(data.rivers, data.dem, o, s);
    std::string first;
    EXPECT_EQ(violations(out, &first), 0u) << first;
    // The generator promises no crossings: nothing but the rounding to 1 mm may change.
    EXPECT_EQ(s.crossingsSplit, 0u) << describe(s);
    EXPECT_EQ(s.verticesOutsideDem, 0u) << describe(s);
    EXPECT_EQ(out.size(), data.rivers.size()) << describe(s);
}

TEST(RiverCleaning, CdtAcceptsTheCleanedNetwork) {
    const DemGrid dem = makeDem();
    const RiverLines in = spaghetti(11, 40, 2, 98);
    std::string error;
    Cdt before;
    EXPECT_FALSE(buildCdt(buildPointSet(dem, in, {}), {}, before, error));
    RiverCleaningStats s;
    const RiverLines out = cleanRivers(in, dem, {}, s);
    Cdt after;
    EXPECT_TRUE(buildCdt(buildPointSet(dem, out, {}), {}, after, error)) << error;
    // The simple crossing too.
    const RiverLines x = {{{10, 10}, {90, 50}}, {{20, 80}, {60, 0}}};
    EXPECT_FALSE(buildCdt(buildPointSet(dem, x, {}), {}, before, error));
    EXPECT_TRUE(buildCdt(buildPointSet(dem, cleanRivers(x, dem, {}, s), {}), {}, after, error))
        << error;
}
