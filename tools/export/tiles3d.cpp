#include "tiles3d.h"

#include <ogr_spatialref.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <vector>

#include "atomicfile.h"
#include "gdal_errors.h"
#include "gltfmodel.h"
#include "jsontext.h"
#include "selection.h"
#include "srs.h"
#include "ulod.h"
#include "workers.h"

namespace unilod::exporter {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

// File CRS -> WGS84 longitude/latitude -> ECEF -> the east-north-up frame at the model centre.
class Georeference {
public:
    // `verticalText`: the vertical CRS of the file's heights (--vertical-crs), empty: heights are
    // ellipsoidal already.
    bool init(const std::string& srsText, const std::string& verticalText, const std::string& what,
              const format::Header& header, std::string& error) {
        OGRSpatialReference src;
        if (srsText.empty()) {
            error = what + ": has no CRS: give its CRS with --s-srs (e.g. EPSG:32616) to place it "
                           "on the globe";
            return false;
        }
        if (!parseSrs(srsText, src)) {
            error = what + ": GDAL cannot read the CRS '" + srsText.substr(0, 80) + "'";
            return false;
        }
        // The model's coordinates are metres (build keeps or makes a projected CRS in metres, or
        // none): a geographic, geocentric or non-metre CRS would put it somewhere else entirely.
        if (src.IsGeographic() || src.IsGeocentric() || !src.IsProjected() ||
            std::fabs(src.GetLinearUnits() - 1.0) > 1e-9) {
            const char* name = src.GetName();
            error = what + ": the CRS '" + std::string(name ? name : srsText.substr(0, 80)) +
                    "' is not a projected CRS in metres, the unit of the model's coordinates "
                    "(give the CRS the DEM was built in, e.g. EPSG:32616)";
            return false;
        }
        OGRSpatialReference wgs84;
        wgs84.importFromEPSG(4326);
        src.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
        wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
        if (!verticalText.empty()) {
            // Heights of a vertical CRS: the compound CRS -> WGS84 3D (EPSG:4979) through PROJ,
            // without the "ballpark" fallback that would keep the heights as they are where PROJ
            // lacks the geoid grid.
            OGRSpatialReference vertical, compound, wgs84h;
            if (!parseSrs(verticalText, vertical) || !vertical.IsVertical()) {
                error = "--vertical-crs '" + verticalText.substr(0, 80) +
                        "' is not a vertical CRS GDAL reads (e.g. EPSG:5773, EGM96 height)";
                return false;
            }
            if (src.IsCompound() || src.IsVertical()) {
                error = what +
                        ": its CRS names its heights already; --vertical-crs needs a "
                        "horizontal CRS";
                return false;
            }
            if (compound.SetCompoundCS("unilod heights", &src, &vertical) != OGRERR_NONE) {
                error = what + ": GDAL cannot combine its CRS with --vertical-crs";
                return false;
            }
            wgs84h.importFromEPSG(4979);
            compound.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
            wgs84h.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
            OGRCoordinateTransformationOptions options;
            options.SetBallparkAllowed(false);
            {
                const QuietGdalErrors quiet;  // PROJ's message names the whole compound CRS
                ct_.reset(OGRCreateCoordinateTransformation(&compound, &wgs84h, options));
            }
            vertical_ = true;
            const char* name = vertical.GetName();
            if (!ct_) {
                error = what + ": PROJ has no exact transformation from the vertical CRS '" +
                        std::string(name ? name : verticalText) +
                        "' to WGS84 ellipsoidal heights (its geoid grid is not installed? "
                        "Debian's proj-data holds EGM96, EPSG:5773)";
                return false;
            }
        } else {
            ct_.reset(OGRCreateCoordinateTransformation(&src, &wgs84));
        }
        if (!ct_) {
            error = what + ": GDAL/PROJ cannot transform its CRS to WGS84 longitude/latitude";
            return false;
        }
        double x = 0.5 * (header.minX + header.maxX), y = 0.5 * (header.minY + header.maxY);
        double z = 0.5 * (header.minZ + header.maxZ);
        int ok = 0;
        if (!ct_->Transform(1, &x, &y, vertical_ ? &z : nullptr, &ok) || !ok || !std::isfinite(x) ||
            !std::isfinite(y) || !std::isfinite(z)) {
            error = what + ": the model centre does not transform to WGS84 longitude/latitude" +
                    (vertical_ ? " and ellipsoidal height (outside the geoid grid?)" : "");
            return false;
        }
        lon0_ = x;
        lat0_ = y;
        const double lam = lon0_ * kPi / 180, phi = lat0_ * kPi / 180;
        origin_ = ecef(lam, phi, 0.0);
        east_ = {-std::sin(lam), std::cos(lam), 0.0};
        north_ = {-std::sin(phi) * std::cos(lam), -std::sin(phi) * std::sin(lam), std::cos(phi)};
        up_ = {std::cos(phi) * std::cos(lam), std::cos(phi) * std::sin(lam), std::sin(phi)};
        return true;
    }

