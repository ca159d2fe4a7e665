// Bending Adjustment Index (paper §2.2, Eq. 1-2, Table 1). See bai.h for the definitions.
//
// Turning points (paper §2.2.1, after Shen 2009): the turning angle at interior vertex i has the
// sign of the exact orientation of (v[i-1], v[i], v[i+1]): + counter-clockwise, - clockwise,
// 0 collinear. Collinear vertices carry no sign and never make a turning point, so collinear runs
// stay inside the bend around them. Where the sign changes between vertex i (last of the old
// sign) and vertex j (first of the new sign), the turning point is vertex floor((i + j) / 2):
// the inflection vertex itself when collinear vertices lie between, and vertex i when the
// inflection falls inside segment (i, i+1). Bends run between consecutive turning points, the
// first from the polyline's start and the last to its end, so every vertex lies in a bend (paper:
// "all of the curve points are included in bends"); a turning point belongs to both of its bends.
//
// Per bend, in the horizontal plane: W = |v_a v_b|, L = sum of segment lengths, S = |area| of the
// polygon v_a..v_b closed by the chord, S0 = pi (W/2)^2, and
//     BAI = (S/S0) (L/W) (L/l_avg) (S/s_avg) = L^2 S^2 / (S0 W l_avg s_avg).
// Degenerate bends (W = 0, a closed loop) and rivers whose bends have no area get BAI = 0:
// the cleaning stage removes self-touching rivers, so this only guards the arithmetic.
#include "bai.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>

#include "atomicfile.h"
#include "numtext.h"

