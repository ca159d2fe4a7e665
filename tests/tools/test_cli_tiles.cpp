// `unilod export --3dtiles` (tools/export/tiles3d.h) on the bundled Jacksboro model:
// - the tileset's structure (with --tile-ratio 1): every entry a chain of one tile per stored
//   level (coarsest first), refine REPLACE, geometricError the level's stored `max` error and
//   falling going down (levels a client would never draw at rest left out), every child's box
//   inside its parent's, every content file a glTF that tinygltf loads, with the level's
//   triangle and river edge counts;
// - the default thinning of the chains by triangle counts (--tile-ratio 0.5);
// - the georeference, checked against PROJ independently: tile positions (glTF, y-up, relative to
//   the node translation) mapped through the root transform must land on the ECEF coordinates
//   that GDAL/PROJ gives for the block's world vertices (file CRS -> EPSG:4978);
// - usage and data errors: no CRS without --s-srs, an existing folder, --3dtiles with -o;
// - the real client: CesiumJS in headless Chromium (tests/cesium/run.mjs) loads it, draws the
//   terrain and blue rivers, and selects fewer tiles from far away, for the plain and the
//   --compress tileset. Skipped only where Chromium cannot start (run.mjs exits 77 and says why);
// - --compress: the same tree and tiles, each tile the same mesh within the reported bound, no
//   crack between tiles of entries a client may draw side by side, a fraction of the bytes.
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <tiny_gltf.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>

#include "testutil.h"
#include "tools/cliutil.h"
#include "tools/glbcheck.h"
#include "ulod.h"

using namespace unilod;
namespace fs = std::filesystem;
using nlohmann::json;
using unilod::test::q;
using unilod::test::runCli;

namespace {

const std::string kDem = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif";
const std::string kRivers = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson";

class TilesTest : public ::testing::Test {
protected:
    static inline test::TempDir* dir = nullptr;
    static inline std::string model, tiles, tilesAll, packed;
    static inline test::Model m;
    static inline json tileset, tilesetAll;  // default; --tile-ratio 1 (every level drawn at rest)

    static void SetUpTestSuite() {
        dir = new test::TempDir("tiles");
        model = dir->file("j.ulod");
        tiles = dir->file("tiles");
        auto r = runCli("build -q " + q(kDem) + " " + q(kRivers) + " -o " + q(model) +
                        " --block-size 64");
        ASSERT_EQ(r.code, 0) << r.err;
        r = runCli("export -q " + q(model) + " --3dtiles " + q(tiles));
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_NE(r.out.find("3D Tiles 1.1 tileset"), std::string::npos) << r.out;
        packed = dir->file("tiles_packed");
        r = runCli("export -q " + q(model) + " --3dtiles " + q(packed) + " --compress");
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_NE(r.out.find("compressed: positions within"), std::string::npos) << r.out;
        tilesAll = dir->file("tiles_all");
        r = runCli("export -q " + q(model) + " --3dtiles " + q(tilesAll) + " --tile-ratio 1");
        ASSERT_EQ(r.code, 0) << r.err;
        std::string error;
        ASSERT_TRUE(test::readModel(model, m, error)) << error;
        tileset = json::parse(test::slurp(tiles + "/tileset.json"));
        tilesetAll = json::parse(test::slurp(tilesAll + "/tileset.json"));
    }
    static void TearDownTestSuite() {
        delete dir;
        dir = nullptr;
    }

