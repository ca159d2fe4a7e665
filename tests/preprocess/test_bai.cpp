// BAI (paper §2.2, Eq. 1-2, Table 1) against closed-form values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>

#include "bai.h"

using namespace unilod;

namespace {

constexpr double kPi = std::numbers::pi;

struct Line {
    PointSet set;
    void add(double x, double y, double z = 700.0) {
        set.points.push_back({x, y, z, PointKind::River, false});
        if (set.rivers.empty()) set.rivers.emplace_back();
        set.rivers[0].push_back(static_cast<PointId>(set.points.size() - 1));
    }
    std::vector<Bend> bends(int row = -1) const {
        const BaiTable t = BaiTable::paperDefault();
        return computeBends(set.points, set.rivers[0], Quantizer::forPoints(set.points), t, row);
    }
};

// Arc of a circle centred (cx, cy) with radius r from angle a0 to a1 in n segments, skipping the
// first vertex when `skipFirst`.
void addArc(Line& l, double cx, double cy, double r, double a0, double a1, int n, bool skipFirst) {
    for (int i = skipFirst ? 1 : 0; i <= n; ++i) {
        const double a = a0 + (a1 - a0) * i / n;
        l.add(cx + r * std::cos(a), cy + r * std::sin(a));
    }
}

// Closed forms for an arc of pi radians sampled in n chords: chord-polygon length and the area
// between the polyline and the diameter (a fan of n isosceles triangles).
double arcLength(double r, int n) {
    return n * 2 * r * std::sin(kPi / (2 * n));
}
double arcArea(double r, int n) {
    return n * 0.5 * r * r * std::sin(kPi / n);
}

double bai(double w, double l, double s, double lAvg, double sAvg) {
    const double s0 = kPi * w * w / 4;
    return (s / s0) * (l / w) * (l / lAvg) * (s / sAvg);
}

void expectBend(const Bend& b, std::uint32_t first, std::uint32_t last, double w, double l,
                double s, double lAvg, double sAvg) {
    EXPECT_EQ(b.first, first);
    EXPECT_EQ(b.last, last);
    EXPECT_NEAR(b.width, w, 1e-9 * w);
    EXPECT_NEAR(b.length, l, 1e-9 * l);
    EXPECT_NEAR(b.area, s, 1e-9 * s);
    const double expected = bai(w, l, s, lAvg, sAvg);
    EXPECT_NEAR(b.bai, expected, 1e-9 * expected);
}

}  // namespace

TEST(Bai, StraightLineHasNoBends) {
    Line l;
    for (int i = 0; i < 10; ++i)
        l.add(100.0 * i, 50.0 * i);  // exactly collinear on the grid
    EXPECT_TRUE(l.bends().empty());
    const auto f = baiFactors(l.set, BaiTable::paperDefault(), 2);
    for (float v : f)
        EXPECT_EQ(v, 1.0f);
}

TEST(Bai, TwoPointLineHasNoBends) {
    Line l;
    l.add(0, 0);
    l.add(10, 10);
    EXPECT_TRUE(l.bends().empty());
}

TEST(Bai, Semicircle) {
    const double r = 1000;
    const int n = 32;
    Line l;
    addArc(l, 0, 0, r, kPi, 0, n, false);  // clockwise over the top: every turn negative
    const auto bends = l.bends(BaiTable::paperDefault().findRow(500));
    ASSERT_EQ(bends.size(), 1u);
    const double w = 2 * r, len = arcLength(r, n), s = arcArea(r, n);
    expectBend(bends[0], 0, n, w, len, s, len, s);
    // One bend: l_avg = L and s_avg = S, so BAI = e * f = (S / S0) (L / W) ~ (1/2)(pi/2).
    EXPECT_NEAR(bends[0].bai, kPi / 4, 0.01);
    // z = 700 m: low mountainous class, row 500 m -> C2 = 0.5.
    EXPECT_DOUBLE_EQ(bends[0].c, 0.5);
    EXPECT_DOUBLE_EQ(bends[0].meanZ, 700.0);
    const auto f =
        baiFactors(l.set, BaiTable::paperDefault(), BaiTable::paperDefault().findRow(500));
    for (float v : f)
        EXPECT_FLOAT_EQ(v, static_cast<float>(0.5 * bends[0].bai + 1));
}

