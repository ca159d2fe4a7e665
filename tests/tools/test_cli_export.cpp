// `unilod export` (tools/export/gltfexport.h): the bundled Jacksboro model exported with --h-lim
// and with --camera, loaded back with tinygltf's own loader. Per block the triangle and line
// counts, the index values (16-bit where the level's vertices fit, else 32-bit) and the
// positions are compared with the level that engine/lod/lod.h's chooseLevel picks from the
// file's error table, with h_lim recomputed here (the camera formula written out again); with a
// view direction the export equals what the engine draws (`unilod capture` of the same view: same
// blocks, levels and counts); plus normals facing up (the axis mapping keeps the winding), the
// georeference in asset.extras, and usage / data errors that leave no output file.
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>
#include <tuple>

#include "campath.h"
#include "lod.h"
#include "testutil.h"
#include "tools/cliutil.h"
#include "tools/glbcheck.h"
#include "ulod.h"

using namespace unilod;
namespace fs = std::filesystem;
using unilod::test::q;
using unilod::test::runCli;

namespace {

const std::string kDem = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif";
const std::string kRivers = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson";

template <typename T>
const T* accessorData(const tinygltf::Model& m, int index, std::size_t components) {
    const tinygltf::Accessor& a = m.accessors.at(std::size_t(index));
    const tinygltf::BufferView& v = m.bufferViews.at(std::size_t(a.bufferView));
    const std::vector<unsigned char>& b = m.buffers.at(std::size_t(v.buffer)).data;
    EXPECT_LE(v.byteOffset + a.byteOffset + a.count * components * sizeof(T), b.size());
    return reinterpret_cast<const T*>(b.data() + v.byteOffset + a.byteOffset);
}

class ExportTest : public ::testing::Test {
protected:
    static inline test::TempDir* dir = nullptr;
    static inline std::string model;
    static inline format::Header header;
    static inline std::vector<format::Block> blocks;

    static void SetUpTestSuite() {
        dir = new test::TempDir("export");
        model = dir->file("j.ulod");
        const auto r = runCli("build -q " + q(kDem) + " " + q(kRivers) + " -o " + q(model));
        ASSERT_EQ(r.code, 0) << r.err;
        test::Model m;
        std::string error;
        ASSERT_TRUE(test::readModel(model, m, error)) << error;
        header = m.header;
        blocks = std::move(m.blocks);
    }
    static void TearDownTestSuite() {
        delete dir;
        dir = nullptr;
    }

