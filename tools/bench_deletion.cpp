// Benchmark of the river-constrained deletion sequence (paper §3.2-3.3): constrained Delaunay
// construction, then the full deletion sequence with records and both error metrics, on a
// synthetic block (jittered grid + meandering rivers with tributaries, fixed seed). Prints one
// JSON object: times (s), peak resident memory (bytes and bytes per point), structure sizes.
//   bench_deletion [points=100000] [--no-paper] [--no-max] [--seed N]
// The deletion order is a fixed-seed shuffle of the unlocked points (the importance order is a
// separate module; a random order gives holes of the same size on average).
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cdt.h"
#include "deletion.h"
#include "jsontext.h"

namespace {

using namespace unilod;

struct Rng {
    std::uint64_t state;
    std::uint64_t next() {
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }
};

double height(double x, double y) {
    return 300.0 + 80.0 * std::sin(x * 0.0021) * std::cos(y * 0.0017) + 25.0 * std::sin(0.011 * x) +
           10.0 * std::cos(0.013 * y + 0.4 * std::sin(0.003 * x));
}

// Jittered grid (spacing 10 m), border points unjittered and locked; `rivers` meandering rivers
// west to east, each with a tributary joining from the north; DEM points closer than 3 m
// (vertically in y) to a river are dropped.
PointSet makeTerrain(std::size_t target, std::uint64_t seed) {
    Rng rng{seed};
    PointSet set;
    const double spacing = 10.0;
    const auto side = std::size_t(std::sqrt(double(target) * 0.97));
    const double size = spacing * double(side - 1);
    const std::size_t riverCount = std::max<std::size_t>(2, side / 120);
    const double band = size / double(riverCount + 1);
    std::vector<double> phase(riverCount), amp(riverCount);
    for (std::size_t r = 0; r < riverCount; ++r) {
        phase[r] = rng.uniform() * 6.28;
        amp[r] = band * (0.15 + 0.15 * rng.uniform());
    }
    auto riverY = [&](std::size_t r, double x) {
        return band * double(r + 1) + amp[r] * std::sin(phase[r] + x / (band * 0.7));
    };
    set.points.reserve(target + target / 10);
    for (std::size_t j = 0; j < side; ++j) {
        for (std::size_t i = 0; i < side; ++i) {
            const bool border = i == 0 || j == 0 || i + 1 == side || j + 1 == side;
            double x = spacing * double(i), y = spacing * double(j);
            if (!border) {
                x += (rng.uniform() - 0.5) * 6.0;
                y += (rng.uniform() - 0.5) * 6.0;
                bool near = false;
                for (std::size_t r = 0; r < riverCount && !near; ++r) {
                    near = std::fabs(y - riverY(r, x)) < 3.0;
                }
                if (near) continue;
            }
            set.points.push_back({x, y, height(x, y), PointKind::Dem, border});
        }
    }
    auto addRiverPoint = [&](double x, double y, bool locked) {
        set.points.push_back({x, y, height(x, y) - 4.0, PointKind::River, locked});
        return PointId(set.points.size() - 1);
    };
    const double step = 7.0;
    for (std::size_t r = 0; r < riverCount; ++r) {
        Polyline main;
        const double x0 = spacing * 2.5, x1 = size - spacing * 2.5;
        const auto count = std::size_t((x1 - x0) / step);
        for (std::size_t k = 0; k <= count; ++k) {
            const double x = x0 + (x1 - x0) * double(k) / double(count);
            main.push_back(addRiverPoint(x, riverY(r, x), k == 0 || k == count));
        }
        const PointId junction = main[main.size() / 2];
        set.points[junction].locked = true;
        Polyline trib;
        const double jx = set.points[junction].x, jy = set.points[junction].y;
        const double tx = jx - band * 0.3, ty = jy + band * 0.45;
        const auto tcount = std::size_t(std::hypot(jx - tx, jy - ty) / step);
        for (std::size_t k = 0; k < tcount; ++k) {
            const double f = double(k) / double(tcount);
            const double x = tx + (jx - tx) * f + 8.0 * std::sin(f * 20.0);
            trib.push_back(addRiverPoint(x, ty + (jy - ty) * f, k == 0));
        }
        trib.push_back(junction);
        set.rivers.push_back(std::move(main));
        set.rivers.push_back(std::move(trib));
    }
    return set;
}

double seconds(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
}

std::size_t peakRssBytes() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return std::size_t(usage.ru_maxrss) * 1024;
}