    // World points (x, y, z of the file CRS; z ellipsoidal height) in place -> ENU.
    bool toEnu(std::vector<double>& xs, std::vector<double>& ys, std::vector<double>& zs) const {
        const std::size_t n = xs.size();
        if (n == 0) return true;
        std::vector<int> ok(n, 0);
        if (!ct_->Transform(n, xs.data(), ys.data(), vertical_ ? zs.data() : nullptr, ok.data()))
            return false;
        for (std::size_t i = 0; i < n; ++i) {
            if (!ok[i] || !std::isfinite(xs[i]) || !std::isfinite(ys[i]) || !std::isfinite(zs[i]))
                return false;
            const std::array<double, 3> p =
                ecef(xs[i] * kPi / 180, ys[i] * kPi / 180, zs[i]);
            const double d[3] = {p[0] - origin_[0], p[1] - origin_[1], p[2] - origin_[2]};
            xs[i] = d[0] * east_[0] + d[1] * east_[1] + d[2] * east_[2];
            ys[i] = d[0] * north_[0] + d[1] * north_[1] + d[2] * north_[2];
            zs[i] = d[0] * up_[0] + d[1] * up_[1] + d[2] * up_[2];
        }
        return true;
    }

    // The ENU -> ECEF matrix, column-major (3D Tiles `transform`).
    json transform() const {
        return json::array({east_[0], east_[1], east_[2], 0.0, north_[0], north_[1], north_[2],
                            0.0, up_[0], up_[1], up_[2], 0.0, origin_[0], origin_[1], origin_[2],
                            1.0});
    }
    double longitude() const { return lon0_; }
    double latitude() const { return lat0_; }
    bool vertical() const { return vertical_; }

private:
    // WGS84 geodetic (radians, metres) -> ECEF.
    static std::array<double, 3> ecef(double lam, double phi, double h) {
        constexpr double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2 - f);
        const double s = std::sin(phi), c = std::cos(phi);
        const double n = a / std::sqrt(1 - e2 * s * s);
        return {(n + h) * c * std::cos(lam), (n + h) * c * std::sin(lam), (n * (1 - e2) + h) * s};
    }

    struct Release {
        void operator()(OGRCoordinateTransformation* t) const {
            OGRCoordinateTransformation::DestroyCT(t);
        }
    };
    std::unique_ptr<OGRCoordinateTransformation, Release> ct_;
    bool vertical_ = false;  // heights converted (--vertical-crs)
    double lon0_ = 0, lat0_ = 0;
    std::array<double, 3> origin_{}, east_{}, north_{}, up_{};
};