TEST(Bai, SCurveOfTwoArcs) {
    // Arc 1 (radius 1000, 16 chords) turns right, arc 2 (radius 400, 24 chords) turns left; they
    // meet tangentially at (2000, 0). There the turn is (pi/24 - pi/16)/2 < 0, still arc 1's
    // sign, so the turning point is that vertex (position 16).
    const double r1 = 1000, r2 = 400;
    const int n1 = 16, n2 = 24;
    Line l;
    addArc(l, r1, 0, r1, kPi, 0, n1, false);
    addArc(l, 2 * r1 + r2, 0, r2, kPi, 2 * kPi, n2, true);
    const auto bends = l.bends();
    ASSERT_EQ(bends.size(), 2u);
    const double l1 = arcLength(r1, n1), l2 = arcLength(r2, n2);
    const double s1 = arcArea(r1, n1), s2 = arcArea(r2, n2);
    const double lAvg = (l1 + l2) / 2, sAvg = (s1 + s2) / 2;
    expectBend(bends[0], 0, n1, 2 * r1, l1, s1, lAvg, sAvg);
    expectBend(bends[1], n1, n1 + n2, 2 * r2, l2, s2, lAvg, sAvg);
    EXPECT_GT(bends[0].bai, bends[1].bai);  // the bigger bend dominates both ratios

    // The turning point belongs to both bends and takes the larger factor.
    const BaiTable t = BaiTable::paperDefault();
    const int row = t.findRow(1000);  // C2 = 0.75
    const auto f = baiFactors(l.set, t, row);
    EXPECT_FLOAT_EQ(f[0], static_cast<float>(0.75 * bends[0].bai + 1));
    EXPECT_FLOAT_EQ(f[n1], static_cast<float>(0.75 * bends[0].bai + 1));
    EXPECT_FLOAT_EQ(f[n1 + 1], static_cast<float>(0.75 * bends[1].bai + 1));
}

TEST(Bai, CollinearRunsStayInsideBends) {
    // Lead-in (0,-300) -> (0,0) in 3 collinear steps, arc 1 (right turns, r = 1000, 16 chords)
    // to (2000,0), a straight run down to (2000,-400) in 4 collinear steps, arc 2 (left turns,
    // r = 400, 24 chords). The sign changes from the vertex (2000,0) (position 19) to (2000,-400)
    // (position 23): the turning point is the middle vertex (2000,-200) (position 21).
    const double r1 = 1000, r2 = 400;
    const int n1 = 16, n2 = 24;
    Line l;
    l.add(0, -300);
    l.add(0, -200);
    l.add(0, -100);
    addArc(l, r1, 0, r1, kPi, 0, n1, false);
    for (int k = 1; k <= 3; ++k)
        l.add(2000, -100.0 * k);
    addArc(l, 2 * r1 + r2, -400, r2, kPi, 2 * kPi, n2, false);
    const auto bends = l.bends();
    ASSERT_EQ(bends.size(), 2u);
    const double w1 = std::hypot(2000, 100), len1 = 300 + arcLength(r1, n1) + 200,
                 s1 = arcArea(r1, n1) + (300 + 200) / 2.0 * 2000;
    const double w2 = std::hypot(2 * r2, 200), len2 = 200 + arcLength(r2, n2),
                 s2 = arcArea(r2, n2) + 0.5 * 200 * 2 * r2;
    const double lAvg = (len1 + len2) / 2, sAvg = (s1 + s2) / 2;
    expectBend(bends[0], 0, 21, w1, len1, s1, lAvg, sAvg);
    expectBend(bends[1], 21, 47, w2, len2, s2, lAvg, sAvg);  // 3 + 17 + 3 + 25 vertices
}

TEST(Bai, ZigZagMakesOneTurningPointPerSignChange) {
    Line l;
    const double ys[] = {0, 10, 0, 10, 0, 10};
    for (int i = 0; i < 6; ++i)
        l.add(10.0 * i, ys[i]);
    // Signs at positions 1..4: -, +, -, +  -> turning points 1, 2, 3 -> 4 bends.
    const auto bends = l.bends();
    ASSERT_EQ(bends.size(), 4u);
    EXPECT_EQ(bends[0].first, 0u);
    EXPECT_EQ(bends[0].last, 1u);
    EXPECT_EQ(bends[3].first, 3u);
    EXPECT_EQ(bends[3].last, 5u);
    EXPECT_EQ(bends[0].bai, 0.0);  // a single segment encloses no area
    EXPECT_GT(bends[3].bai, 0.0);
}

TEST(BaiTable, PaperDefaultAndClasses) {
    const BaiTable t = BaiTable::paperDefault();
    ASSERT_EQ(t.rows.size(), 5u);
    const int r = t.findRow(1000);
    ASSERT_GE(r, 0);
    EXPECT_EQ(t.findRow(300), -1);
    EXPECT_DOUBLE_EQ(t.constantFor(r, -20), 2.0);    // below sea level: first class
    EXPECT_DOUBLE_EQ(t.constantFor(r, 499.9), 2.0);  // flat
    EXPECT_DOUBLE_EQ(t.constantFor(r, 500), 0.75);   // low mountainous
    EXPECT_DOUBLE_EQ(t.constantFor(r, 2999), 0.75);  // high mountainous
    EXPECT_DOUBLE_EQ(t.constantFor(t.findRow(1500), 700), 1.0);
    EXPECT_DOUBLE_EQ(t.constantFor(t.findRow(100), 4500), 0.05);  // above 3000: last class
}

