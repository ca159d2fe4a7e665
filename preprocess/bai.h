// Bending Adjustment Index (paper §2.2, Eq. 1-2; Table 1).
//
// For each river polyline: the turning angle at every interior vertex (sign from an exact
// orientation test), turning points where the sign changes, bends between consecutive turning
// points (and the polyline's ends). Per bend: width W (chord), length L (arc), area S (between arc
// and chord), S0 = area of the circle of diameter W, e = S/S0, f = L/W, and
//     BAI = e * f * (L / l_avg) * (S / s_avg)            (Eq. 1)
// with l_avg, s_avg the means over that polyline's bends. River point k of a bend gets the pseudo
// distance D_k = d_k * (C * BAI + 1) (Eq. 2), C from Table 1 by the bend's mean altitude class
// and a configurable simplification-threshold row.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "grid.h"
#include "points.h"

namespace unilod {

// Table 1 of the paper as data. Altitude classes are given by their lower bounds in metres
// (paper: 0, 500, 1000 -> flat, low mountainous, high mountainous); an altitude below the first
// bound uses the first class, above the last bound the last class. Each row holds C per class
// for one simplification threshold (metres).
struct BaiTable {
    std::vector<double> classLowerBounds;  // ascending
    struct Row {
        double threshold = 0;
        std::vector<double> c;  // one per class
    };
    std::vector<Row> rows;  // ascending threshold

    // The paper's Table 1.
    static BaiTable paperDefault();

    // Reads a table from a small text file (format in bai.cpp and README). Returns false and sets
    // `error` (naming the file and line) on failure.
    static bool load(const std::string& path, BaiTable& table, std::string& error);

    // Index of the row with exactly this threshold, or -1.
    int findRow(double threshold) const;
    // C for the given row and mean altitude.
    double constantFor(int row, double altitude) const;
    // The altitude class of a mean altitude (index into Row::c).
    std::size_t classOf(double altitude) const;
};

// Default simplification-threshold row: 500 m (C = 1 / 0.5 / 0.5). The middle of the paper's
// rows and of its view distances' model-error tolerances (Table 2: ~96-1449 m).
inline constexpr double kDefaultBaiRow = 500.0;

struct Bend {
    std::uint32_t first = 0, last = 0;  // vertex positions in the polyline, first < last
    double width = 0;                   // W: chord length |v_first v_last| (horizontal)
    double length = 0;                  // L: arc length along the polyline (horizontal)
    double area = 0;                    // S: |area| enclosed by the arc and the chord
    double meanZ = 0;                   // arithmetic mean of the bend's vertex altitudes
    double bai = 0;                     // Eq. 1
    double c = 0;                       // bending adjustment constant (Table 1)
};

// The bends of one polyline, with BAI filled in (l_avg, s_avg over these bends). `table`/`row`
// set Bend::c; pass row = -1 to leave c = 0. A polyline with no turning at all (straight or only
// collinear runs) has no bends. Turning signs are exact on the grid of `quantizer`.
std::vector<Bend> computeBends(const std::vector<Point>& points, const Polyline& line,
                               const Quantizer& quantizer, const BaiTable& table, int row);

// Per point factor (C * BAI + 1) of Eq. 2; 1 for points in no bend and for DEM points. A vertex
// in several bends (a turning point, or a junction of several polylines) takes the largest.
std::vector<float> baiFactors(const PointSet& set, const BaiTable& table, int row);

// How the greedy order (deletion.h) turns the error d that deleting a point causes into its key.
//  - none (default constructed): key = d.
//  - fixed factors (`build --bai-row R`: baiFactors of row R): key = d * factor, Eq. 2 with one C.
//  - by threshold (the greedy order's default): the paper compares the pseudo distance
//    d * (C * BAI + 1) with the simplification threshold t, and its Table 1 gives C per
//    threshold (0.1 / 0.05 at 100-200 m, 1 / 0.5 at 500 m, 2 / 0.75-1 at 1000-1500 m). The key
//    is the smallest threshold that accepts the deletion:
//        key = min { t >= 0 : d * (C(t) * BAI + 1) <= t },
//    C(t) the table's C for the bend's altitude class, linear in t between rows (the first row
//    below the first threshold, the last above the last). A point in several bends must pass
//    every bend's test. So a deletion at a running error e is one the paper's own test accepts at
//    a threshold of e, instead of at the 500 m row's C at every error (which held river bends to
//    about e / (BAI + 1) at any e). Non-decreasing in d: points with one BAI keep their order.
class BaiKeys {
public:
    BaiKeys() = default;
    explicit BaiKeys(std::vector<float> factor) : factor_(std::move(factor)) {}
    static BaiKeys byThreshold(const PointSet& set, const BaiTable& table);

    bool empty() const { return factor_.empty() && first_.empty(); }
    std::size_t size() const {
        return factor_.empty() ? (first_.empty() ? 0 : first_.size() - 1) : factor_.size();
    }
    double key(std::uint32_t point, double d) const {
        if (!(d > 0)) return d;  // a free deletion stays free, whatever a table's C
        if (!factor_.empty()) return d * double(factor_[point]);
        if (first_.empty() || first_[point] == first_[point + 1]) return d;
        return thresholdKey(point, d);
    }

private:
    double thresholdKey(std::uint32_t point, double d) const;
    std::vector<float> factor_;
    // By threshold: per point its bends' (altitude class, BAI), largest BAI per class.
    std::vector<std::uint32_t> first_;  // size points + 1
    struct Entry {
        std::uint32_t cls = 0;
        double bai = 0;
    };
    std::vector<Entry> entries_;
    std::vector<double> thresholds_;      // the table's row thresholds, ascending
    std::vector<std::vector<double>> c_;  // per class, C at each threshold
};

}  // namespace unilod