struct Box {
    double lo[3] = {std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity()};
    double hi[3] = {-std::numeric_limits<double>::infinity(),
                    -std::numeric_limits<double>::infinity(),
                    -std::numeric_limits<double>::infinity()};
    void add(const double p[3]) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], p[k]);
            hi[k] = std::max(hi[k], p[k]);
        }
    }
    void add(const Box& b) {
        if (b.empty()) return;
        add(b.lo);
        add(b.hi);
    }
    bool empty() const { return !(lo[0] <= hi[0]); }
    // 3D Tiles box: centre and three half-axes; half sizes kept >= 0.5 m (flat tiles).
    json toJson() const {
        json a = json::array();
        for (int k = 0; k < 3; ++k)
            a.push_back(0.5 * (lo[k] + hi[k]));
        for (int k = 0; k < 3; ++k)
            for (int j = 0; j < 3; ++j)
                a.push_back(j == k ? std::max(0.5 * (hi[k] - lo[k]), 0.5) : 0.0);
        return a;
    }
};

// One stored level of one entry, written as a tile.
struct LevelTile {
    std::string uri;
    Box box;
    double error = 0;
    bool hasContent = false;
};

struct Entry {
    std::vector<LevelTile> levels;  // the stored levels kept as tiles, finest first
    std::uint32_t firstChild = format::kNoChild, childCount = 0;
    bool omitted = false;  // no tile; its children take its place (planTiles)
};

// The chain of entry `i` (coarsest level first) as a tile (planTiles: which levels and entries).
json chainTile(const std::vector<Entry>& entries, std::size_t i, Box& box, double& error) {
    const Entry& e = entries[i];
    if (e.levels.empty()) return json::object();  // the reader refuses such a block
    // Children of the finest level: the child entries' chains, an omitted child's children in
    // its place.
    json below = json::array();
    Box belowBox;
    double belowError = 0;
    const std::function<void(std::size_t)> place = [&](std::size_t c) {
        const Entry& child = entries[c];
        if (child.omitted) {
            for (std::uint32_t g = 0; g < child.childCount; ++g)
                place(child.firstChild + g);
            return;
        }
        Box b;
        double err = 0;
        below.push_back(chainTile(entries, c, b, err));
        belowBox.add(b);
        belowError = std::max(belowError, err);
    };
    if (e.firstChild != format::kNoChild)
        for (std::uint32_t c = 0; c < e.childCount; ++c)
            place(e.firstChild + c);
    for (const LevelTile& t : e.levels) {
        Box b = t.box;
        b.add(belowBox);
        const double err = std::max(t.error, belowError);
        json tile = {{"boundingVolume", {{"box", b.toJson()}}},
                     {"geometricError", err},
                     {"refine", "REPLACE"}};
        if (t.hasContent) tile["content"] = {{"uri", t.uri}};
        if (!below.empty()) tile["children"] = std::move(below);
        below = json::array({std::move(tile)});
        belowBox = b;
        belowError = err;
    }
    box = belowBox;
    error = belowError;
    return std::move(below[0]);
}

// Tiles on the longest path from `tile` down.
std::size_t depthOf(const json& tile) {
    std::size_t below = 0;
    if (tile.contains("children"))
        for (const json& c : tile["children"])
            below = std::max(below, depthOf(c));
    return below + 1;
}

// Which stored levels of each entry become tiles, from the directory alone (level errors and
// triangle counts).
// Under REPLACE refinement a tile with its parent's error is refined along with it (the same error
// over a box no farther away), and a child coarser than its parent is not wanted, so errors fall
// strictly going down:
// - a level with the error of the entry's next coarser level is left out (the engine, too, draws
//   the coarsest level within a bound);
// - a tree node starts from its children's hand-over states (preprocess/nodebuild.h) and a child
//   goes on simplifying past that for its own drawing, so a child's chain keeps only its levels
//   below its parent's starting (finest) error, and always its finest;
// - a child whose finest level has its parent's starting error (a node handed over at its start)
//   is left out whole: its own children take its place, and leaves at that error are left out
//   when all children of the parent are such (the parent's finest tile is then a leaf).
// Then the chain is thinned (`ratio` < 1): going up from the finest, a level becomes a tile only
// where it has at most `ratio` times the triangles of the tile below it; the coarsest is kept
// (it takes over from the parent), in place of the last one kept before it where the two are
// closer than `ratio`. Every tile still holds its level's whole mesh, so the stored levels'
// fine spacing made the tiles hold about five times the full-resolution triangles and chains
// of a hundred tiles a client walks down one by one; with ratio 0.5 a chain's tiles hold at
// most twice its finest level's, and a client draws at most 1 / ratio times the triangles of
// the coarsest stored level within its bound.
struct EntryPlan {
    std::vector<std::size_t> levels;  // the stored levels kept, finest first
    bool omitted = false;             // no tile at all (above)
};

