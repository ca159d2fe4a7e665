// Ingestion (ingest.h): the one path from a DEM + river files to block point sets.
#include "ingest.h"

#include <sys/stat.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <utility>

#include "atomicfile.h"
#include "gdal_errors.h"
#include "predicates.h"
#include "ulod.h"

namespace unilod {

namespace {

bool checkElevations(const DemGrid& dem, const std::string& path, std::string& error) {
    for (std::size_t i = 0; i < dem.z.size(); ++i) {
        const float z = dem.z[i];
        if (std::isnan(z) || (z >= kMinPlausibleZ && z <= kMaxPlausibleZ)) continue;
        const std::size_t col = i % std::size_t(dem.width), row = i / std::size_t(dem.width);
        error = "DEM '" + path + "': elevation " + std::to_string(z) + " at cell (" +
                std::to_string(col) + ", " + std::to_string(row) + ") is outside the plausible " +
                "range [" + std::to_string(int(kMinPlausibleZ)) + ", " +
                std::to_string(int(kMaxPlausibleZ)) + "] m (a wrong nodata value or units?)";
        return false;
    }
    // Nodata sentinels inside the plausible range (ASCII grids without a NODATA_value line,
    // rasters whose nodata was never declared): such a cell next to real terrain is thousands
    // of metres off its neighbour, which no terrain is from one cell to the next.
    std::size_t count = 0, first = 0;
    const std::size_t w = std::size_t(dem.width), h = std::size_t(dem.height);
    for (std::size_t i = 0; i < dem.z.size(); ++i) {
        const float z = dem.z[i];
        if (z != kUndeclaredNodata[0] && z != kUndeclaredNodata[1]) continue;
        const std::size_t c = i % w, r = i / w;
        bool jump = false;
        for (const auto& [dc, dr] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
            if ((c == 0 && dc < 0) || (c + 1 == w && dc > 0) || (r == 0 && dr < 0) ||
                (r + 1 == h && dr > 0))
                continue;
            const float n = dem.z[(r + std::size_t(dr)) * w + c + std::size_t(dc)];
            jump = jump || (!std::isnan(n) && std::fabs(double(n) - z) > kNodataJump);
        }
        if (jump && count++ == 0) first = i;
    }
    if (count > 0) {
        char value[32];
        std::snprintf(value, sizeof value, "%g", double(dem.z[first]));
        error = "DEM '" + path + "': " + std::to_string(count) + " cells hold " + value +
                " next to cells more than " + std::to_string(int(kNodataJump)) +
                " m higher or lower (the first at cell (" + std::to_string(first % w) + ", " +
                std::to_string(first / w) + ")), as a nodata value the file does not declare " +
                "would; declare it: gdal_translate -a_nodata " + value + " '" + path +
                "' fixed.tif";
        return false;
    }
    return true;
}

// The point set drops repeated consecutive vertices and lines with fewer than two distinct
// vertices (pointset.h); say so, since the user's data changes.
void warnDegenerateLines(const RiverLines& rivers, const IngestOptions& o) {
    std::size_t repeated = 0, degenerate = 0;
    for (const RiverLine& line : rivers) {
        std::size_t here = 0;
        for (std::size_t i = 1; i < line.size(); ++i)
            here += line[i] == line[i - 1];
        repeated += here;
        degenerate += line.size() - here < 2;
    }
    if ((repeated > 0 || degenerate > 0) && o.warn) {
        o.warn("rivers '" + o.riversPath + "': dropped " + std::to_string(repeated) +
               " repeated vertices and " + std::to_string(degenerate) +
               " zero-length lines (fewer than two distinct vertices)");
    }
}

bool anyVertexOnDem(const RiverLines& rivers, const DemGrid& dem) {
    for (const RiverLine& line : rivers) {
        for (const XY& v : line) {
            if (std::isfinite(dem.sample(v.x, v.y))) return true;
        }
    }
    return false;
}

// Lines whose bounding box misses the DEM's extent: nothing of them can be on it.
std::size_t linesOutsideDem(const RiverLines& rivers, const DemGrid& dem) {
    const double xa = dem.originX - 0.5 * dem.cellX, xb = xa + dem.width * dem.cellX;
    const double ya = dem.originY - 0.5 * dem.cellY, yb = ya + dem.height * dem.cellY;
    const double x0 = std::min(xa, xb), x1 = std::max(xa, xb);
    const double y0 = std::min(ya, yb), y1 = std::max(ya, yb);
    std::size_t outside = 0;
    for (const RiverLine& line : rivers) {
        double lx0 = INFINITY, lx1 = -INFINITY, ly0 = INFINITY, ly1 = -INFINITY;
        for (const XY& v : line) {
            lx0 = std::min(lx0, v.x), lx1 = std::max(lx1, v.x);
            ly0 = std::min(ly0, v.y), ly1 = std::max(ly1, v.y);
        }
        if (!line.empty() && (lx1 < x0 || lx0 > x1 || ly1 < y0 || ly0 > y1)) ++outside;
    }
    return outside;
}

// A river segment's heights are interpolated between its vertices, and DEM points within the
// river clearance of it are dropped, so a long segment would carry the terrain along its chord
// (generalised river data on a fine DEM: 335 m off the DEM at full resolution, in no stored
// error). Segments longer than two sampled cells get vertices about one sampled cell apart
// within the DEM's extent (their heights are sampled from the DEM like every river vertex).
// Returns the number of vertices inserted; at most as many as the DEM has sampled points (a
// hundred thousand at least): beyond that, `skipped` counts the long segments left as they are.
std::size_t densifyRivers(RiverLines& rivers, const DemGrid& dem, int stride,
                          std::size_t& skipped) {
    skipped = 0;
    const double step = std::max(std::fabs(dem.cellX), std::fabs(dem.cellY)) * stride;
    if (!(step > 0)) return 0;
    const double budget =
        std::max(1e5, double(dem.width) * double(dem.height) / (double(stride) * stride));
    const double xa = dem.originX - 0.5 * dem.cellX, xb = xa + dem.width * dem.cellX;
    const double ya = dem.originY - 0.5 * dem.cellY, yb = ya + dem.height * dem.cellY;
    const double lo[2] = {std::min(xa, xb), std::min(ya, yb)};
    const double hi[2] = {std::max(xa, xb), std::max(ya, yb)};
    std::size_t inserted = 0;
    for (RiverLine& line : rivers) {
        if (line.size() < 2) continue;
        RiverLine out{line.front()};
        for (std::size_t i = 1; i < line.size(); ++i) {
            const XY a = line[i - 1], b = line[i];
            const double d[2] = {b.x - a.x, b.y - a.y}, p[2] = {a.x, a.y};
            const double len = std::hypot(d[0], d[1]);
            if (std::isfinite(len) && len > 2 * step) {
                // The segment's parameter range inside the DEM's extent (Liang-Barsky).
                double t0 = 0, t1 = 1;
                for (int k = 0; k < 2 && t0 < t1; ++k) {
                    if (d[k] == 0) {
                        if (p[k] < lo[k] || p[k] > hi[k]) t1 = t0 - 1;
                        continue;
                    }
                    double u = (lo[k] - p[k]) / d[k], v = (hi[k] - p[k]) / d[k];
                    if (u > v) std::swap(u, v);
                    t0 = std::max(t0, u);
                    t1 = std::min(t1, v);
                }
                const double pieces = t0 < t1 ? std::ceil((t1 - t0) * len / step) : 0;
                const bool overBudget = double(inserted) + pieces > budget;
                if (pieces > 0 && overBudget) {
                    ++skipped;
                } else if (pieces > 0) {
                    const auto n = static_cast<std::size_t>(pieces);
                    for (std::size_t k = 0; k <= n; ++k) {
                        const double t = t0 + (t1 - t0) * double(k) / double(n);
                        if (!(t > 0 && t < 1)) continue;
                        out.push_back({a.x + t * d[0], a.y + t * d[1]});
                        ++inserted;
                    }
                }
            }
            out.push_back(b);
        }
        line = std::move(out);
    }
    return inserted;
}

std::string cells(const DemGrid& dem) {
    return std::to_string(dem.width) + " x " + std::to_string(dem.height) + " cells";
}

}  // namespace

std::vector<std::string> datasetFiles(const std::string& name, bool raster) {
    if (name.empty()) return {};
    // A path on the disk that is no regular file or folder is not opened (a FIFO would block):
    // the name itself or the file a GDAL name reads (a subdataset's container).
    const auto openable = [](const std::string& path) {
        struct stat st {};
        return path.empty() || ::stat(path.c_str(), &st) != 0 || S_ISREG(st.st_mode) ||
               S_ISDIR(st.st_mode);
    };
    if (!openable(name) || !openable(format::fileInside(name))) return {};
    QuietGdalErrors quiet;
    GDALDatasetH dataset =
        GDALOpenEx(name.c_str(), GDAL_OF_READONLY | (raster ? GDAL_OF_RASTER : GDAL_OF_VECTOR),
                   nullptr, nullptr, nullptr);
    if (dataset == nullptr) return {};
    std::vector<std::string> files;
    char** list = GDALGetFileList(dataset);
    for (char** f = list; f != nullptr && *f != nullptr; ++f)
        if (*f != name && std::find(files.begin(), files.end(), *f) == files.end())
            files.emplace_back(*f);
    CSLDestroy(list);
    GDALClose(dataset);
    return files;
}

void addInputFiles(format::OutputOptions& output, const std::string& demPath,
                   const std::string& riversPath) {
    for (const auto& [name, raster] : {std::pair{&demPath, true}, {&riversPath, false}}) {
        if (name->empty()) continue;
        output.inputs.push_back(*name);
        for (std::string& file : datasetFiles(*name, raster))
            output.inputParts.emplace_back(std::move(file), *name);
    }
}

bool ingest(const IngestOptions& o, Ingested& data, std::string& error) {
    data = Ingested{};
    auto warn = [&](const std::string& w) {
        if (o.warn) o.warn(w);
    };
    if (o.riversPath.empty()) {
        // A terrain-only model: the options that select or filter rivers would be ignored.
        for (const auto& [name, given] :
             {std::pair{"--layer", !o.layer.empty()}, std::pair{"--where", !o.where.empty()},
              std::pair{"--min-river-length", o.minRiverLength > 0}}) {
            if (given) {
                error = std::string(name) + " selects rivers, but no RIVERS file is given";
                return false;
            }
        }
    }
    DemLoadOptions demOptions;
    demOptions.band = o.band;
    demOptions.targetSrs = o.targetSrs;
    demOptions.assumeSrs = o.assumeSrs;
    demOptions.warn = warn;
    demOptions.memoryBytes = o.demMemoryBytes;
    demOptions.memoryWhat = o.demMemoryWhat;
    demOptions.memorySkippable = o.demMemorySkippable;
    demOptions.threads = o.demThreads;
    demOptions.bytesPerCell = o.demBytesPerCell;
    demOptions.baseBytes = o.demBaseBytes;
    if (o.stride > 1) {
        demOptions.spillDir = o.demSpillDir;
        demOptions.spillStride = o.stride;
    }
    DemGrid& dem = data.dem;
    if (!loadDem(o.demPath, demOptions, dem, error)) return false;
    if (dem.width < 2 || dem.height < 2) {
        error = "DEM '" + o.demPath + "': " + cells(dem) +
                " is too small to triangulate (at least 2 x 2)";
        return false;
    }
    if (!checkElevations(dem, o.demPath, error)) return false;
    if (!fillSmallHoles(dem, o.demPath, kDefaultMaxFillCells, data.nodata, error)) return false;
    // Nodata that only bounds the domain (a DEM clipped to a watershed or a coast, the corners
    // a reprojection leaves) is the normal case: the build summary counts it. Filled cells
    // (invented altitudes) and holes kept inside the domain are worth a warning.
    if (data.nodata.filledCells > 0 || data.nodata.keptHoles > 0) {
        warn("DEM '" + o.demPath + "': " + std::to_string(data.nodata.nodataCells) +
             " nodata cells (nodata value, mask, NaN or infinite); " +
             std::to_string(data.nodata.holes - data.nodata.keptHoles) +
             " interior holes of at most " + std::to_string(kDefaultMaxFillCells) + " cells (" +
             std::to_string(data.nodata.filledCells) +
             " cells) filled from their rims; the rest is outside the domain (" +
             std::to_string(data.nodata.keptHoles) + " larger holes)");
    }

    RiverLoadOptions riverOptions;
    riverOptions.layer = o.layer;
    riverOptions.where = o.where;
    riverOptions.assumeSrs = o.assumeSrs;
    riverOptions.warn = warn;
    RiverLines rivers;
    if (o.riversPath.empty()) return true;  // a terrain-only model
    if (!loadRivers(o.riversPath, riverOptions, dem.wkt, rivers, error)) return false;
    warnDegenerateLines(rivers, o);
    if (rivers.empty()) {
        warn("rivers '" + o.riversPath + "': no line features: building a terrain-only model");
        return true;
    }
    // River cleaning (DESIGN.md "Point set"): clip to the DEM, snap, split at crossings, drop
    // duplicates, zero-length segments and short rivers, so that the constrained triangulation
    // gets a planar network whose rivers meet only at shared vertices.
    if (o.onStage) o.onStage("cleaning the rivers");
    RiverCleaningOptions cleaning;
    cleaning.minRiverLength = o.minRiverLength;
    std::size_t notDensified = 0;
    const std::size_t densified = densifyRivers(rivers, dem, o.stride, notDensified);
    if (notDensified > 0)
        warn("rivers '" + o.riversPath + "': " + std::to_string(notDensified) +
             " long segments were not given vertices about every cell (more than the DEM's "
             "points already inserted): along them the terrain follows the segment's chord");
    data.rivers = cleanRivers(rivers, dem, cleaning, data.cleaning);
    data.cleaning.densifiedVertices = densified;
    data.cleaning.inputVertices -= densified;
    const RiverCleaningStats& s = data.cleaning;
    if (data.rivers.empty()) {
        // Nothing on the valid DEM: with no vertex on it either, most likely the wrong CRS.
        if (!anyVertexOnDem(rivers, dem) && s.segmentsCut == 0) {
            error = "rivers '" + o.riversPath + "': no river vertex lies on the DEM '" + o.demPath +
                    "' (a CRS mistake? try --s-srs or check the data)";
            return false;
        }
        warn("rivers '" + o.riversPath + "': no river is left on the valid DEM '" + o.demPath +
             "' after cleaning (" + std::to_string(s.shortLinesDropped) +
             " lines shorter than --min-river-length, the rest off the DEM or over nodata): "
             "building a terrain-only model");
    } else if (const std::size_t outside = linesOutsideDem(rivers, dem); outside > 0) {
        // A whole line off the DEM is more likely a mistake (another area's data, a wrong
        // --where) than the usual cut at the DEM's edge: it was dropped with no word.
        warn("rivers '" + o.riversPath + "': " + std::to_string(outside) + " of " +
             std::to_string(rivers.size()) + " lines lie entirely outside the DEM '" + o.demPath +
             "': dropped");
    }  // rivers cut at the DEM's edge or at nodata: counted in the summary, no warning (usual)
    if (s.crossingsSplit + s.selfCrossings + s.touchesSplit > 0) {
        warn("rivers '" + o.riversPath +
             "': crossing or touching rivers were split at the crossing");
    }
    // Repeated vertices and zero-length lines were counted, with numbers, by
    // warnDegenerateLines before cleaning; the summary gives cleaning's own counts.
    return true;
}

bool splitIntoBlocks(Ingested& data, const IngestOptions& o, int blockSize, bool lockOuterEdge,
                     BlockSource& source, std::string& error) {
    DemGrid& dem = data.dem;
    BlockOptions blocks;
    blocks.blockSize = blockSize;
    blocks.stride = o.stride;
    blocks.lockOuterEdge = lockOuterEdge;
    blocks.riverClearance = o.riverClearance;
    if (!source.init(dem, data.rivers, blocks, error)) {
        error = "DEM '" + o.demPath + "': " + error;
        return false;
    }
    bool any = false;
    for (std::size_t i = 0; i < source.blockCount() && !any; ++i)
        any = source.hasDomain(i);
    if (!any) {
        error = "DEM '" + o.demPath + "': no valid data to triangulate (no 2 x 2 cells" +
                (o.stride > 1 ? " of the --stride " + std::to_string(o.stride) + " lattice" : "") +
                " with at least 3 valid)";
        return false;
    }
    return true;
}

namespace {

// Metres a block may span in one direction: the exact grid holds |c| <= kMaxGridCoordinate units
// from the block centre (cdt.cpp), one unit spare for the rounding.
constexpr double kExactSpan = 2.0 * double(kMaxGridCoordinate - 1) * format::kGridUnit;

int largestExactBlock(const DemGrid& dem) {
    const double cell = std::max(std::fabs(dem.cellX), std::fabs(dem.cellY));
    return int(std::min(std::floor(kExactSpan / cell), double(kWholeDem)));
}

}  // namespace

int automaticBlockSize(const DemGrid& dem, int stride) {
    return std::max(1, std::min(largestExactBlock(dem), std::max(kDefaultBlockSize, 2 * stride)));
}

bool checkCellsFitExactGrid(const DemGrid& dem, int stride, std::string& error) {
    // Cells below 1 cm (ten grid units) would put neighbouring points on the same or adjacent
    // grid points: merged silently (a 0.5 mm DEM of 400 points became 121 vertices).
    constexpr double kMinCell = 0.01;
    const double smallest = std::min(std::fabs(dem.cellX), std::fabs(dem.cellY)) * stride;
    if (std::min(dem.width, dem.height) >= 2 && smallest < kMinCell) {
        char text[96];
        std::snprintf(text, sizeof text, "%.3g mm", smallest * 1000);
        const double need = std::ceil(kMinCell / (smallest / stride));
        error = "its cells" +
                std::string(stride > 1 ? " (at --stride " + std::to_string(stride) + ")" : "") +
                " are " + text +
                " wide: too small for the exact 1 mm grid (cells of at least 1 cm; --stride " +
                (need < 1e9 ? std::to_string(std::lround(need)) : std::string("N")) +
                " samples them that far apart, or check its georeferencing)";
        return false;
    }
    const double cell = std::max(std::fabs(dem.cellX), std::fabs(dem.cellY)) * stride;
    if (std::min(dem.width, dem.height) < 2 || 2 * cell <= kExactSpan) return true;
    error = "its cells" +
            std::string(stride > 1 ? " (at --stride " + std::to_string(stride) + ")" : "") +
            " are " + std::to_string(std::lround(cell / 1000)) +
            " km wide: too large for the exact 1 mm grid, where a block of two cells must fit " +
            std::to_string(std::lround(kExactSpan / 1000)) + " km (cells of at most " +
            std::to_string(std::lround(kExactSpan / 2000)) +
            " km; resample the DEM to smaller cells, or check its georeferencing)";
    return false;
}

bool checkBlockFitsExactGrid(const DemGrid& dem, int stride, int blockSize, std::string& error) {
    // The block grid's step: the block size rounded down to the stride (blocks.cpp borderLines),
    // at most the DEM's sampled extent in that direction.
    const int step = std::max(stride, blockSize / stride * stride);
    for (const auto& [n, cell] :
         {std::pair{dem.width, dem.cellX}, std::pair{dem.height, dem.cellY}}) {
        const int extent = std::min(step, (n - 1) / stride * stride);
        const double metres = extent * std::fabs(cell);
        if (metres <= kExactSpan) continue;
        error = "--block-size " + std::to_string(blockSize) + ": blocks " +
                std::to_string(std::lround(metres / 1000)) +
                " km wide are too large for the exact 1 mm grid (at most " +
                std::to_string(std::lround(kExactSpan / 1000)) + " km); use --block-size " +
                std::to_string(largestExactBlock(dem)) + " or less";
        return false;
    }
    return true;
}

void recordIngestOptions(const IngestOptions& o, nlohmann::json& info) {
    info["dem"] = o.demPath;
    info["rivers"] = o.riversPath;
    info["band"] = o.band;
    info["t_srs"] = o.targetSrs;
    info["layer"] = o.layer;
    info["where"] = o.where;
    info["assume_crs"] = o.assumeSrs;
    info["stride"] = o.stride;
    info["min_river_length"] = o.minRiverLength;
    info["river_clearance_m"] = o.riverClearance;
}

IngestOptions ingestOptionsFromInfo(const nlohmann::json& info) {
    IngestOptions o;
    if (!info.is_object()) return o;
    auto get = [&](const char* key, auto& value) {
        const auto it = info.find(key);
        if (it == info.end()) return;
        try {
            value = it->template get<std::remove_reference_t<decltype(value)>>();
        } catch (const nlohmann::json::exception&) {
        }
    };
    get("dem", o.demPath);
    get("rivers", o.riversPath);
    get("band", o.band);
    get("t_srs", o.targetSrs);
    get("layer", o.layer);
    get("where", o.where);
    get("assume_crs", o.assumeSrs);
    get("stride", o.stride);
    get("min_river_length", o.minRiverLength);
    get("river_clearance_m", o.riverClearance);
    o.stride = std::max(1, o.stride);
    return o;
}

}  // namespace unilod