    static tinygltf::Model load(const std::string& path) {
        tinygltf::Model m;
        tinygltf::TinyGLTF loader;
        std::string err, warn;
        EXPECT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, path)) << err << warn;
        return m;
    }

    // The cut for per-block h_lim (engine/lod/cut.h, written out again): from the root, a node
    // with children whose finest error exceeds its h_lim gives way to its children, any other
    // node is drawn. Directory indices in file order (the export's node order).
    static std::vector<std::size_t> expectedCut(const std::vector<double>& hLim) {
        std::vector<bool> child(blocks.size(), false);
        for (const format::Block& b : blocks)
            for (std::uint32_t c = 0; c < b.childCount; ++c) child[b.firstChild + c] = true;
        std::vector<std::size_t> cut, stack;
        for (std::size_t i = 0; i < blocks.size(); ++i)
            if (!child[i]) stack.push_back(i);
        while (!stack.empty()) {
            const std::size_t i = stack.back();
            stack.pop_back();
            const format::Block& b = blocks[i];
            if (b.childCount > 0 && b.errorMax[b.levels.front().step] > hLim[i]) {
                for (std::uint32_t c = 0; c < b.childCount; ++c) stack.push_back(b.firstChild + c);
            } else {
                cut.push_back(i);
            }
        }
        std::sort(cut.begin(), cut.end());
        return cut;
    }

    // The drawn block (glTF node) covering each leaf block: its glTF node index, or -1.
    static std::vector<int> coveringNodes(const tinygltf::Model& m) {
        std::vector<int> byIndex(blocks.size(), -1), out(blocks.size(), -1);
        for (std::size_t k = 0; k < m.nodes.size(); ++k)
            byIndex[std::size_t(m.nodes[k].extras.Get("index").GetNumberAsInt())] = int(k);
        std::vector<std::size_t> parent(blocks.size(), SIZE_MAX);
        for (std::size_t i = 0; i < blocks.size(); ++i)
            for (std::uint32_t c = 0; c < blocks[i].childCount; ++c)
                parent[blocks[i].firstChild + c] = i;
        for (std::size_t i = 0; i < blocks.size(); ++i) {
            if (blocks[i].level != 0) continue;
            for (std::size_t at = i; at != SIZE_MAX && out[i] < 0; at = parent[at])
                out[i] = byIndex[at];
        }
        return out;
    }

    // Checks the .glb against the cut and levels chosen for the given per-block h_lim; returns
    // totals.
    static void checkModel(const tinygltf::Model& m, const std::vector<double>& hLim,
                           std::uint64_t& triangles, std::uint64_t& edges,
                           std::set<std::size_t>& levelsUsed) {
        triangles = edges = 0;
        ASSERT_EQ(m.asset.version, "2.0");
        ASSERT_TRUE(m.asset.extras.IsObject());
        EXPECT_EQ(m.asset.extras.Get("crs_wkt").Get<std::string>(), header.crsWkt);
        EXPECT_FALSE(header.crsWkt.empty());
        const tinygltf::Value& origin = m.asset.extras.Get("origin");
        ASSERT_TRUE(origin.IsArray());
        EXPECT_DOUBLE_EQ(origin.Get(0).GetNumberAsDouble(), header.originX);
        EXPECT_DOUBLE_EQ(origin.Get(1).GetNumberAsDouble(), header.originY);
        ASSERT_EQ(m.scenes.size(), 1u);
        const std::vector<std::size_t> cut = expectedCut(hLim);
        ASSERT_EQ(m.nodes.size(), cut.size());
        ASSERT_EQ(m.scenes[0].nodes.size(), cut.size());
        for (std::size_t at = 0; at < cut.size(); ++at) {
            const std::size_t i = cut[at];
            SCOPED_TRACE("block " + std::to_string(i));
            const format::Block& b = blocks[i];
            const engine::LevelChoice choice = engine::chooseLevel(b.levels, b.errorMax, hLim[i]);
            levelsUsed.insert(choice.level);
            const format::Level& level = b.levels[choice.level];
            const tinygltf::Node& node = m.nodes[std::size_t(m.scenes[0].nodes[at])];
            EXPECT_EQ(node.extras.Get("index").GetNumberAsInt(), int(i));
            EXPECT_EQ(node.extras.Get("col").GetNumberAsInt(), int(b.col));
            EXPECT_EQ(node.extras.Get("row").GetNumberAsInt(), int(b.row));
            EXPECT_EQ(node.extras.Get("tree_level").GetNumberAsInt(), int(b.level));
            EXPECT_EQ(node.extras.Get("level").GetNumberAsInt(), int(choice.level));
            ASSERT_EQ(node.translation.size(), 3u);
            EXPECT_DOUBLE_EQ(node.translation[0], b.originX - header.originX);
            EXPECT_DOUBLE_EQ(node.translation[1], 0.0);
            EXPECT_DOUBLE_EQ(node.translation[2], -(b.originY - header.originY));
            EXPECT_TRUE(node.matrix.empty());
            ASSERT_GE(node.mesh, 0);
            const tinygltf::Mesh& mesh = m.meshes[std::size_t(node.mesh)];
            std::size_t triPrims = 0, linePrims = 0;
            for (const tinygltf::Primitive& p : mesh.primitives) {
                const int posIndex = p.attributes.at("POSITION");
                const tinygltf::Accessor& pos = m.accessors[std::size_t(posIndex)];
                ASSERT_EQ(pos.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
                ASSERT_EQ(pos.type, TINYGLTF_TYPE_VEC3);
                ASSERT_EQ(pos.count, level.vertexCount);
                ASSERT_EQ(pos.minValues.size(), 3u);
                ASSERT_EQ(pos.maxValues.size(), 3u);
                const float* xyz = accessorData<float>(m, posIndex, 3);
                // Positions: the block-relative (x, z, -y) of the file's vertices; with the
                // node's translation the world point relative to the header's origin.
                for (std::size_t v = 0; v < level.vertexCount; ++v) {
                    const format::Vertex& fv = b.vertices[v];
                    ASSERT_EQ(xyz[3 * v], fv.x);
                    ASSERT_EQ(xyz[3 * v + 1], fv.z);
                    ASSERT_EQ(xyz[3 * v + 2], -fv.y);
                    ASSERT_NEAR(node.translation[0] + xyz[3 * v],
                                b.originX + double(fv.x) - header.originX, 1e-6);
                    ASSERT_NEAR(node.translation[2] + xyz[3 * v + 2],
                                -(b.originY + double(fv.y) - header.originY), 1e-6);
                    for (int k = 0; k < 3; ++k) {
                        ASSERT_GE(xyz[3 * v + k], pos.minValues[std::size_t(k)]);
                        ASSERT_LE(xyz[3 * v + k], pos.maxValues[std::size_t(k)]);
                    }
                }
                // 16-bit indices where the level's vertices fit (65 535 at most), else 32-bit.
                const tinygltf::Accessor& idx = m.accessors[std::size_t(p.indices)];
                std::vector<std::uint32_t> ix(idx.count);
                if (level.vertexCount <= 65535) {
                    ASSERT_EQ(idx.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
                    const std::uint16_t* s = accessorData<std::uint16_t>(m, p.indices, 1);
                    ix.assign(s, s + idx.count);
                } else {
                    ASSERT_EQ(idx.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
                    const std::uint32_t* l = accessorData<std::uint32_t>(m, p.indices, 1);
                    ix.assign(l, l + idx.count);
                }
                for (std::size_t k = 0; k < idx.count; ++k)
                    ASSERT_LT(ix[k], level.vertexCount);
                if (p.mode == TINYGLTF_MODE_TRIANGLES) {
                    ++triPrims;
                    ASSERT_EQ(idx.count, 3u * level.triangleCount);
                    triangles += idx.count / 3;
                    std::size_t clockwise = 0;
                    for (std::uint32_t t = 0; t < level.triangleCount; ++t) {
                        const format::Triangle& tri = b.terrainIndices[level.triangleFirst + t];
                        ASSERT_EQ(ix[3 * t], tri.a);
                        ASSERT_EQ(ix[3 * t + 1], tri.b);
                        ASSERT_EQ(ix[3 * t + 2], tri.c);
                        // Seen from above (glTF +y) a triangle keeps the file's orientation in
                        // x-y (counter-clockwise, except float slivers of the exact grid).
                        const float* a = xyz + 3 * ix[3 * t];
                        const float* bb = xyz + 3 * ix[3 * t + 1];
                        const float* c = xyz + 3 * ix[3 * t + 2];
                        const double ny = (double(bb[2]) - a[2]) * (double(c[0]) - a[0]) -
                                          (double(bb[0]) - a[0]) * (double(c[2]) - a[2]);
                        const format::Vertex& fa = b.vertices[tri.a];
                        const format::Vertex& fb = b.vertices[tri.b];
                        const format::Vertex& fc = b.vertices[tri.c];
                        const double xy = (double(fb.x) - fa.x) * (double(fc.y) - fa.y) -
                                          (double(fb.y) - fa.y) * (double(fc.x) - fa.x);
                        ASSERT_EQ(ny, xy) << "triangle " << t;
                        if (ny <= 0) {
                            // Only a sliver may flip in float: exactly counter-clockwise on the
                            // file's grid, and thinner than a centimetre.
                            ++clockwise;
                            ASSERT_EQ(b.grid.size(), b.vertices.size());
                            const format::GridXY ga = b.grid[tri.a], gb = b.grid[tri.b],
                                                 gc = b.grid[tri.c];
                            const double area2 =
                                double((std::int64_t(gb.x) - ga.x) * (std::int64_t(gc.y) - ga.y) -
                                       (std::int64_t(gb.y) - ga.y) * (std::int64_t(gc.x) - ga.x));
                            EXPECT_GT(area2, 0.0) << "triangle " << t;
                            double longest = 0;
                            for (auto [p0, p1] : {std::pair{ga, gb}, {gb, gc}, {gc, ga}})
                                longest = std::max(longest, std::hypot(double(p1.x) - p0.x,
                                                                       double(p1.y) - p0.y));
                            EXPECT_LT(area2 / longest * format::kGridUnit, 0.01)
                                << "triangle " << t << " flips in float but is no sliver";
                        }
                    }
                    EXPECT_LE(clockwise * 100, std::size_t(level.triangleCount));
                    const int nIndex = p.attributes.at("NORMAL");
                    ASSERT_EQ(m.accessors[std::size_t(nIndex)].count, level.vertexCount);
                    const float* n = accessorData<float>(m, nIndex, 3);
                    for (std::size_t v = 0; v < level.vertexCount; ++v) {
                        const double len = std::sqrt(double(n[3 * v]) * n[3 * v] +
                                                     double(n[3 * v + 1]) * n[3 * v + 1] +
                                                     double(n[3 * v + 2]) * n[3 * v + 2]);
                        ASSERT_NEAR(len, 1.0, 1e-4);
                        ASSERT_GT(n[3 * v + 1], 0.0f);  // a height field: normals point up
                    }
                } else {
                    ASSERT_EQ(p.mode, TINYGLTF_MODE_LINE);
                    ++linePrims;
                    ASSERT_EQ(idx.count, 2u * level.riverCount);
                    edges += idx.count / 2;
                    for (std::uint32_t e = 0; e < level.riverCount; ++e) {
                        const format::Edge& edge = b.riverIndices[level.riverFirst + e];
                        ASSERT_EQ(ix[2 * e], edge.a);
                        ASSERT_EQ(ix[2 * e + 1], edge.b);
                    }
                }
            }
            EXPECT_EQ(triPrims, level.triangleCount > 0 ? 1u : 0u);
            EXPECT_EQ(linePrims, level.riverCount > 0 ? 1u : 0u);
        }
    }
};

std::string summaryLine(std::uint64_t triangles, std::uint64_t edges) {
    return std::to_string(triangles) + " triangles, " + std::to_string(edges) + " river edges";
}

}  // namespace

TEST_F(ExportTest, HLimRoundTrip) {
    std::set<std::size_t> allLevels;
    std::uint64_t previous = ~0ull;
    for (double h : {0.0, 40.0, 150.0, 1e6}) {
        SCOPED_TRACE("h_lim " + std::to_string(h));
        const std::string out = dir->file("h.glb");
        std::ostringstream hs;
        hs << h;
        // The same output every time: replaced with --overwrite (refused without it: below).
        const auto r = runCli("export -q " + q(model) + " --h-lim " + hs.str() + " -o " + q(out) +
                              " --overwrite");
        ASSERT_EQ(r.code, 0) << r.err;
        if (h == 0.0) {
            const auto again = runCli("export -q " + q(model) + " --h-lim 5 -o " + q(out));
            EXPECT_EQ(again.code, 1);
            EXPECT_NE(again.err.find("--overwrite"), std::string::npos) << again.err;
        }
        const tinygltf::Model m = load(out);
        std::uint64_t triangles = 0, edges = 0;
        checkModel(m, std::vector<double>(blocks.size(), h), triangles, edges, allLevels);
        EXPECT_NE(r.out.find(summaryLine(triangles, edges)), std::string::npos) << r.out;
        EXPECT_LT(triangles, previous);  // a larger h_lim selects coarser levels
        previous = triangles;
        EXPECT_TRUE(m.asset.extras.Get("selection").Get("h_lim").IsNumber());
    }
    EXPECT_GE(allLevels.size(), 4u);
}

TEST_F(ExportTest, CameraRoundTrip) {
    // Low above the corner block (0, 0): near blocks fine, far blocks coarse.
    const double eye[3] = {header.minX + 2000, header.maxY - 2000, header.maxZ + 500};
    const double fov = 45, height = 800, pixels = 2;
    std::ostringstream cam;
    cam.precision(17);
    cam << eye[0] << "," << eye[1] << "," << eye[2];
    const std::string out = dir->file("cam.glb");
    // The stored levels as they are (--no-refine; the refined leaves of the default are checked
    // against the engine below).
    const auto r = runCli("export -q --no-refine " + q(model) + " --camera " + cam.str() +
                          " --fov 45 --size 1200x800 --pixels 2 -o " + q(out));
    ASSERT_EQ(r.code, 0) << r.err;
    std::vector<double> hLim;
    const double width = 1200, t = std::tan(fov / 2 * M_PI / 180);
    // cos^2 of the frustum's corner ray (DESIGN.md "Screen-space error", nearest mode).
    const double edge = 1 / (1 + t * t * (1 + (width / height) * (width / height)));
    for (const format::Block& b : blocks) {
        // Nearest point of the bounding box, then Eq. 11 with S * cos^2, written out again.
        const double lo[3] = {b.minX, b.minY, b.minZ}, hi[3] = {b.maxX, b.maxY, b.maxZ};
        double s2 = 0;
        for (int k = 0; k < 3; ++k) {
            const double d = std::max({lo[k] - eye[k], 0.0, eye[k] - hi[k]});
            s2 += d * d;
        }
        hLim.push_back(2 * pixels * std::sqrt(s2) * edge * t / height);
    }
    std::set<std::size_t> levels;
    std::uint64_t triangles = 0, edges = 0;
    const tinygltf::Model m = load(out);
    checkModel(m, hLim, triangles, edges, levels);
    EXPECT_GE(levels.size(), 2u) << "the camera should select different levels per block";
    EXPECT_NE(r.out.find(summaryLine(triangles, edges)), std::string::npos) << r.out;
    // With yaw and pitch but --no-cull: every block, none finer than without the direction
    // (the depth bound of engine/lod/lod.h only ever raises h_lim).
    const std::string out2 = dir->file("cam2.glb");
    ASSERT_EQ(runCli("export -q --no-refine " + q(model) + " --camera " + cam.str() +
                     ",135,-30 --no-cull --fov 45 --size 1200x800 --pixels 2 -o " + q(out2))
                  .code,
              0);
    const tinygltf::Model m2 = load(out2);
    // Every leaf is covered in both; with the direction by the same block at a level no finer,
    // or by a block higher in the tree.
    const std::vector<int> cover = coveringNodes(m), cover2 = coveringNodes(m2);
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        if (blocks[i].level != 0) continue;
        ASSERT_GE(cover[i], 0);
        ASSERT_GE(cover2[i], 0);
        const tinygltf::Value& a = m.nodes[std::size_t(cover[i])].extras;
        const tinygltf::Value& b = m2.nodes[std::size_t(cover2[i])].extras;
        const int index = a.Get("index").GetNumberAsInt();
        if (b.Get("index").GetNumberAsInt() == index) {
            EXPECT_GE(b.Get("level").GetNumberAsInt(), a.Get("level").GetNumberAsInt());
            EXPECT_GE(b.Get("h_lim").GetNumberAsDouble(), hLim[std::size_t(index)] * (1 - 1e-12));
        } else {
            EXPECT_GT(b.Get("tree_level").GetNumberAsInt(), a.Get("tree_level").GetNumberAsInt());
        }
    }
}