std::vector<EntryPlan> planTiles(const std::vector<format::BlockInfo>& infos,
                                 const std::function<double(const format::Level&)>& errorOf,
                                 double ratio) {
    const std::size_t count = infos.size();
    std::vector<double> cap(count, std::numeric_limits<double>::infinity());
    for (const format::BlockInfo& info : infos) {
        if (info.firstChild == format::kNoChild || info.levels.empty()) continue;
        for (std::uint32_t c = 0; c < info.childCount; ++c)
            cap[info.firstChild + c] = errorOf(info.levels.front());
    }
    std::vector<EntryPlan> plans(count);
    for (std::size_t i = 0; i < count; ++i) {
        const std::vector<format::Level>& levels = infos[i].levels;
        for (std::size_t l = 0; l < levels.size(); ++l) {
            const double e = errorOf(levels[l]);
            if (l > 0 && e >= cap[i]) break;  // levels ascend in error: the rest too
            if (l + 1 < levels.size() && errorOf(levels[l + 1]) == e && e < cap[i]) continue;
            plans[i].levels.push_back(l);
        }
        std::vector<std::size_t>& kept = plans[i].levels;
        if (ratio >= 1 || kept.size() <= 2) continue;
        const auto triangles = [&](std::size_t l) { return double(levels[l].triangleCount); };
        std::vector<std::size_t> thinned = {kept.front()};
        for (std::size_t k = 1; k + 1 < kept.size(); ++k)
            if (triangles(kept[k]) <= ratio * triangles(thinned.back())) thinned.push_back(kept[k]);
        if (thinned.size() > 1 && triangles(kept.back()) > ratio * triangles(thinned.back()))
            thinned.pop_back();
        thinned.push_back(kept.back());
        kept = std::move(thinned);
    }
    const auto atCap = [&](std::size_t c) {
        return plans[c].levels.size() == 1 && errorOf(infos[c].levels.front()) >= cap[c];
    };
    const auto leaf = [&](std::size_t c) { return infos[c].firstChild == format::kNoChild; };
    for (std::size_t c = 0; c < count; ++c)
        plans[c].omitted = atCap(c) && !leaf(c);
    // The children that take the place of an entry's finest tile's: omitted ones replaced by
    // theirs.
    std::vector<std::size_t> placed;
    const std::function<void(std::size_t)> place = [&](std::size_t c) {
        if (!plans[c].omitted) {
            placed.push_back(c);
            return;
        }
        for (std::uint32_t g = 0; g < infos[c].childCount; ++g)
            place(infos[c].firstChild + g);
    };
    for (std::size_t i = 0; i < count; ++i) {
        if (plans[i].omitted || leaf(i)) continue;
        placed.clear();
        for (std::uint32_t c = 0; c < infos[i].childCount; ++c)
            place(infos[i].firstChild + c);
        if (std::all_of(placed.begin(), placed.end(),
                        [&](std::size_t c) { return leaf(c) && atCap(c); })) {
            for (std::size_t c : placed)
                plans[c].omitted = true;
        }
    }
    return plans;
}

}  // namespace