namespace unilod {

BaiTable BaiTable::paperDefault() {
    BaiTable t;
    t.classLowerBounds = {0.0, 500.0, 1000.0};
    t.rows = {{100, {0.1, 0.05, 0.05}},
              {200, {0.1, 0.05, 0.05}},
              {500, {1.0, 0.5, 0.5}},
              {1000, {2.0, 0.75, 0.75}},
              {1500, {2.0, 1.0, 1.0}}};
    return t;
}

// File format (whitespace separated, '#' starts a comment):
//     altitudes 0 500 1000          lower bounds of the altitude classes, ascending
//     100  0.1 0.05 0.05            threshold (m) and one C per class; thresholds ascending
bool BaiTable::load(const std::string& path, BaiTable& table, std::string& error) {
    if (std::string why; !format::checkInputFile(path, false, why)) {
        error = path + ": " + why;
        return false;
    }
    std::ifstream in(path);
    if (!in) {
        error = path + ": cannot open BAI table";
        return false;
    }
    BaiTable t;
    std::string line;
    int lineNo = 0;
    bool haveClasses = false;
    auto fail = [&](const std::string& what) {
        error = path + ":" + std::to_string(lineNo) + ": " + what;
        return false;
    };
    while (std::getline(in, line)) {
        ++lineNo;
        // A UTF-8 byte order mark (editors on Windows write one) is not part of the text.
        if (lineNo == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
        if (auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
        std::istringstream ls(line);
        std::string first;
        if (!(ls >> first)) continue;
        std::vector<double> values;
        std::string tok;
        while (ls >> tok) {
            double v = 0;  // the shared number syntax: no hexadecimal, finite
            if (!format::parseFiniteNumber(tok, v)) return fail("'" + tok + "' is not a number");
            values.push_back(v);
        }
        if (first == "altitudes") {
            if (haveClasses) return fail("second 'altitudes' line");
            if (values.empty()) return fail("'altitudes' needs at least one class bound");
            if (!std::is_sorted(values.begin(), values.end()) ||
                std::adjacent_find(values.begin(), values.end()) != values.end()) {
                return fail("altitude class bounds must be strictly ascending");
            }
            t.classLowerBounds = values;
            haveClasses = true;
            continue;
        }
        if (!haveClasses) return fail("expected 'altitudes <bounds...>' before the rows");
        double threshold = 0;
        if (!format::parseFiniteNumber(first, threshold) || threshold < 0) {
            return fail("'" + first + "' is not a threshold in metres");
        }
        if (values.size() != t.classLowerBounds.size()) {
            return fail("row " + first + " has " + std::to_string(values.size()) +
                        " constants, expected " + std::to_string(t.classLowerBounds.size()));
        }
        for (double c : values) {
            if (c < 0) return fail("bending adjustment constants must be >= 0");
        }
        if (!t.rows.empty() && threshold <= t.rows.back().threshold) {
            return fail("thresholds must be strictly ascending");
        }
        t.rows.push_back({threshold, values});
    }
    if (!haveClasses || t.rows.empty()) {
        error = path + ": BAI table needs an 'altitudes' line and at least one row";
        return false;
    }
    table = std::move(t);
    return true;
}

int BaiTable::findRow(double threshold) const {
    for (std::size_t i = 0; i < rows.size(); ++i) {
        if (rows[i].threshold == threshold) return static_cast<int>(i);
    }
    return -1;
}

std::size_t BaiTable::classOf(double altitude) const {
    std::size_t cls = 0;
    while (cls + 1 < classLowerBounds.size() && altitude >= classLowerBounds[cls + 1])
        ++cls;
    return cls;
}

double BaiTable::constantFor(int row, double altitude) const {
    return rows.at(static_cast<std::size_t>(row)).c[classOf(altitude)];
}

std::vector<Bend> computeBends(const std::vector<Point>& points, const Polyline& line,
                               const Quantizer& quantizer, const BaiTable& table, int row) {
    std::vector<Bend> bends;
    const std::size_t m = line.size();
    if (m < 3) return bends;

    // Split positions: 0, the turning points, m - 1.
    std::vector<std::uint32_t> splits{0};
    int lastSign = 0;
    std::size_t lastPos = 0;
    GridPoint prev = quantizer(points[line[0]]), cur = quantizer(points[line[1]]);
    for (std::size_t i = 1; i + 1 < m; ++i) {
        const GridPoint next = quantizer(points[line[i + 1]]);
        const int s = orient2d(prev, cur, next);
        if (s != 0) {
            if (lastSign != 0 && s != lastSign) {
                splits.push_back(static_cast<std::uint32_t>((lastPos + i) / 2));
            }
            lastSign = s;
            lastPos = i;
        }
        prev = cur;
        cur = next;
    }
    if (lastSign == 0) return bends;  // no turning at all: a straight line has no bends
    splits.push_back(static_cast<std::uint32_t>(m - 1));

    double sumL = 0, sumS = 0;
    for (std::size_t b = 0; b + 1 < splits.size(); ++b) {
        Bend bend;
        bend.first = splits[b];
        bend.last = splits[b + 1];
        const Point& a = points[line[bend.first]];
        const Point& z = points[line[bend.last]];
        bend.width = std::hypot(z.x - a.x, z.y - a.y);
        double twiceArea = 0, sumZ = 0;
        for (std::uint32_t k = bend.first; k <= bend.last; ++k) {
            const Point& p = points[line[k]];
            sumZ += p.z;
            if (k < bend.last) {
                const Point& q = points[line[k + 1]];
                bend.length += std::hypot(q.x - p.x, q.y - p.y);
                // Shoelace relative to the first vertex (closing edge back to it adds nothing).
                twiceArea += (p.x - a.x) * (q.y - a.y) - (q.x - a.x) * (p.y - a.y);
            }
        }
        bend.area = std::fabs(twiceArea) / 2;
        bend.meanZ = sumZ / double(bend.last - bend.first + 1);
        bend.c = row >= 0 ? table.constantFor(row, bend.meanZ) : 0.0;
        sumL += bend.length;
        sumS += bend.area;
        bends.push_back(bend);
    }
    const double lAvg = sumL / double(bends.size()), sAvg = sumS / double(bends.size());
    for (Bend& bend : bends) {
        const double s0 = std::numbers::pi * bend.width * bend.width / 4;
        if (bend.width > 0 && lAvg > 0 && sAvg > 0) {
            bend.bai = (bend.area / s0) * (bend.length / bend.width) * (bend.length / lAvg) *
                       (bend.area / sAvg);
        }
    }
    return bends;
}

std::vector<float> baiFactors(const PointSet& set, const BaiTable& table, int row) {
    std::vector<float> factor(set.points.size(), 1.0f);
    const Quantizer quantizer = Quantizer::forPoints(set.points);
    for (const Polyline& line : set.rivers) {
        for (const Bend& bend : computeBends(set.points, line, quantizer, table, row)) {
            const auto f = static_cast<float>(bend.c * bend.bai + 1.0);
            for (std::uint32_t k = bend.first; k <= bend.last; ++k) {
                float& slot = factor[line[k]];
                if (set.points[line[k]].kind == PointKind::River) slot = std::max(slot, f);
            }
        }
    }
    return factor;
}

BaiKeys BaiKeys::byThreshold(const PointSet& set, const BaiTable& table) {
    BaiKeys k;
    const std::size_t n = set.points.size();
    for (const BaiTable::Row& r : table.rows)
        k.thresholds_.push_back(r.threshold);
    const std::size_t classes = table.rows.empty() ? 0 : table.rows.front().c.size();
    k.c_.assign(classes, {});
    for (std::size_t j = 0; j < classes; ++j) {
        for (const BaiTable::Row& r : table.rows)
            k.c_[j].push_back(r.c[j]);
    }
    // Per point, the largest BAI of its bends in each class (collected, then grouped).
    std::vector<std::pair<std::uint32_t, Entry>> all;
    if (classes > 0) {
        const Quantizer quantizer = Quantizer::forPoints(set.points);
        for (const Polyline& line : set.rivers) {
            for (const Bend& bend : computeBends(set.points, line, quantizer, table, -1)) {
                if (!(bend.bai > 0)) continue;
                const Entry e{std::uint32_t(table.classOf(bend.meanZ)), bend.bai};
                for (std::uint32_t i = bend.first; i <= bend.last; ++i) {
                    if (set.points[line[i]].kind == PointKind::River) all.push_back({line[i], e});
                }
            }
        }
    }
    std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) {
        return a.first != b.first             ? a.first < b.first
               : a.second.cls != b.second.cls ? a.second.cls < b.second.cls
                                              : a.second.bai > b.second.bai;
    });
    k.first_.assign(n + 1, 0);
    for (std::size_t i = 0; i < all.size(); ++i) {
        if (i > 0 && all[i].first == all[i - 1].first && all[i].second.cls == all[i - 1].second.cls)
            continue;  // a smaller BAI of the same class: implied
        k.entries_.push_back(all[i].second);
        ++k.first_[all[i].first + 1];
    }
    for (std::size_t v = 0; v < n; ++v)
        k.first_[v + 1] += k.first_[v];
    return k;
}

double BaiKeys::thresholdKey(std::uint32_t point, double d) const {
    // g_e(t) = t - d * (C_e(t) * BAI_e + 1) for each entry e; the key is the smallest t >= 0
    // where every g_e >= 0. Between two row thresholds each g_e is linear, so the set where all
    // hold is an interval per piece: scan the pieces in ascending t.
    const std::uint32_t a = first_[point], b = first_[point + 1];
    const std::size_t rows = thresholds_.size();
    auto solve = [&](double t0, double t1, std::size_t r0, std::size_t r1) {
        // Piece [t0, t1] (t1 may be infinite) with C linear from row r0 at t0 to row r1 at t1
        // (r0 == r1: constant). Returns the smallest feasible t in it, or NaN.
        double lo = t0, hi = t1;
        for (std::uint32_t i = a; i < b; ++i) {
            const Entry& e = entries_[i];
            const double c0 = c_[e.cls][r0], c1 = c_[e.cls][r1];
            const double slopeC = r0 == r1 ? 0.0 : (c1 - c0) / (t1 - t0);
            // g(t) = t - d - d * BAI * (c0 + slopeC * (t - t0)) = p * t + q
            const double p = 1.0 - d * e.bai * slopeC;
            const double q = -d - d * e.bai * (c0 - slopeC * t0);
            if (p > 0) {
                lo = std::max(lo, -q / p);
            } else if (p < 0) {
                hi = std::min(hi, -q / p);
            } else if (q < 0) {
                return std::numeric_limits<double>::quiet_NaN();
            }
        }
        return lo <= hi ? lo : std::numeric_limits<double>::quiet_NaN();
    };
    if (rows == 0) return d;
    double t = solve(0.0, thresholds_.front(), 0, 0);
    for (std::size_t r = 0; std::isnan(t) && r + 1 < rows; ++r)
        t = solve(thresholds_[r], thresholds_[r + 1], r, r + 1);
    if (std::isnan(t)) t = solve(thresholds_.back(), HUGE_VAL, rows - 1, rows - 1);
    // Never below the error itself; a table of extreme constants (finite, but products that
    // overflow to inf * 0) keys the point last instead of with NaN.
    if (std::isnan(t)) return HUGE_VAL;
    return std::max(t, d);
}

}  // namespace unilod
