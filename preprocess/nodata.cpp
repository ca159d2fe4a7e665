// Nodata hole filling (nodata.h, rule 1).
#include "nodata.h"

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
    auto at = [&](int c, int r) { return std::size_t(r) * std::size_t(w) + std::size_t(c); };
    std::vector<std::uint8_t> seen(dem.z.size(), 0);
    std::vector<std::size_t> region, stack;
    const int dc[4] = {1, -1, 0, 0}, dr[4] = {0, 0, 1, -1};
    for (const float z : dem.z)
        stats.nodataCells += std::isnan(z);
    for (std::size_t start = 0; start < dem.z.size(); ++start) {
        if (!std::isnan(dem.z[start]) || seen[start]) continue;
        // Flood the 4-connected nodata region.
        region.clear();
        stack.assign(1, start);
        seen[start] = 1;
        bool border = false;
        while (!stack.empty()) {
            const std::size_t i = stack.back();
            stack.pop_back();
            region.push_back(i);
            const int c = int(i % std::size_t(w)), r = int(i / std::size_t(w));
            if (c == 0 || r == 0 || c == w - 1 || r == h - 1) border = true;
            for (int k = 0; k < 4; ++k) {
                const int nc = c + dc[k], nr = r + dr[k];
                if (nc < 0 || nr < 0 || nc >= w || nr >= h) continue;
                const std::size_t j = at(nc, nr);
                if (!seen[j] && std::isnan(dem.z[j])) {
                    seen[j] = 1;
                    stack.push_back(j);
                }
            }
        }
        if (border) continue;  // outside the data (rule 2)
        ++stats.holes;
        if (region.size() > maxFillCells) {  // a hole of the domain (blocks.h "Domain")
            ++stats.keptHoles;
            stats.keptHoleCells += region.size();
            continue;
        }
        stats.filledCells += fillCells(dem, region);
    }
    return true;
}

}  // namespace unilod