bool exportTileset(const TilesetOptions& options, TilesetSummary& summary, std::string& error) {
    summary = {};
    // The output first: a bad -o (an existing folder, the input) fails before the work.
    format::AtomicFile folder;
    if (!folder.openFolder(options.outDir,
                           {.replace = false, .inputs = {options.path}, .inputParts = {}}, error)) {
        return false;
    }
    format::Reader reader;
    if (!reader.open(options.path, error)) return false;
    SelectionOptions so;
    so.metric = options.metric;
    std::uint32_t metric = 0;
    if (!resolveMetric(reader, so, metric, error)) return false;
    const format::Header& header = reader.header();
    const std::string srsText = options.sourceSrs.empty() ? header.crsWkt : options.sourceSrs;
    Georeference geo;
    if (!geo.init(srsText, options.verticalSrs, options.path, header, error)) return false;
    const fs::path temp = folder.tempPath();
    std::error_code ec;
    fs::create_directory(temp / "tiles", ec);
    if (ec) {
        error = options.outDir + ": cannot create the folder 'tiles': " + ec.message();
        return false;
    }

    const std::size_t count = reader.blocks().size();
    const auto errorOf = [metric](const format::Level& level) {
        return double(metric == format::kMetricPaper ? level.errorPaper : level.errorMax);
    };
    const std::vector<EntryPlan> plans = planTiles(reader.blocks(), errorOf, options.tileRatio);
    std::vector<Entry> entries(count);
    std::vector<bool> isChild(count, false);
    std::vector<double> cx, cy, cz;  // box corners
    // --compress: one grid (gltfmodel.h QuantizationGrid), sized from the leaves' directory
    // boxes: their 8 corners in the tileset frame, grown by the sagitta of the Earth's curvature
    // over the diagonal, 1 % and 1 m (a tile that does not fit 16 bits keeps float positions).
    double leafHalfExtent = 0;
    for (std::size_t i = 0; i < count && options.compress; ++i) {
        const format::BlockInfo& b = reader.blocks()[i];
        if (b.level != 0) continue;
        cx.clear(), cy.clear(), cz.clear();
        for (int corner = 0; corner < 8; ++corner) {
            cx.push_back(corner & 1 ? b.maxX : b.minX);
            cy.push_back(corner & 2 ? b.maxY : b.minY);
            cz.push_back(corner & 4 ? b.maxZ : b.minZ);
        }
        if (!geo.toEnu(cx, cy, cz)) {
            error = options.path + ": " + format::blockName(b.col, b.row, b.level) +
                    ": its box does not transform to WGS84 longitude/latitude";
            return false;
        }
        Box box;
        for (int corner = 0; corner < 8; ++corner) {
            const double p[3] = {cx[corner], cy[corner], cz[corner]};
            box.add(p);
        }
        const double diagonal = std::hypot(b.maxX - b.minX, b.maxY - b.minY);
        double half = 0;
        for (int k = 0; k < 3; ++k)
            half = std::max(half, 0.5 * (box.hi[k] - box.lo[k]));
        leafHalfExtent =
            std::max(leafHalfExtent, (half + diagonal * diagonal / (8 * 6.35e6)) * 1.01 + 1.0);
    }
    const QuantizationGrid grid(leafHalfExtent);
    // Which entries are some entry's child (the roots are the others).
    for (std::size_t i = 0; i < count; ++i) {
        const format::BlockInfo& info = reader.blocks()[i];
        if (info.firstChild != format::kNoChild)
            for (std::uint32_t c = 0; c < info.childCount; ++c)
                isChild[info.firstChild + c] = true;
    }
    // The entries on worker threads (options.threads), one entry a task: each task reads its
    // entry (Reader::readBlock is safe to share), transforms it with a Georeference of its own
    // (a PROJ transformation is not), writes its tiles and keeps its sums apart; the sums are
    // added in entry order afterwards, so the output does not depend on the thread count.
    struct Sums {
        std::size_t tiles = 0, floatTiles = 0;
        std::uint64_t vertices = 0, triangles = 0, riverEdges = 0, bytes = 0;
        double maxMove = 0;
        std::string error;
        bool ok = true;
    };
    std::vector<Sums> sums(count);
    engine::WorkerPool pool(options.threads);
    std::vector<std::unique_ptr<Georeference>> geos;  // free ones, under `mutex`
    std::mutex mutex;
    std::size_t done = 0;
    bool failed = false;
    const auto exportEntry = [&](std::size_t i, Georeference& g, Sums& sum) {
        Entry& entry = entries[i];
        const format::BlockInfo& info = reader.blocks()[i];
        entry.firstChild = info.firstChild;
        entry.childCount = info.childCount;
        entry.omitted = plans[i].omitted;
        if (entry.omitted) return true;
        format::Block block;
        std::vector<double> xs, ys, zs, xyz, enu, unsnapped, snapMoves;
        if (!reader.readBlock(i, block, sum.error)) return false;
        const std::size_t n = block.vertices.size();
        xs.resize(n);
        ys.resize(n);
        zs.resize(n);
        for (std::size_t v = 0; v < n; ++v) {
            if (options.compress) {
                exactXY(block, v, xs[v], ys[v]);  // a shared vertex: the same point everywhere
            } else {
                xs[v] = block.originX + double(block.vertices[v].x);
                ys[v] = block.originY + double(block.vertices[v].y);
            }
            zs[v] = block.vertices[v].z;
        }
        if (!g.toEnu(xs, ys, zs)) {
            sum.error = options.path + ": " + format::blockName(block.col, block.row, block.level) +
                        ": a vertex does not transform to WGS84 longitude/latitude" +
                        (g.vertical() ? " and ellipsoidal height (outside the geoid grid?)" : "");
            return false;
        }
        if (options.compress) {
            enu.resize(3 * n);
            snapMoves.resize(n);
            for (std::size_t v = 0; v < n; ++v) {
                enu[3 * v] = xs[v], enu[3 * v + 1] = ys[v], enu[3 * v + 2] = zs[v];
                double p[3] = {xs[v], ys[v], zs[v]};
                // The largest move onto the grid of the vertex prefix [0, v] (a level's).
                snapMoves[v] = std::max(v > 0 ? snapMoves[v - 1] : 0.0, grid.snap(p));
                xs[v] = p[0], ys[v] = p[1], zs[v] = p[2];
            }
        }
        entry.levels.clear();
        for (const std::size_t l : plans[i].levels) {
            const format::Level& level = block.levels[l];
            LevelTile& t = entry.levels.emplace_back();
            t.error = errorOf(level);
            for (std::size_t v = 0; v < level.vertexCount; ++v) {
                const double p[3] = {xs[v], ys[v], zs[v]};
                t.box.add(p);
            }
            if (level.vertexCount == 0 || level.triangleCount + level.riverCount == 0) continue;
            std::array<double, 3> centre = {0.5 * (t.box.lo[0] + t.box.hi[0]),
                                            0.5 * (t.box.lo[1] + t.box.hi[1]),
                                            0.5 * (t.box.lo[2] + t.box.hi[2])};
            GltfEncoding encoding{.compress = options.compress};
            if (options.compress) {
                grid.snap(centre.data());
                encoding.step = grid.step();
            }
            xyz.resize(3 * std::size_t(level.vertexCount));
            for (std::size_t v = 0; v < level.vertexCount; ++v) {
                xyz[3 * v] = xs[v] - centre[0];
                xyz[3 * v + 1] = ys[v] - centre[1];
                xyz[3 * v + 2] = zs[v] - centre[2];
            }
            if (options.compress) {
                unsnapped.resize(xyz.size());
                for (std::size_t k = 0; k < xyz.size(); ++k)
                    unsnapped[k] = enu[k] - centre[k % 3];
                encoding.unsnapped = &unsnapped;
            }
            GltfMaterials materials;
            tinygltf::Model model = newGltfModel("unilod export --3dtiles", encoding, materials);
            LevelCounts counts;
            const std::string name = std::to_string(i) + "-" + std::to_string(l);
            addLevelMesh(model, block, l, xyz, centre, name, encoding, materials, counts);
            if (options.compress) {
                sum.maxMove = std::max(sum.maxMove, snapMoves[level.vertexCount - 1]);
                sum.floatTiles += counts.shortPositions ? 0 : 1;
            }
            std::string glb;
            if (!writeGlb(model, encoding, glb)) {
                sum.error = options.outDir + ": cannot serialize the glTF tile " + name;
                return false;
            }
            t.uri = "tiles/" + name + ".glb";
            t.hasContent = true;
            {
                const std::lock_guard lock(mutex);  // AtomicFile is not shared-safe
                if (!folder.writeInside(t.uri, glb, sum.error)) return false;
            }
            sum.bytes += glb.size();
            sum.vertices += counts.vertices;
            sum.triangles += counts.triangles;
            sum.riverEdges += counts.riverEdges;
            ++sum.tiles;
        }
        return true;
    };
    pool.run(count, [&](std::size_t i) {
        std::unique_ptr<Georeference> g;
        {
            const std::lock_guard lock(mutex);
            if (failed) return;  // a task failed: the export stops
            if (!geos.empty()) {
                g = std::move(geos.back());
                geos.pop_back();
            }
        }
        Sums& sum = sums[i];
        if (!g) {
            g = std::make_unique<Georeference>();
            if (!g->init(srsText, options.verticalSrs, options.path, header, sum.error)) {
                sum.ok = false;
            }
        }
        if (sum.ok) sum.ok = exportEntry(i, *g, sum);
        const std::lock_guard lock(mutex);
        geos.push_back(std::move(g));
        failed = failed || !sum.ok;
        ++done;
        if (options.progress) options.progress(done, count);
    });
    for (const Sums& sum : sums) {  // `failed` is set only with a task's error: found here
        if (!sum.ok) {
            error = sum.error;
            return false;
        }
        summary.tiles += sum.tiles;
        summary.floatTiles += sum.floatTiles;
        summary.vertices += sum.vertices;
        summary.triangles += sum.triangles;
        summary.riverEdges += sum.riverEdges;
        summary.bytes += sum.bytes;
        summary.maxQuantizationError = std::max(summary.maxQuantizationError, sum.maxMove);
    }
    summary.entries = count;

    // Roots: entries that are no entry's child (one for a built hierarchy).
    std::vector<std::size_t> roots;
    for (std::size_t i = 0; i < count; ++i)
        if (!isChild[i]) roots.push_back(i);
    json root;
    Box modelBox;
    double rootError = 0;
    if (roots.size() == 1) {
        root = chainTile(entries, roots[0], modelBox, rootError);
    } else {
        // Several roots: a root without content that always refines (its error is the model's
        // diagonal, more than any level's).
        json children = json::array();
        for (std::size_t r : roots) {
            Box b;
            double err = 0;
            children.push_back(chainTile(entries, r, b, err));
            modelBox.add(b);
            rootError = std::max(rootError, err);
        }
        const double diagonal = std::hypot(header.maxX - header.minX, header.maxY - header.minY,
                                           header.maxZ - header.minZ);
        rootError = std::max(rootError, diagonal);
        root = {{"boundingVolume", {{"box", modelBox.toJson()}}},
                {"geometricError", rootError},
                {"refine", "REPLACE"},
                {"children", std::move(children)}};
    }
    root["transform"] = geo.transform();
    const std::size_t depth = depthOf(root);
    const double diagonal = std::hypot(header.maxX - header.minX, header.maxY - header.minY,
                                       header.maxZ - header.minZ);
    json tileset = {
        {"asset",
         {{"version", "1.1"}, {"generator", kTilesetGenerator}, {"tilesetVersion", "1"}}},
        {"geometricError", std::max(diagonal, rootError)},
        {"root", std::move(root)},
        {"extras",
         {{"source", validUtf8(options.path)},
          {"crs_wkt", validUtf8(options.sourceSrs.empty() ? header.crsWkt : options.sourceSrs)},
          {"metric", format::metricName(metric)},
          {"tile_ratio", options.tileRatio},
          {"origin_longitude_degrees", geo.longitude()},
          {"origin_latitude_degrees", geo.latitude()},
          {"heights", options.verticalSrs.empty()
                          ? "the file's z taken as WGS84 ellipsoidal heights (no geoid applied)"
                          : "the file's z in the vertical CRS " + validUtf8(options.verticalSrs) +
                                ", converted to WGS84 ellipsoidal heights by PROJ"},
          {"layout",
           "root transform: east-north-up frame at the origin longitude/latitude, height 0 on "
           "WGS84, to ECEF; vertices exact (file CRS -> WGS84 via PROJ, z as ellipsoidal "
           "height). Every .ulod entry (block or hierarchy node) is a chain of tiles, one per "
           "kept stored level, coarsest first (refine REPLACE), going up a chain at most "
           "--tile-ratio times the triangles of the tile below; the finest's children are the "
           "child entries' chains. geometricError = the level's stored error (metric), falling "
           "strictly going down: a level with the error of the next coarser one, a child's levels "
           "at or above its parent's finest error, and a node handed over at its start (its "
           "children in its place) are left out. Content tiles/<entry>-<level>.glb."}}}};
    if (options.compress) {
        tileset["extras"]["compression"] =
            "positions on one grid (16-bit with KHR_mesh_quantization where a tile fits, else "
            "float), 8-bit octahedral normals (meshopt filter), EXT_meshopt_compression";
        tileset["extras"]["quantization_step_m"] = grid.step();
        tileset["extras"]["max_quantization_error_m"] = summary.maxQuantizationError;
    }
    const std::string text = tileset.dump(1) + "\n";
    if (!folder.writeInside("tileset.json", text, error)) return false;
    summary.bytes += text.size();
    summary.rootError = rootError;
    summary.depth = depth;
    summary.longitude = geo.longitude();
    summary.latitude = geo.latitude();
    return folder.commit(error);
}