namespace {
std::string writeTemp(const std::string& name, const std::string& text) {
    const std::string path = testing::TempDir() + name;
    std::ofstream(path) << text;
    return path;
}
}  // namespace

TEST(BaiTable, LoadsFromFile) {
    const auto path = writeTemp("bai_ok.txt",
                                "# custom table\naltitudes 0 200\n"
                                "50 3 1   # comment\n\n400 4 2\n");
    BaiTable t;
    std::string err;
    ASSERT_TRUE(BaiTable::load(path, t, err)) << err;
    ASSERT_EQ(t.rows.size(), 2u);
    EXPECT_DOUBLE_EQ(t.constantFor(t.findRow(50), 100), 3);
    EXPECT_DOUBLE_EQ(t.constantFor(t.findRow(400), 250), 2);

    // A UTF-8 byte order mark before the first line is not text ("expected 'altitudes'" before).
    const auto bom = writeTemp("bai_bom.txt",
                               "\xEF\xBB\xBF"
                               "altitudes 0 200\n50 3 1\n");
    ASSERT_TRUE(BaiTable::load(bom, t, err)) << err;
    EXPECT_EQ(t.rows.size(), 1u);
}

TEST(BaiTable, RejectsBadFiles) {
    struct Case {
        const char* text;
        const char* expect;
    };
    const Case cases[] = {
        {"50 1 1\n", ":1: expected 'altitudes"},
        {"altitudes 0 500\n50 1\n", ":2: row 50 has 1 constants, expected 2"},
        {"altitudes 500 0\n", ":1: altitude class bounds must be strictly ascending"},
        {"altitudes 0 500\n50 1 x\n", ":2: 'x' is not a number"},
        {"altitudes 0 500\n50 1 0x10\n", ":2: '0x10' is not a number"},  // strtod read 16
        {"altitudes 0 500\n0x32 1 1\n", ":2: '0x32' is not a threshold in metres"},
        {"altitudes 0 500\n50 1 -1\n", ":2: bending adjustment constants must be >= 0"},
        {"altitudes 0 500\n50 1 1\n40 1 1\n", ":3: thresholds must be strictly ascending"},
        {"# nothing\n", "needs an 'altitudes' line"},
    };
    int i = 0;
    for (const Case& c : cases) {
        const auto path = writeTemp("bai_bad" + std::to_string(i++) + ".txt", c.text);
        BaiTable t;
        std::string err;
        EXPECT_FALSE(BaiTable::load(path, t, err)) << c.text;
        EXPECT_NE(err.find(path), std::string::npos) << err;
        EXPECT_NE(err.find(c.expect), std::string::npos) << err;
    }
    BaiTable t;
    std::string err;
    EXPECT_FALSE(BaiTable::load(testing::TempDir() + "does_not_exist.txt", t, err));
    EXPECT_NE(err.find("cannot open"), std::string::npos);
}

// The greedy order's keys by threshold (bai.h BaiKeys::byThreshold) against a brute-force
// oracle: the smallest threshold t on a fine grid at which the paper's test d (C(t) BAI + 1) <= t
// holds, C(t) interpolated here independently from the table's rows.
namespace {

double tableC(const BaiTable& t, std::size_t cls, double threshold) {
    const auto& rows = t.rows;
    if (threshold <= rows.front().threshold) return rows.front().c[cls];
    for (std::size_t r = 0; r + 1 < rows.size(); ++r) {
        const double t0 = rows[r].threshold, t1 = rows[r + 1].threshold;
        if (threshold <= t1) {
            const double a = (threshold - t0) / (t1 - t0);
            return rows[r].c[cls] + a * (rows[r + 1].c[cls] - rows[r].c[cls]);
        }
    }
    return rows.back().c[cls];
}

// Smallest accepting t on a grid of `step` (the true key lies in (result - step, result]).
double bruteKey(const BaiTable& t, std::size_t cls, double bai, double d, double step) {
    for (double x = 0;; x += step) {
        if (d * (tableC(t, cls, x) * bai + 1) <= x) return x;
    }
}

}  // namespace