std::size_t cdtBytes(const Cdt& cdt) {
    return cdt.gx.capacity() * 4 + cdt.gy.capacity() * 4 + cdt.representative.capacity() * 4 +
           cdt.vertexTriangle.capacity() * 4 + cdt.locked.capacity() + cdt.tv.capacity() * 4 +
           cdt.tn.capacity() * 4 + cdt.tc.capacity() + cdt.stamp.capacity() * 4 +
           cdt.freeSlots.capacity() * 4;
}

}  // namespace

int main(int argc, char** argv) {
    std::size_t points = 100000;
    std::uint64_t seed = 1;
    DeletionOptions options;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--no-paper") == 0) {
            options.paperError = false;
        } else if (std::strcmp(argv[i], "--no-max") == 0) {
            options.maxError = false;
        } else if (std::strcmp(argv[i], "--seed") == 0 && i + 1 < argc) {
            seed = std::strtoull(argv[++i], nullptr, 10);
        } else if (argv[i][0] != '-') {
            points = std::strtoull(argv[i], nullptr, 10);
        } else {
            std::fprintf(stderr,
                         "usage: bench_deletion [points] [--no-paper] [--no-max] [--seed N]\n");
            return 1;
        }
    }
    const auto t0 = std::chrono::steady_clock::now();
    const PointSet set = makeTerrain(points, seed);
    std::vector<PointId> order;
    for (PointId i = 0; i < set.points.size(); ++i) {
        if (!set.points[i].locked) order.push_back(i);
    }
    Rng rng{seed * 31 + 7};
    for (std::size_t i = order.size(); i > 1; --i)
        std::swap(order[i - 1], order[rng.next() % i]);
    const std::size_t rssInput = peakRssBytes();
    const auto t1 = std::chrono::steady_clock::now();
    Cdt cdt;
    std::string error;
    if (!buildCdt(set, {}, cdt, error)) {
        std::fprintf(stderr, "bench_deletion: %s\n", error.c_str());
        return 1;
    }
    const auto t2 = std::chrono::steady_clock::now();
    const std::size_t cdtMemory = cdtBytes(cdt);
    const std::uint32_t triangles = cdt.realTriangleCount, riverEdges = cdt.constraintEdgeCount;
    DeletionRecords records;
    if (!runDeletion(set, cdt, order, options, records, error)) {
        std::fprintf(stderr, "bench_deletion: %s\n", error.c_str());
        return 1;
    }
    const auto t3 = std::chrono::steady_clock::now();
    const std::size_t peak = peakRssBytes();
    const std::size_t n = set.points.size();
    std::size_t riverPoints = 0;
    for (const Point& p : set.points)
        riverPoints += p.kind == PointKind::River;
    nlohmann::json out;
    out["points"] = n;
    out["river_points"] = riverPoints;
    out["rivers"] = set.rivers.size();
    out["initial_triangles"] = triangles;
    out["initial_river_edges"] = riverEdges;
    out["order_length"] = order.size();
    out["steps"] = records.steps.size();
    out["kept"] = records.kept.size();
    out["deferrals"] = records.deferrals;
    out["deferred_vertices"] = records.deferredVertices;
    out["metrics"] = {{"max", options.maxError}, {"paper", options.paperError}};
    out["seconds"] = {{"generate", seconds(t0, t1)},
                      {"cdt", seconds(t1, t2)},
                      {"deletion", seconds(t2, t3)},
                      {"cdt_plus_deletion", seconds(t1, t3)}};
    out["memory"] = {
        {"peak_rss_bytes", peak},
        {"peak_rss_bytes_per_point", double(peak) / double(n)},
        {"rss_after_input_bytes", rssInput},
        {"cdt_bytes", cdtMemory},
        {"records_bytes", records.memoryBytes()},
        {"records_bytes_per_step",
         records.steps.empty() ? 0.0
                               : double(records.memoryBytes()) / double(records.steps.size())}};
    const double steps = std::max<double>(1.0, double(records.steps.size()));
    out["per_step"] = {{"removed_triangles", double(records.removedTriangles.size()) / steps},
                       {"added_triangles", double(records.addedTriangles.size()) / steps},
                       {"removed_river_edges", double(records.removedEdges.size()) / steps},
                       {"added_river_edges", double(records.addedEdges.size()) / steps}};
    if (!records.errorMax.empty()) out["final_error_max_m"] = records.errorMax.back();
    if (!records.errorPaper.empty()) out["final_error_paper_m"] = records.errorPaper.back();
    std::printf("%s\n", jsonText(out, 2).c_str());
    return 0;
}