std::string tilesetForeignPart(const std::filesystem::directory_entry& entry) {
    namespace fs = std::filesystem;
    const std::string name = entry.path().filename().string();
    std::error_code ec;
    if (entry.is_symlink(ec)) return name;
    // A regular file of a tileset's size only (a FIFO would block the read; the largest model's
    // tileset.json is some MB, a file of GBs would be parsed whole).
    constexpr std::uintmax_t kMaxTilesetBytes = std::uintmax_t(256) << 20;
    if (name == "tileset.json" && entry.is_regular_file(ec)) {
        if (entry.file_size(ec) > kMaxTilesetBytes || ec) return name;
        std::ifstream in(entry.path(), std::ios::binary);
        const json j = json::parse(in, nullptr, false);
        const bool ours = j.is_object() && j.contains("asset") && j["asset"].is_object() &&
                          j["asset"].contains("generator") &&
                          j["asset"]["generator"] == kTilesetGenerator;
        return ours ? "" : name;
    }
    if (name == "tiles" && entry.is_directory(ec)) {
        std::vector<std::string> other;
        // Advanced with an error code: the range-for's increment throws on a read error.
        for (fs::directory_iterator it(entry.path(), ec), end; !ec && it != end; it.increment(ec)) {
            const std::string t = it->path().filename().string();
            std::error_code te;
            const bool glb = t.size() > 4 && t.compare(t.size() - 4, 4, ".glb") == 0;
            if (!glb || it->is_symlink(te) || !it->is_regular_file(te)) other.push_back(t);
        }
        if (ec) return name;  // unreadable: not known to be ours
        if (other.empty()) return "";
        return "tiles/" + *std::min_element(other.begin(), other.end());
    }
    return name;
}

}  // namespace unilod::exporter