TEST(BaiKeys, ByThresholdIsTheSmallestAcceptingThreshold) {
    Line l;
    addArc(l, 0, 0, 1000, kPi, 0, 32, false);  // z = 700 m: the low mountainous class
    const BaiTable table = BaiTable::paperDefault();
    const double b = l.bends().at(0).bai;
    ASSERT_GT(b, 0.5);
    const BaiKeys keys = BaiKeys::byThreshold(l.set, table);
    ASSERT_EQ(keys.size(), l.set.points.size());
    const std::size_t cls = table.classOf(700);
    ASSERT_EQ(cls, 1u);
    // Below the first row (100 m) C = 0.05; above the last (1500 m) C = 1.
    EXPECT_NEAR(keys.key(5, 10.0), 10.0 * (0.05 * b + 1), 1e-9);
    EXPECT_NEAR(keys.key(5, 2000.0), 2000.0 * (1.0 * b + 1), 1e-6);
    double last = 0;
    for (double d = 0.5; d < 1600; d += 7.25) {
        const double k = keys.key(5, d);
        EXPECT_GE(k, last) << "d = " << d;  // non-decreasing in d
        last = k;
        const double step = 0.01;
        const double oracle = bruteKey(table, cls, b, d, step);
        EXPECT_LE(k, oracle + 1e-9) << "d = " << d;
        EXPECT_GT(k, oracle - step - 1e-9) << "d = " << d;
        // The paper's test accepts the key itself.
        EXPECT_LE(d * (tableC(table, cls, k) * b + 1), k * (1 + 1e-12)) << "d = " << d;
    }
    // Every vertex is in the bend; the old fixed row (500 m: C = 0.5) keys d * (0.5 BAI + 1).
    const BaiKeys fixed(baiFactors(l.set, table, table.findRow(500)));
    EXPECT_FLOAT_EQ(float(fixed.key(5, 100.0)), float(100.0 * (0.5 * b + 1)));
    EXPECT_LT(keys.key(5, 50.0), fixed.key(5, 50.0));  // C = 0.05 at 100 m, not 0.5
}

TEST(BaiKeys, StepsInTheTableAreCrossedWhereTheTestFailsThroughout) {
    // C jumps from 0 to 100 between 10 m and 200 m: for d = 50 and BAI ~ 0.79 no threshold
    // below 200 m accepts (the pseudo distance grows faster than t), so the key is past the
    // last row: d (100 BAI + 1).
    BaiTable table;
    table.classLowerBounds = {0};
    table.rows = {{10, {0}}, {200, {100}}};
    Line l;
    addArc(l, 0, 0, 1000, kPi, 0, 32, false);
    const double b = l.bends(-1).at(0).bai;
    const BaiKeys keys = BaiKeys::byThreshold(l.set, table);
    EXPECT_NEAR(keys.key(3, 50.0), 50.0 * (100 * b + 1), 1e-6);
    EXPECT_NEAR(keys.key(3, 5.0), 5.0, 1e-12);  // C = 0 below the first row: the error itself
    EXPECT_NEAR(keys.key(3, 50.0), bruteKey(table, 0, b, 50.0, 0.01), 0.01);
}

TEST(BaiKeys, PointsOutsideBendsAndDemPointsKeyTheirError) {
    Line l;
    for (int i = 0; i < 10; ++i)
        l.add(100.0 * i, 50.0 * i);  // straight: no bend
    l.set.points.push_back({5, 500, 700, PointKind::Dem, false});
    const BaiKeys keys = BaiKeys::byThreshold(l.set, BaiTable::paperDefault());
    for (std::uint32_t v = 0; v < l.set.points.size(); ++v)
        EXPECT_EQ(keys.key(v, 42.5), 42.5);
    EXPECT_TRUE(BaiKeys().empty());
    EXPECT_EQ(BaiKeys().key(0, 3.0), 3.0);
}

TEST(BaiKeys, ExtremeTableConstantsGiveOrderedKeys) {
    // Finite but extreme constants (a --bai-table file may hold them): no NaN key, the order in
    // d kept, a zero error stays zero.
    BaiTable table;
    table.classLowerBounds = {0};
    table.rows = {{0, {-1e308}}, {1, {1e308}}, {1e300, {1e308}}};
    Line l;
    addArc(l, 0, 0, 1000, kPi, 0, 32, false);
    const BaiKeys keys = BaiKeys::byThreshold(l.set, table);
    double last = 0;
    for (double d : {0.0, 1e-9, 0.5, 1.0, 10.0, 1e6}) {
        const double k = keys.key(4, d);
        EXPECT_FALSE(std::isnan(k)) << d;
        EXPECT_GE(k, last) << d;
        last = k;
    }
    EXPECT_EQ(keys.key(4, 0.0), 0.0);
    const BaiKeys fixed(std::vector<float>(l.set.points.size(), HUGE_VALF));
    EXPECT_EQ(fixed.key(4, 0.0), 0.0);
}
