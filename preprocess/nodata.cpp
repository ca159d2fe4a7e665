// Nodata hole filling (nodata.h, rule 1).
#include "nodata.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace unilod {

std::size_t fillCells(DemGrid& dem, std::vector<std::size_t> left) {
    const int w = dem.width, h = dem.height;
    const int dc[4] = {1, -1, 0, 0}, dr[4] = {0, 0, 1, -1};
    std::size_t filled = 0;
    while (!left.empty()) {
        std::vector<std::pair<std::size_t, float>> fills;
        std::vector<std::size_t> still;
        for (std::size_t i : left) {
            const int c = int(i % std::size_t(w)), r = int(i / std::size_t(w));
            double sum = 0;
            int count = 0;
            for (int k = 0; k < 4; ++k) {
                const int nc = c + dc[k], nr = r + dr[k];
                if (nc < 0 || nr < 0 || nc >= w || nr >= h) continue;
                const float z = dem.z[std::size_t(nr) * std::size_t(w) + std::size_t(nc)];
                if (!std::isnan(z)) {
                    sum += z;
                    ++count;
                }
            }
            if (count > 0) {
                fills.push_back({i, float(sum / count)});
            } else {
                still.push_back(i);
            }
        }
        if (fills.empty()) break;  // nothing valid reachable
        for (const auto& [i, z] : fills)
            dem.z[i] = z;
        filled += fills.size();
        left.swap(still);
    }
    return filled;
}

bool fillSmallHoles(DemGrid& dem, const std::string& path, std::size_t maxFillCells,
                    NodataStats& stats, std::string& error) {
    (void)path, (void)error;
    stats = {};
    const int w = dem.width, h = dem.height;
    // The nodata cells as runs along the rows, joined into 4-connected regions by a union-find
    // over the runs: memory grows with the runs, not the cells. (Until 2026-11-30 a flood fill
    // listed every cell of a region: a corridor of data clipped from a large raster is one
    // nodata region of almost every cell, 16 bytes each; an 8 000^2 raster holding 72 000
    // points of data peaked at 754 MB.)
    struct Run {
        int row, c0, c1;  // columns [c0, c1)
    };
    std::vector<Run> runs;
    std::vector<std::size_t> rowStart(std::size_t(h) + 1, 0);
    for (int r = 0; r < h; ++r) {
        rowStart[std::size_t(r)] = runs.size();
        const float* z = dem.z.data() + std::size_t(r) * std::size_t(w);
        for (int c = 0; c < w;) {
            if (!std::isnan(z[c])) {
                ++c;
                continue;
            }
            const int c0 = c;
            while (c < w && std::isnan(z[c]))
                ++c;
            runs.push_back({r, c0, c});
        }
    }
    rowStart[std::size_t(h)] = runs.size();
    // Union-find; the root of a region is its first run in row-major order.
    std::vector<std::size_t> parent(runs.size());
    for (std::size_t i = 0; i < runs.size(); ++i)
        parent[i] = i;
    auto find = [&](std::size_t i) {
        while (parent[i] != i) {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        return i;
    };
    for (int r = 1; r < h; ++r) {
        std::size_t i = rowStart[std::size_t(r) - 1], j = rowStart[std::size_t(r)];
        const std::size_t iEnd = j, jEnd = rowStart[std::size_t(r) + 1];
        while (i < iEnd && j < jEnd) {
            if (std::max(runs[i].c0, runs[j].c0) < std::min(runs[i].c1, runs[j].c1)) {
                const std::size_t a = find(i), b = find(j);
                if (a != b) parent[std::max(a, b)] = std::min(a, b);
            }
            if (runs[i].c1 < runs[j].c1) {
                ++i;
            } else {
                ++j;
            }
        }
    }
    // Per region (at its root): cells, and whether it touches the raster border.
    std::vector<std::uint64_t> size(runs.size(), 0);
    std::vector<std::uint8_t> border(runs.size(), 0);
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const Run& u = runs[i];
        const std::size_t root = find(i);
        parent[i] = root;
        size[root] += std::uint64_t(u.c1 - u.c0);
        stats.nodataCells += std::size_t(u.c1 - u.c0);
        if (u.row == 0 || u.row == h - 1 || u.c0 == 0 || u.c1 == w) border[root] = 1;
    }
    // Holes: regions off the border (one touching it is outside the data, rule 2). The small
    // ones are filled (independently: no cell of one is a 4-neighbour of another's).
    std::vector<std::size_t> small;  // runs of small holes, grouped by region
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (parent[i] != i || border[i]) continue;
        ++stats.holes;
        if (size[i] > maxFillCells) {  // a hole of the domain (blocks.h "Domain")
            ++stats.keptHoles;
            stats.keptHoleCells += std::size_t(size[i]);
        }
    }
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const std::size_t root = parent[i];
        if (!border[root] && size[root] <= maxFillCells) small.push_back(i);
    }
    std::stable_sort(small.begin(), small.end(),
                     [&](std::size_t a, std::size_t b) { return parent[a] < parent[b]; });
    std::vector<std::size_t> cells;
    for (std::size_t k = 0; k < small.size();) {
        const std::size_t root = parent[small[k]];
        cells.clear();
        for (; k < small.size() && parent[small[k]] == root; ++k) {
            const Run& u = runs[small[k]];
            for (int c = u.c0; c < u.c1; ++c)
                cells.push_back(std::size_t(u.row) * std::size_t(w) + std::size_t(c));
        }
        stats.filledCells += fillCells(dem, cells);
    }
    return true;
}

}  // namespace unilod