// The export of a view is what the engine draws for it: `unilod capture` of the same camera
// (settled, validation on) lists the same blocks at the same levels with the same counts, and
// refines the same leaves from their records (lod/refine.h) by the same steps.
TEST_F(ExportTest, CameraEqualsEngineSelection) {
    // In the north-west corner block, looking out of the model to the north-west and down:
    // the blocks behind the eye are culled.
    std::ostringstream cam;
    cam.precision(17);
    cam << header.minX + 1500 << "," << header.maxY - 1500 << "," << header.maxZ + 300
        << ",315,-35";
    const std::string common =
        " --camera " + cam.str() + " --fov 50 --size 640x400 --pixels 1.5 --metric max";
    const std::string out = dir->file("view.glb");
    const auto r = runCli("export -q " + q(model) + common + " -o " + q(out));
    ASSERT_EQ(r.code, 0) << r.err;
    const std::string frames = dir->file("frames");
    const auto c = runCli("capture --validation " + q(model) + common + " --out " + q(frames));
    ASSERT_EQ(c.code, 0) << c.err;
    const nlohmann::json j = nlohmann::json::parse(test::slurp(frames + "/frame_0000.json"));

    // directory index, tree level, level, steps done when refined (-1: a stored level)
    std::set<std::tuple<int, int, int, int>> engine, exported;
    std::size_t refined = 0;
    for (const auto& b : j.at("blocks")) {
        EXPECT_FALSE(b.at("fallback").get<bool>());
        const bool isRefined = b.at("refined").get<bool>();
        refined += isRefined;
        engine.insert({b.at("index").get<int>(), b.at("tree_level").get<int>(),
                       b.at("level").get<int>(), isRefined ? b.at("steps_done").get<int>() : -1});
    }
    EXPECT_GT(refined, 0u);
    const tinygltf::Model m = load(out);
    std::uint64_t triangles = 0, edges = 0;
    for (const tinygltf::Node& node : m.nodes) {
        exported.insert({node.extras.Get("index").GetNumberAsInt(),
                         node.extras.Get("tree_level").GetNumberAsInt(),
                         node.extras.Get("level").GetNumberAsInt(),
                         node.extras.Get("refined").Get<bool>()
                             ? node.extras.Get("steps_done").GetNumberAsInt()
                             : -1});
        for (const tinygltf::Primitive& p : m.meshes[std::size_t(node.mesh)].primitives) {
            const std::size_t n = m.accessors[std::size_t(p.indices)].count;
            (p.mode == TINYGLTF_MODE_TRIANGLES ? triangles : edges) +=
                n / (p.mode == TINYGLTF_MODE_TRIANGLES ? 3 : 2);
        }
    }
    EXPECT_EQ(exported, engine);
    EXPECT_GT(exported.size(), 0u);
    EXPECT_LT(exported.size(), blocks.size()) << "the view should cull some blocks";
    EXPECT_EQ(triangles, j.at("totals").at("triangles").get<std::uint64_t>());
    EXPECT_EQ(edges, j.at("totals").at("river_edges").get<std::uint64_t>());
    EXPECT_TRUE(m.asset.extras.Get("selection").Get("culled").Get<bool>());

    // --no-refine on both: stored levels only, the same counts again, and more triangles.
    const std::string stored = dir->file("stored.glb");
    ASSERT_EQ(runCli("export -q --no-refine " + q(model) + common + " -o " + q(stored)).code, 0);
    const std::string storedFrames = dir->file("stored_frames");
    const auto c2 = runCli("capture --validation --no-refine " + q(model) + common + " --out " +
                           q(storedFrames));
    ASSERT_EQ(c2.code, 0) << c2.err;
    const nlohmann::json j2 = nlohmann::json::parse(test::slurp(storedFrames + "/frame_0000.json"));
    for (const auto& b : j2.at("blocks"))
        EXPECT_FALSE(b.at("refined").get<bool>());
    std::uint64_t storedTriangles = 0;
    const tinygltf::Model m2 = load(stored);
    for (const tinygltf::Node& node : m2.nodes) {
        EXPECT_FALSE(node.extras.Get("refined").Get<bool>());
        for (const tinygltf::Primitive& p : m2.meshes[std::size_t(node.mesh)].primitives)
            if (p.mode == TINYGLTF_MODE_TRIANGLES)
                storedTriangles += m2.accessors[std::size_t(p.indices)].count / 3;
    }
    EXPECT_EQ(storedTriangles, j2.at("totals").at("triangles").get<std::uint64_t>());
    EXPECT_GT(storedTriangles, triangles);
}