    static tinygltf::Model load(const std::string& path) {
        tinygltf::Model g;
        tinygltf::TinyGLTF loader;
        std::string err, warn;
        EXPECT_TRUE(loader.LoadBinaryFromFile(&g, &err, &warn, path)) << path << err << warn;
        return g;
    }
    // "tiles/<entry>-<level>.glb" -> entry, level.
    static std::pair<std::size_t, std::size_t> parseUri(const std::string& uri) {
        std::size_t e = 0, l = 0;
        EXPECT_EQ(std::sscanf(uri.c_str(), "tiles/%zu-%zu.glb", &e, &l), 2) << uri;
        return {e, l};
    }
};

bool inside(const json& child, const json& parent) {
    for (int k = 0; k < 3; ++k) {
        const double c = child[k], ch = child[3 + 4 * k], p = parent[k], ph = parent[3 + 4 * k];
        if (c - ch < p - ph - 1e-6 || c + ch > p + ph + 1e-6) return false;
    }
    return true;
}

TEST_F(TilesTest, ChainsOfLevelsUnderTheHierarchy) {
    // With --tile-ratio 1: every level a client would draw at rest is a tile.
    EXPECT_EQ(tilesetAll["asset"]["version"], "1.1");
    const json& root = tilesetAll["root"];
    ASSERT_TRUE(root.contains("transform"));
    // A level is left out where a client would never draw it at rest: a child's level at or
    // above its parent's starting error (a child simplifies on past the state its parent starts
    // from; such a tile is refined along with its parent or would be coarser than it), and a
    // level with the error of the entry's next coarser level. An entry whose only such level is
    // its finest, at its parent's starting error, may be left out whole (its children, or for
    // leaves nothing, in its place): checked below by what the tiles cover.
    std::vector<double> cap(m.blocks.size(), std::numeric_limits<double>::infinity());
    for (const format::Block& b : m.blocks)
        for (std::uint32_t c = 0; c < b.childCount; ++c)
            cap[b.firstChild + c] = b.levels.front().errorMax;
    std::vector<std::vector<std::size_t>> kept(m.blocks.size());
    std::size_t aboveCap = 0, sameError = 0;
    for (std::size_t i = 0; i < m.blocks.size(); ++i) {
        const std::vector<format::Level>& levels = m.blocks[i].levels;
        for (std::size_t l = 0; l < levels.size(); ++l) {
            if (l > 0 && levels[l].errorMax >= cap[i]) {
                ++aboveCap;
            } else if (l + 1 < levels.size() && levels[l + 1].errorMax == levels[l].errorMax &&
                       levels[l].errorMax < cap[i]) {
                ++sameError;
            } else {
                kept[i].push_back(l);
            }
        }
        ASSERT_FALSE(kept[i].empty()) << "entry " << i;
    }
    // The bundled model has all three: leaves simplify past their hand-over, a node's running
    // maximum stays flat over several stored levels (the root's five coarsest share one), and
    // nodes hand over at their start.
    EXPECT_GT(aboveCap, 0u);
    EXPECT_GT(sameError, 0u);
    // The leaf blocks under an entry.
    std::vector<std::vector<std::size_t>> leaves(m.blocks.size());
    std::function<void(std::size_t, std::vector<std::size_t>&)> collect =
        [&](std::size_t i, std::vector<std::size_t>& out) {
            const format::Block& b = m.blocks[i];
            if (b.firstChild == format::kNoChild) out.push_back(i);
            for (std::uint32_t c = 0; c < b.childCount; ++c)
                collect(b.firstChild + c, out);
        };
    for (std::size_t i = 0; i < m.blocks.size(); ++i) {
        collect(i, leaves[i]);
        std::sort(leaves[i].begin(), leaves[i].end());
    }
    std::vector<std::vector<int>> seen(m.blocks.size());
    for (std::size_t i = 0; i < m.blocks.size(); ++i)
        seen[i].assign(m.blocks[i].levels.size(), 0);
    std::size_t tileCount = 0;
    std::function<void(const json&, const json*)> walk = [&](const json& t, const json* parent) {
        ++tileCount;
        EXPECT_EQ(t["refine"], "REPLACE");
        ASSERT_TRUE(t.contains("content"));
        const auto [e, l] = parseUri(t["content"]["uri"]);
        ASSERT_LT(e, m.blocks.size());
        ASSERT_LT(l, m.blocks[e].levels.size());
        ++seen[e][l];
        const format::Block& b = m.blocks[e];
        EXPECT_GE(double(t["geometricError"]), double(b.levels[l].errorMax));
        if (parent != nullptr) {
            // Strictly: a child with its parent's error is never drawn at rest.
            EXPECT_LT(double(t["geometricError"]), double((*parent)["geometricError"]))
                << t["content"]["uri"];
            EXPECT_TRUE(inside(t["boundingVolume"]["box"], (*parent)["boundingVolume"]["box"]))
                << t["content"]["uri"];
        }
        const json children = t.value("children", json::array());
        const auto at = std::find(kept[e].begin(), kept[e].end(), l);
        ASSERT_NE(at, kept[e].end()) << "entry " << e << " level " << l << " is left out";
        if (at != kept[e].begin()) {
            ASSERT_EQ(children.size(), 1u);
            EXPECT_EQ(parseUri(children[0]["content"]["uri"]), std::make_pair(e, *(at - 1)));
        } else if (children.empty()) {
            // A finest tile without children: a leaf block, or a node whose leaves hold no
            // smaller error at full resolution.
            for (std::size_t leaf : leaves[e])
                EXPECT_GE(m.blocks[leaf].levels.front().errorMax, b.levels.front().errorMax)
                    << "entry " << e << " leaf " << leaf;
        } else {
            // The finest tile's children cover the entry's leaf blocks once each, each child the
            // coarsest kept level of an entry below.
            std::vector<std::size_t> covered;
            for (const json& c : children) {
                const auto [ce, cl] = parseUri(c["content"]["uri"]);
                EXPECT_EQ(cl, kept[ce].back()) << "entry " << ce;
                covered.insert(covered.end(), leaves[ce].begin(), leaves[ce].end());
            }
            std::sort(covered.begin(), covered.end());
            EXPECT_EQ(covered, leaves[e]) << "entry " << e;
        }
        for (const json& c : children)
            walk(c, &t);
    };
    walk(root, nullptr);
    // Every kept level of an entry that has tiles appears once; an entry without tiles had one
    // kept level, its finest, at its parent's starting error.
    std::size_t levels = 0, omitted = 0;
    for (std::size_t i = 0; i < m.blocks.size(); ++i) {
        const bool anySeen = std::any_of(seen[i].begin(), seen[i].end(), [](int n) { return n; });
        if (!anySeen) {
            ++omitted;
            EXPECT_EQ(kept[i].size(), 1u) << "entry " << i;
            EXPECT_GE(m.blocks[i].levels.front().errorMax, cap[i]) << "entry " << i;
            continue;
        }
        for (std::size_t l = 0; l < seen[i].size(); ++l) {
            const bool isKept = std::find(kept[i].begin(), kept[i].end(), l) != kept[i].end();
            EXPECT_EQ(seen[i][l], isKept ? 1 : 0) << "entry " << i << " level " << l;
        }
        levels += kept[i].size();
    }
    EXPECT_GT(omitted, 0u);
    EXPECT_EQ(tileCount, levels);
    EXPECT_EQ(std::size_t(std::distance(fs::directory_iterator(tilesAll + "/tiles"),
                                        fs::directory_iterator())),
              tileCount);  // no file that no tile names
    // The root is the hierarchy's root entry at its coarsest level.
    EXPECT_EQ(parseUri(root["content"]["uri"]).first, m.blocks.size() - 1);
}

// The default tileset thins the chains (--tile-ratio 0.5): its tiles are some of the
// every-level tileset's, with the same structure rules, each entry's finest and coarsest kept;
// going up a chain a tile has at most half the triangles of the one below (but where only the
// two ends are left), so a chain's tiles hold at most twice its finest tile's triangles.
TEST_F(TilesTest, DefaultChainsAreThinnedByTriangles) {
    using Tile = std::pair<std::size_t, std::size_t>;  // entry, level
    const auto collect = [](const json& t, std::map<Tile, const json*>& out) {
        std::function<void(const json&)> walk = [&](const json& x) {
            std::size_t e = 0, l = 0;
            EXPECT_EQ(
                std::sscanf(std::string(x["content"]["uri"]).c_str(), "tiles/%zu-%zu.glb", &e, &l),
                2);
            EXPECT_TRUE(out.emplace(Tile{e, l}, &x).second);
            if (x.contains("children"))
                for (const json& c : x["children"])
                    walk(c);
        };
        walk(t);
    };
    std::map<Tile, const json*> thin, all;
    collect(tileset["root"], thin);
    collect(tilesetAll["root"], all);
    EXPECT_LT(thin.size() * 2, all.size());  // the bundled model: 142 of 503
    std::map<std::size_t, std::vector<std::size_t>> chainThin, chainAll;  // levels, finest first
    for (const auto& [t, x] : thin) {
        ASSERT_TRUE(all.count(t)) << t.first << "-" << t.second;
        EXPECT_EQ(double((*x)["geometricError"]), double((*all.at(t))["geometricError"]));
        chainThin[t.first].push_back(t.second);
    }
    for (const auto& [t, x] : all)
        chainAll[t.first].push_back(t.second);
    EXPECT_EQ(chainThin.size(), chainAll.size());  // the same entries have tiles
    const auto triangles = [&](std::size_t e, std::size_t l) {
        return double(m.blocks[e].levels[l].triangleCount);
    };
    std::size_t thinned = 0;
    for (const auto& [e, levels] : chainAll) {
        const std::vector<std::size_t>& kept = chainThin[e];
        ASSERT_FALSE(kept.empty()) << "entry " << e;
        EXPECT_EQ(kept.front(), levels.front()) << "entry " << e;
        EXPECT_EQ(kept.back(), levels.back()) << "entry " << e;
        double sum = 0;
        for (std::size_t k = 0; k < kept.size(); ++k) {
            sum += triangles(e, kept[k]);
            if (k > 0 && kept.size() > 2) {
                EXPECT_LE(triangles(e, kept[k]), 0.5 * triangles(e, kept[k - 1]))
                    << "entry " << e << " level " << kept[k];
            }
            // Chained as in the every-level tileset: a tile above a finer one of its entry.
            if (k > 0) {
                const json& upper = *thin.at({e, kept[k]});
                ASSERT_EQ(upper["children"].size(), 1u);
                EXPECT_EQ(
                    upper["children"][0]["content"]["uri"],
                    "tiles/" + std::to_string(e) + "-" + std::to_string(kept[k - 1]) + ".glb");
            }
        }
        EXPECT_LE(sum, 2 * triangles(e, kept.front())) << "entry " << e;
        thinned += levels.size() - kept.size();
    }
    EXPECT_GT(thinned, 0u);
    // No file that no tile names.
    EXPECT_EQ(std::size_t(std::distance(fs::directory_iterator(tiles + "/tiles"),
                                        fs::directory_iterator())),
              thin.size());
    // --tile-ratio is checked and belongs to --3dtiles.
    for (const std::string& bad : {" --tile-ratio 0 --3dtiles " + q(dir->file("r0")),
                                   " --tile-ratio 1.5 --3dtiles " + q(dir->file("r1")),
                                   " --tile-ratio nan --3dtiles " + q(dir->file("r2")),
                                   " --tile-ratio 0.5 -o " + q(dir->file("r.glb"))}) {
        const auto r = runCli("export -q " + q(model) + bad);
        EXPECT_EQ(r.code, 2) << bad << "\n" << r.err;
        EXPECT_NE(r.err.find("tile-ratio"), std::string::npos) << r.err;
    }
}

// Every tile of the tileset in `set` checked against the .ulod level (counts); on every 7th tile
// (by name) every 13th vertex mapped through the root transform to ECEF, compared with what PROJ
// gives from `src` (the file's CRS, with its heights' vertical CRS or without) to EPSG:4978.
// Returns the worst distance; `mine` receives the ECEF points in order.
double againstProj(const std::string& set, const test::Model& m, OGRSpatialReference& src,
                   std::vector<std::array<double, 3>>& mine) {
    const json ts = json::parse(test::slurp(set + "/tileset.json"));
    const json& tr = ts["root"]["transform"];
    EXPECT_EQ(tr.size(), 16u);
    auto toEcef = [&](const double enu[3], double out[3]) {
        for (int r = 0; r < 3; ++r)
            out[r] = double(tr[r]) * enu[0] + double(tr[4 + r]) * enu[1] +
                     double(tr[8 + r]) * enu[2] + double(tr[12 + r]);
    };
    OGRSpatialReference ecef;
    EXPECT_EQ(ecef.importFromEPSG(4978), OGRERR_NONE);
    src.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    ecef.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    OGRCoordinateTransformationOptions options;
    options.SetBallparkAllowed(false);
    std::unique_ptr<OGRCoordinateTransformation> ct(
        OGRCreateCoordinateTransformation(&src, &ecef, options));
    EXPECT_TRUE(ct);
    if (!ct) return HUGE_VAL;
    std::vector<std::string> names;
    for (const auto& file : fs::directory_iterator(set + "/tiles"))
        names.push_back(file.path().filename().string());
    std::sort(names.begin(), names.end());
    std::size_t checkedTiles = 0;
    double worst = 0;
    for (const std::string& name : names) {
        std::size_t e = 0, l = 0;
        EXPECT_EQ(std::sscanf(name.c_str(), "%zu-%zu.glb", &e, &l), 2) << name;
        const format::Block& b = m.blocks.at(e);
        const format::Level& level = b.levels.at(l);
        tinygltf::Model g;
        tinygltf::TinyGLTF loader;
        std::string err, warn;
        EXPECT_TRUE(loader.LoadBinaryFromFile(&g, &err, &warn, set + "/tiles/" + name)) << err;
        EXPECT_EQ(g.nodes.size(), 1u);
        EXPECT_EQ(g.meshes.size(), 1u);
        if (g.meshes.size() != 1 || g.meshes[0].primitives.empty()) return HUGE_VAL;
        const tinygltf::Mesh& mesh = g.meshes[0];
        const tinygltf::Primitive& terrain = mesh.primitives[0];
        EXPECT_EQ(terrain.mode, TINYGLTF_MODE_TRIANGLES);
        EXPECT_EQ(g.accessors[std::size_t(terrain.indices)].count, 3u * level.triangleCount);
        const std::size_t lines =
            mesh.primitives.size() > 1 ? g.accessors[std::size_t(mesh.primitives[1].indices)].count
                                       : 0;
        EXPECT_EQ(lines, 2u * level.riverCount);
        if (mesh.primitives.size() > 1) {
            EXPECT_EQ(mesh.primitives[1].mode, TINYGLTF_MODE_LINE);
        }
        const tinygltf::Accessor& pa = g.accessors[std::size_t(terrain.attributes.at("POSITION"))];
        EXPECT_EQ(pa.count, level.vertexCount);
        if (++checkedTiles % 7 != 0) continue;
        const tinygltf::BufferView& v = g.bufferViews[std::size_t(pa.bufferView)];
        const float* p =
            reinterpret_cast<const float*>(g.buffers[0].data.data() + v.byteOffset + pa.byteOffset);
        const std::vector<double>& t = g.nodes[0].translation;
        EXPECT_EQ(t.size(), 3u);
        for (std::size_t i = 0; i < pa.count && t.size() == 3; i += 13) {
            // glTF (x, y, z) y-up -> ENU (x, -z, y).
            const double gx = t[0] + p[3 * i], gy = t[1] + p[3 * i + 1], gz = t[2] + p[3 * i + 2];
            const double enu[3] = {gx, -gz, gy};
            std::array<double, 3> at{};
            toEcef(enu, at.data());
            mine.push_back(at);
            double x = b.originX + double(b.vertices[i].x), y = b.originY + double(b.vertices[i].y),
                   z = b.vertices[i].z;
            EXPECT_TRUE(ct->Transform(1, &x, &y, &z));
            worst = std::max(worst, std::hypot(at[0] - x, at[1] - y, at[2] - z));
        }
    }
    return worst;
}

TEST_F(TilesTest, ContentIsTheLevelAndLandsWherePROJPutsIt) {
    // PROJ's own answer: the file's CRS -> geocentric WGS84 (EPSG:4978), z as ellipsoidal height.
    OGRSpatialReference src;
    ASSERT_EQ(src.SetFromUserInput(m.header.crsWkt.c_str()), OGRERR_NONE);
    std::vector<std::array<double, 3>> mine;
    const double worst = againstProj(tiles, m, src, mine);
    EXPECT_GT(mine.size(), 1000u);
    // Float positions relative to tile centres a few km away: millimetres.
    EXPECT_LT(worst, 0.02) << "worst distance to PROJ's ECEF point " << worst << " m";
}

// --vertical-crs EPSG:5773: the file's z are EGM96 heights; PROJ (Debian's proj-data has the
// EGM96 grid) makes them ellipsoidal, about 30 m lower at Jacksboro.
TEST_F(TilesTest, VerticalCrsMakesHeightsEllipsoidal) {
    const std::string egm = dir->file("tiles_egm96");
    const auto r =
        runCli("export -q " + q(model) + " --3dtiles " + q(egm) + " --vertical-crs EPSG:5773");
    ASSERT_EQ(r.code, 0) << r.err;
    const json ts = json::parse(test::slurp(egm + "/tileset.json"));
    EXPECT_NE(std::string(ts["extras"]["heights"]).find("EPSG:5773"), std::string::npos);
    OGRSpatialReference horizontal, vertical, compound;
    ASSERT_EQ(horizontal.SetFromUserInput(m.header.crsWkt.c_str()), OGRERR_NONE);
    ASSERT_EQ(vertical.importFromEPSG(5773), OGRERR_NONE);
    ASSERT_EQ(compound.SetCompoundCS("test", &horizontal, &vertical), OGRERR_NONE);
    std::vector<std::array<double, 3>> shifted, plain;
    const double worst = againstProj(egm, m, compound, shifted);
    EXPECT_GT(shifted.size(), 1000u);
    EXPECT_LT(worst, 0.02) << "worst distance to PROJ's ECEF point " << worst << " m";
    // The same vertices in the plain tileset: the geoid undulation apart.
    againstProj(tiles, m, horizontal, plain);
    ASSERT_EQ(plain.size(), shifted.size());
    for (std::size_t i = 0; i < plain.size(); i += 97) {
        const double d = std::hypot(plain[i][0] - shifted[i][0], plain[i][1] - shifted[i][1],
                                    plain[i][2] - shifted[i][2]);
        EXPECT_GT(d, 25.0);
        EXPECT_LT(d, 40.0);
    }
    // Not a vertical CRS: refused, no folder.
    const std::string bad = dir->file("tiles_bad_vertical");
    const auto b =
        runCli("export -q " + q(model) + " --3dtiles " + q(bad) + " --vertical-crs EPSG:4326");
    EXPECT_EQ(b.code, 1);
    EXPECT_NE(b.err.find("not a vertical CRS"), std::string::npos) << b.err;
    EXPECT_FALSE(fs::exists(bad));
}

// The entries are exported on worker threads: the same bytes for any count (the fixture's
// tileset used every core).
TEST_F(TilesTest, SameTilesetForAnyThreadCount) {
    for (const char* threads : {"1", "3"}) {
        SCOPED_TRACE(threads);
        const std::string out = dir->file(std::string("tiles_threads_") + threads);
        const auto r =
            runCli("export -q " + q(model) + " --3dtiles " + q(out) + " --threads " + threads);
        ASSERT_EQ(r.code, 0) << r.err;
        std::size_t files = 0;
        for (const auto& f : fs::recursive_directory_iterator(tiles)) {
            if (!f.is_regular_file()) continue;
            const std::string rel = fs::relative(f.path(), tiles).string();
            EXPECT_EQ(test::slurp(out + "/" + rel), test::slurp(f.path().string())) << rel;
            ++files;
        }
        EXPECT_GT(files, 100u);
        EXPECT_EQ(std::distance(fs::recursive_directory_iterator(out),
                                fs::recursive_directory_iterator()),
                  std::distance(fs::recursive_directory_iterator(tiles),
                                fs::recursive_directory_iterator()));
    }
    EXPECT_EQ(
        runCli("export -q " + q(model) + " --3dtiles " + q(dir->file("t17")) + " --threads 17")
            .code,
        2);
    EXPECT_EQ(
        runCli("export -q " + q(model) + " -o " + q(dir->file("t.glb")) + " --threads 2").code, 2);
}

TEST_F(TilesTest, ErrorsLeaveNoFolder) {
    // --3dtiles with -o, or with a camera: usage errors.
    const std::string out = dir->file("bad");
    EXPECT_EQ(runCli("export " + q(model) + " --3dtiles " + q(out) + " -o " + q(dir->file("x.glb")))
                  .code,
              2);
    EXPECT_EQ(runCli("export " + q(model) + " --3dtiles " + q(out) + " --h-lim 5").code, 2);
    EXPECT_FALSE(fs::exists(out));
    // An existing, non-empty output folder is refused and left alone.
    auto r = runCli("export -q " + q(model) + " --3dtiles " + q(tiles));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(tiles), std::string::npos) << r.err;
    EXPECT_TRUE(fs::exists(tiles + "/tileset.json"));
    // --overwrite replaces an earlier tileset, never a folder holding anything else (here a
    // stray file: it was removed with the folder until 2026-12-03).
    const std::string again = dir->file("again");
    const std::string overwrite =
        "export -q " + q(model) + " --3dtiles " + q(again) + " --overwrite";
    // --overwrite refused, naming `part`: exit 1.
    const auto expectRefused = [&](const std::string& part) {
        const auto refused = runCli(overwrite);
        EXPECT_EQ(refused.code, 1);
        EXPECT_NE(refused.err.find(again + ": holds '" + part + "', not of a 3D Tiles tileset"),
                  std::string::npos)
            << refused.err;
    };
    fs::create_directory(again);
    std::ofstream(again + "/stray.txt") << "old";
    expectRefused("stray.txt");
    EXPECT_EQ(test::slurp(again + "/stray.txt"), "old");
    EXPECT_FALSE(fs::exists(again + "/tileset.json"));
    fs::remove(again + "/stray.txt");
    r = runCli("export -q " + q(model) + " --3dtiles " + q(again));
    EXPECT_EQ(r.code, 0) << r.err;
    std::ofstream(again + "/tiles/old.glb") << "old";  // a tile of the earlier tileset
    r = runCli(overwrite);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(again + "/tileset.json"));
    EXPECT_FALSE(fs::exists(again + "/tiles/old.glb"));  // replaced whole
    // Only a tileset of unilod's: a tiles/ folder holding other files, or another tool's
    // tileset.json, is refused by name and left as it was (both were replaced until 2026-12-08).
    std::ofstream(again + "/tiles/notes.txt") << "mine";
    expectRefused("tiles/notes.txt");
    EXPECT_EQ(test::slurp(again + "/tiles/notes.txt"), "mine");
    fs::remove(again + "/tiles/notes.txt");
    const std::string own = test::slurp(again + "/tileset.json");
    json other = json::parse(own);
    other["asset"]["generator"] = "another tool";
    std::ofstream(again + "/tileset.json", std::ios::trunc) << other.dump();
    expectRefused("tileset.json");
    EXPECT_EQ(json::parse(test::slurp(again + "/tileset.json"))["asset"]["generator"],
              "another tool");
    std::ofstream(again + "/tileset.json", std::ios::trunc) << own;
    r = runCli(overwrite);
    EXPECT_EQ(r.code, 0) << r.err;
    r = runCli("export -q " + q(model) + " --3dtiles " + q(out) + " --s-srs NOT_A_CRS");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("NOT_A_CRS"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    // A CRS whose unit is not the model's metres (degrees, geocentric, feet) would place the
    // model anywhere (EPSG:4326 made "longitude 746430"): refused by name, nothing written.
    for (const char* crs : {"EPSG:4326", "EPSG:4978", "EPSG:2236"}) {
        r = runCli("export -q " + q(model) + " --3dtiles " + q(out) + " --s-srs " + crs);
        EXPECT_EQ(r.code, 1) << crs;
        EXPECT_NE(r.err.find("is not a projected CRS in metres"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(out));
    }
}

TEST_F(TilesTest, AModelWithoutCrsNeedsSSrs) {
    // An ESRI ASCII grid without .prj (no CRS) and no rivers: a model whose header has no CRS.
    const std::string asc = dir->file("nocrs.asc"), rivers = dir->file("none.geojson");
    {
        std::ofstream a(asc);
        a << "ncols 24\nnrows 24\nxllcorner 740000\nyllcorner 4050000\ncellsize 30\n";
        for (int r = 0; r < 24; ++r) {
            for (int c = 0; c < 24; ++c)
                a << 300 + 2 * r + ((c * 7 + r * 3) % 5) << (c + 1 < 24 ? " " : "\n");
        }
        std::ofstream(rivers) << R"({"type":"FeatureCollection","features":[]})";
    }
    const std::string plain = dir->file("nocrs.ulod"), out = dir->file("nocrs_tiles");
    auto r = runCli("build -q " + q(asc) + " " + q(rivers) + " -o " + q(plain));
    ASSERT_EQ(r.code, 0) << r.err;
    r = runCli("export -q " + q(plain) + " --3dtiles " + q(out));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(plain), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--s-srs"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    // Placed with --s-srs: the frame's origin is the extent's centre in that CRS (PROJ here).
    r = runCli("export -q " + q(plain) + " --3dtiles " + q(out) + " --s-srs EPSG:32616");
    ASSERT_EQ(r.code, 0) << r.err;
    const json t = json::parse(test::slurp(out + "/tileset.json"));
    test::Model pm;
    std::string error;
    ASSERT_TRUE(test::readModel(plain, pm, error)) << error;
    EXPECT_TRUE(pm.header.crsWkt.empty());
    OGRSpatialReference utm, wgs84;
    ASSERT_EQ(utm.importFromEPSG(32616), OGRERR_NONE);
    ASSERT_EQ(wgs84.importFromEPSG(4326), OGRERR_NONE);
    utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&utm, &wgs84));
    ASSERT_TRUE(ct);
    double x = 0.5 * (pm.header.minX + pm.header.maxX), y = 0.5 * (pm.header.minY + pm.header.maxY);
    ASSERT_TRUE(ct->Transform(1, &x, &y));
    EXPECT_NEAR(double(t["extras"]["origin_longitude_degrees"]), x, 1e-9);
    EXPECT_NEAR(double(t["extras"]["origin_latitude_degrees"]), y, 1e-9);
    EXPECT_NEAR(x, -84.3, 0.1);  // the grid's corner (740000, 4050000) in UTM 16N
}