// Without --camera or --h-lim the view is capture's default overview (the whole model from the
// south): the same file, byte for byte, as that camera given explicitly.
TEST_F(ExportTest, DefaultIsCaptureOverview) {
    const std::string implicit = dir->file("default.glb"), explicit_ = dir->file("overview.glb");
    const auto r = runCli("export -q " + q(model) + " -o " + q(implicit));
    ASSERT_EQ(r.code, 0) << r.err;
    const engine::Camera c = engine::defaultOverview(header);
    std::ostringstream cam;
    cam.precision(17);
    cam << c.eye[0] << "," << c.eye[1] << "," << c.eye[2] << "," << c.yawDegrees << ","
        << c.pitchDegrees;
    ASSERT_EQ(runCli("export -q " + q(model) + " --camera " + cam.str() + " --fov " +
                     std::to_string(c.fovDegrees) + " -o " + q(explicit_))
                  .code,
              0);
    const std::string a = test::slurp(implicit), b = test::slurp(explicit_);
    EXPECT_FALSE(a.empty());
    EXPECT_TRUE(a == b);
    // A view, not the full model: fewer triangles than the finest levels hold.
    const tinygltf::Model m = load(implicit);
    EXPECT_GT(m.nodes.size(), 0u);
}

TEST_F(ExportTest, ErrorsLeaveNoFile) {
    const std::string out = dir->file("bad.glb");
    struct Case {
        std::string args;
        int code;
    };
    const Case cases[] = {
        {"export " + q(dir->file("missing.ulod")) + " --h-lim 5 -o " + q(out), 1},
        {"export " + q(model) + " --h-lim -1 -o " + q(out), 2},
        {"export " + q(model) + " --h-lim 5 --camera 1,2,3 -o " + q(out), 2},
        {"export " + q(model) + " --camera 1,2 -o " + q(out), 2},
        {"export " + q(model) + " --camera 1,2,3 --size 0x5 -o " + q(out), 2},
        {"export " + q(model) + " --camera 1,2,3,0,95 -o " + q(out), 2},  // pitch: usage
        {"export " + q(model) + " --camera 1,2,3 --distance far -o " + q(out), 2},
        {"export " + q(model) + " --h-lim 5 --metric median -o " + q(out), 2},
        {"export " + q(model) + " --h-lim 5", 2},
        {"export " + q(model) + " --h-lim 5 -o " + q(dir->file("no/such/dir/x.glb")), 1},
        {"export " + q(dir->write("junk.ulod", "not a ulod file")) + " --h-lim 5 -o " + q(out), 1},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.args);
        const auto r = runCli(c.args);
        EXPECT_EQ(r.code, c.code) << r.err;
        EXPECT_FALSE(r.err.empty());
        EXPECT_FALSE(fs::exists(out));
    }
    for (const auto& e : fs::directory_iterator(dir->path))
        EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
    EXPECT_EQ(runCli("export --help").code, 0);
}