TEST_F(TilesTest, CesiumJSInHeadlessChromiumDrawsIt) {
    const std::string script = std::string(UNILOD_SOURCE_DIR) + "/tests/cesium/run.mjs";
    for (const std::string& set : {tiles, packed}) {
        SCOPED_TRACE(set);
        const std::string log = dir->file("cesium.log");
        const std::string shots = set + "_cesium";
        const std::string command = "node " + q(script) + " --tileset " + q(set) + " --out " +
                                    q(shots) + " >" + q(log) + " 2>&1";
        const int status = std::system(command.c_str());
        const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        const std::string text = test::slurp(log);
        if (code == 77) GTEST_SKIP() << text;
        EXPECT_EQ(code, 0) << text;
        std::printf("%s", text.c_str());
        EXPECT_TRUE(fs::exists(shots + "_near.png"));
    }
}

TEST_F(TilesTest, CompressedTilesetIsTheSameTilesWithoutCracks) {
    const json p = json::parse(test::slurp(packed + "/tileset.json"));
    const double bound = p["extras"]["max_quantization_error_m"];
    EXPECT_GT(bound, 0.0);
    EXPECT_LT(bound, 1.0);
    const double step = p["extras"]["quantization_step_m"];  // a power of two, bounding moves
    EXPECT_EQ(std::exp2(std::round(std::log2(step))), step);
    EXPECT_LE(bound, 0.5 * step);
    // The same tree: content, errors, refinement, children, node for node.
    std::vector<std::string> uris;
    std::function<void(const json&, const json&)> same = [&](const json& a, const json& b) {
        EXPECT_EQ(a.value("geometricError", -1.0), b.value("geometricError", -1.0));
        EXPECT_EQ(a.value("refine", ""), b.value("refine", ""));
        EXPECT_EQ(a.contains("content"), b.contains("content"));
        if (a.contains("content") && b.contains("content")) {
            EXPECT_EQ(a["content"]["uri"], b["content"]["uri"]);
            uris.push_back(a["content"]["uri"]);
        }
        const json none = json::array();
        const json& ca = a.contains("children") ? a["children"] : none;
        const json& cb = b.contains("children") ? b["children"] : none;
        ASSERT_EQ(ca.size(), cb.size());
        for (std::size_t i = 0; i < ca.size(); ++i)
            same(ca[i], cb[i]);
    };
    same(tileset["root"], p["root"]);
    ASSERT_GT(uris.size(), 100u);
    // Each tile the same mesh; the bytes.
    std::uintmax_t plainBytes = 0, packedBytes = 0;
    std::vector<test::GlbMesh> a(uris.size()), b(uris.size());
    std::vector<
        std::tuple<const test::GlbMesh*, const test::GlbMesh*, std::vector<std::uint32_t>, int>>
        meshes;
    for (std::size_t i = 0; i < uris.size(); ++i) {
        const std::string bytes = test::slurp(packed + "/" + uris[i]);
        plainBytes += fs::file_size(tiles + "/" + uris[i]);
        packedBytes += bytes.size();
        const std::string decoded = test::decodeMeshoptGlb(bytes);
        ASSERT_FALSE(decoded.empty()) << uris[i];
        a[i] = test::readGlbMesh(load(tiles + "/" + uris[i]), 0);
        b[i] = test::readGlbMesh(test::loadGlbBytes(decoded), 0);
        auto map = test::expectSameMesh(a[i], b[i], bound, uris[i]);
        ASSERT_FALSE(map.empty()) << uris[i];
        meshes.emplace_back(&a[i], &b[i], std::move(map), int(parseUri(uris[i]).first));
    }
    EXPECT_LT(packedBytes, plainBytes * 2 / 5) << packedBytes << " of " << plainBytes;
    // Cracks: tiles of two entries neither of which is the other's ancestor may be drawn side by
    // side (a leaf next to a node of another branch).
    std::vector<int> parent(m.blocks.size(), -1);
    for (std::size_t i = 0; i < m.blocks.size(); ++i)
        for (std::uint32_t c = 0; c < m.blocks[i].childCount; ++c)
            parent[m.blocks[i].firstChild + c] = int(i);
    const auto ancestor = [&](int x, int y) {  // x is y's ancestor
        for (int at = parent[std::size_t(y)]; at >= 0; at = parent[std::size_t(at)])
            if (at == x) return true;
        return false;
    };
    const std::size_t shared = test::expectNoCracks(
        meshes, [&](int x, int y) { return x != y && !ancestor(x, y) && !ancestor(y, x); });
    EXPECT_GT(shared, 1000u);
}

}  // namespace