// --compress (gltfmodel.h): the same blocks, vertices (within the bound the export prints),
// triangles and river edges as the plain export; a vertex two blocks share decodes to one point
// in both (no crack between a leaf and a node beside it); and the file is much smaller.
TEST_F(ExportTest, CompressedIsTheSameMeshWithoutCracks) {
    // 64-cell blocks: a cut of leaves and nodes of several tree levels side by side.
    const std::string small = dir->file("j64.ulod");
    const auto built = runCli("build -q " + q(kDem) + " " + q(kRivers) + " --block-size 64 -o " +
                              q(small) + " --overwrite");
    ASSERT_EQ(built.code, 0) << built.err;
    std::set<int> treeLevels;
    std::ostringstream cam;
    cam.precision(17);
    cam << header.minX + 1500 << "," << header.maxY - 1500 << "," << header.maxZ + 300
        << ",135,-20";
    for (const std::string& view :
         {" --camera " + cam.str() + " --pixels 1", std::string(" --h-lim 4")}) {
        SCOPED_TRACE(view);
        const std::string plainPath = dir->file("plain.glb"), packedPath = dir->file("packed.glb");
        const auto r =
            runCli("export -q " + q(small) + view + " -o " + q(plainPath) + " --overwrite");
        ASSERT_EQ(r.code, 0) << r.err;
        const auto c = runCli("export -q " + q(small) + view + " --compress -o " + q(packedPath) +
                              " --overwrite");
        ASSERT_EQ(c.code, 0) << c.err;
        EXPECT_NE(c.out.find("compressed: positions within"), std::string::npos) << c.out;
        const std::string plainBytes = test::slurp(plainPath),
                          packedBytes = test::slurp(packedPath);
        EXPECT_LT(packedBytes.size(), plainBytes.size() / 2);
        const tinygltf::Model plain = load(plainPath);
        const std::string decoded = test::decodeMeshoptGlb(packedBytes);
        ASSERT_FALSE(decoded.empty());
        const tinygltf::Model packed = test::loadGlbBytes(decoded);
        const double bound = packed.asset.extras.Get("max_quantization_error_m").Get<double>();
        EXPECT_GT(bound, 0.0);
        const double step = packed.asset.extras.Get("quantization_step_m").Get<double>();
        EXPECT_EQ(std::exp2(std::round(std::log2(step))), step);
        EXPECT_LE(bound, 0.5 * step);
        ASSERT_EQ(plain.nodes.size(), packed.nodes.size());
        ASSERT_GE(plain.nodes.size(), 4u);
        std::vector<test::GlbMesh> a(plain.nodes.size()), b(plain.nodes.size());
        std::vector<
            std::tuple<const test::GlbMesh*, const test::GlbMesh*, std::vector<std::uint32_t>, int>>
            meshes;
        for (std::size_t i = 0; i < plain.nodes.size(); ++i) {
            EXPECT_EQ(plain.nodes[i].name, packed.nodes[i].name);
            treeLevels.insert(plain.nodes[i].extras.Get("tree_level").GetNumberAsInt());
            a[i] = test::readGlbMesh(plain, int(i));
            b[i] = test::readGlbMesh(packed, int(i));
            auto map = test::expectSameMesh(a[i], b[i], bound, plain.nodes[i].name);
            ASSERT_FALSE(map.empty() && !a[i].positions.empty());
            meshes.emplace_back(&a[i], &b[i], std::move(map), int(i));
        }
        // One node per block of the cut: any two may be side by side.
        const std::size_t shared =
            test::expectNoCracks(meshes, [](int x, int y) { return x != y; });
        EXPECT_GT(shared, 100u);
    }
    EXPECT_GE(treeLevels.size(), 2u);
}
