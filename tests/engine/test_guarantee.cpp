// Issue 5's two engine checks on real captures (Mesa lavapipe, validation layer on), with an
// independent double-precision re-implementation of the camera on the CPU:
// (1) Screen-space guarantee: for every original DEM point of every block, the point and the
//     surface drawn below it (the level the capture chose for that block, read from the .ulod)
//     project at most P pixels apart whenever both are inside the view frustum (`--metric max`,
//     `--distance nearest`). Cameras: an oblique side view, a top-down view, and P = 3. The
//     paper's `--distance centre` (no guarantee) is measured and printed as a negative control.
// (2) Rivers are drawn: points sampled along the drawn river edges that are not hidden by the
//     drawn terrain land on river-coloured pixels of the PNG.
// The bundled data set is built once into a temporary folder with `unilod build` (small blocks).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "cut.h"
#include "pngread.h"
#include "refine.h"
#include "shared.h"
#include "tools/cliutil.h"
#include "ulod.h"

namespace fs = std::filesystem;
using namespace unilod;
using unilod::test::Image;
using unilod::test::q;
using unilod::test::readPng;
using unilod::test::runCli;
using unilod::test::slurp;

namespace {

const std::string kAssets = UNILOD_ASSETS_DIR;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

// The capture's camera, re-implemented from the documented convention (world x east, y north,
// z up; yaw 0 looks north, 90 east; pitch < 0 looks down; vertical fov; Vulkan y down).
struct Projector {
    double eye[3] = {0, 0, 0};
    double f[3] = {0, 0, 0}, r[3] = {0, 0, 0}, u[3] = {0, 0, 0};
    double tanHalf = 1, aspect = 1, width = 0, height = 0;

    explicit Projector(const nlohmann::json& capture) {
        const nlohmann::json& c = capture["camera"];
        for (int i = 0; i < 3; ++i)
            eye[i] = c["eye"][i].get<double>();
        const double yaw = c["yaw"].get<double>() * kDegree;
        const double pitch = c["pitch"].get<double>() * kDegree;
        f[0] = std::sin(yaw) * std::cos(pitch);
        f[1] = std::cos(yaw) * std::cos(pitch);
        f[2] = std::sin(pitch);
        r[0] = std::cos(yaw);
        r[1] = -std::sin(yaw);
        r[2] = 0;
        u[0] = r[1] * f[2] - r[2] * f[1];
        u[1] = r[2] * f[0] - r[0] * f[2];
        u[2] = r[0] * f[1] - r[1] * f[0];
        tanHalf = std::tan(c["fov"].get<double>() * kDegree / 2);
        width = capture["size"][0].get<double>();
        height = capture["size"][1].get<double>();
        aspect = width / height;
    }

    struct Screen {
        double x = 0, y = 0, depth = 0;
        bool inside = false;  // in front of the near plane (1 m) and inside the image rectangle
    };
    Screen project(double px, double py, double pz) const {
        const double p[3] = {px - eye[0], py - eye[1], pz - eye[2]};
        Screen s;
        s.depth = p[0] * f[0] + p[1] * f[1] + p[2] * f[2];
        if (!(s.depth >= 1.0)) return s;
        const double pr = p[0] * r[0] + p[1] * r[1] + p[2] * r[2];
        const double pu = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
        s.x = width / 2 * (1 + pr / (s.depth * tanHalf * aspect));
        s.y = height / 2 * (1 - pu / (s.depth * tanHalf));
        s.inside = s.x >= 0 && s.x <= width && s.y >= 0 && s.y <= height;
        return s;
    }
};

// Point location in one level of one block: the level's triangles bucketed into a uniform grid
// over the block. Positions are the vertices' exact fixed-grid integers (Block::grid, the ones
// the triangulation was computed on), not their float metres: with floats, a point lying a
// fraction of a millimetre off a sliver triangle's long edge can round into it.
class Surface {
public:
    Surface(const format::Block& block, const format::Level& level) : block_(block) {
        const std::uint32_t first = level.triangleFirst, count = level.triangleCount;
        triangles_.assign(block.terrainIndices.begin() + first,
                          block.terrainIndices.begin() + first + count);
        double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
        for (const format::GridXY& g : block.grid) {
            lo[0] = std::min(lo[0], double(g.x));
            lo[1] = std::min(lo[1], double(g.y));
            hi[0] = std::max(hi[0], double(g.x));
            hi[1] = std::max(hi[1], double(g.y));
        }
        minX_ = lo[0];
        minY_ = lo[1];
        cells_ = std::clamp(int(std::sqrt(double(count) / 4)), 1, 512);
        cellW_ = std::max(hi[0] - lo[0], 1.0) / cells_;
        cellH_ = std::max(hi[1] - lo[1], 1.0) / cells_;
        maxX_ = hi[0];
        maxY_ = hi[1];
        buckets_.assign(std::size_t(cells_) * cells_, {});
        for (std::uint32_t t = 0; t < count; ++t) {
            double tlo[2] = {1e300, 1e300}, thi[2] = {-1e300, -1e300};
            for (std::uint32_t v : {triangles_[t].a, triangles_[t].b, triangles_[t].c}) {
                const format::GridXY& g = block.grid[v];
                tlo[0] = std::min(tlo[0], double(g.x));
                tlo[1] = std::min(tlo[1], double(g.y));
                thi[0] = std::max(thi[0], double(g.x));
                thi[1] = std::max(thi[1], double(g.y));
            }
            for (int r = cellY(tlo[1]); r <= cellY(thi[1]); ++r)
                for (int c = cellX(tlo[0]); c <= cellX(thi[0]); ++c)
                    buckets_[std::size_t(r) * cells_ + c].push_back(t);
        }
    }

    // z of the surface at block-relative (x, y) metres, or NaN outside the triangulation.
    double z(double x, double y) const {
        return zGrid(x / format::kGridUnit, y / format::kGridUnit);
    }

    // The same at fixed-grid (x, y): barycentric interpolation in the triangle that contains the
    // point most deeply (every barycentric >= 0; on a shared edge or vertex any of the
    // triangles, z is continuous there). With integer vertices (|coordinate| < 2^26) the areas
    // below are exact in double, so for a grid point "inside" is decided exactly.
    double zGrid(double x, double y) const {
        if (x < minX_ || y < minY_ || x > maxX_ || y > maxY_)
            return std::numeric_limits<double>::quiet_NaN();
        double best = -1e-12, value = std::numeric_limits<double>::quiet_NaN();
        for (std::uint32_t t : buckets_[std::size_t(cellY(y)) * cells_ + cellX(x)]) {
            const format::GridXY& a = block_.grid[triangles_[t].a];
            const format::GridXY& b = block_.grid[triangles_[t].b];
            const format::GridXY& c = block_.grid[triangles_[t].c];
            const double ax = a.x, ay = a.y, bx = b.x, by = b.y, cx = c.x, cy = c.y;
            const double area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
            if (area == 0) continue;
            const double la = ((bx - x) * (cy - y) - (by - y) * (cx - x)) / area;
            const double lb = ((cx - x) * (ay - y) - (cy - y) * (ax - x)) / area;
            const double lc = ((ax - x) * (by - y) - (ay - y) * (bx - x)) / area;
            const double m = std::min({la, lb, lc});
            if (m > best) {
                best = m;
                const double sum = la + lb + lc;  // 1 up to rounding
                value = (la * block_.vertices[triangles_[t].a].z +
                         lb * block_.vertices[triangles_[t].b].z +
                         lc * block_.vertices[triangles_[t].c].z) /
                        sum;
            }
        }
        return value;
    }

private:
    int cellX(double x) const {
        return std::clamp(int(std::floor((x - minX_) / cellW_)), 0, cells_ - 1);
    }
    int cellY(double y) const {
        return std::clamp(int(std::floor((y - minY_) / cellH_)), 0, cells_ - 1);
    }

    const format::Block& block_;
    std::vector<format::Triangle> triangles_;
    double minX_ = 0, minY_ = 0, maxX_ = 0, maxY_ = 0, cellW_ = 1, cellH_ = 1;
    int cells_ = 1;
    std::vector<std::vector<std::uint32_t>> buckets_;
};

// A capture and what it drew: per block of the file, the chosen level and its surface.
// An entry drawn refined from its records (scene.h SceneOptions::refine) is rebuilt here with the
// same CPU module and view (lod/refine.h; the capture's `steps_done` must agree) and stands as a
// copy of the block with one more level: the refined triangles and river edges, its step an
// extra error entry holding the largest own error of the steps taken; `alive` marks the
// vertices those steps did not delete (the other levels' alive vertices are a prefix).
struct Drawn {
    nlohmann::json json;
    Image image;
    std::vector<std::size_t> level;                  // per block index of the file
    std::vector<std::unique_ptr<Surface>> surfaces;  // per block index of the file
    std::vector<std::unique_ptr<format::Block>> refined;  // per block index: a refined leaf
    std::vector<std::vector<std::uint8_t>> alive;         // per block index: a refined leaf's
    const std::vector<format::Block>* file = nullptr;
    std::size_t refinedLeaves = 0, refinedNodes = 0;  // refined entries; of them tree nodes
    const format::Block& block(std::size_t i) const {
        return refined[i] ? *refined[i] : (*file)[i];
    }
    const std::vector<std::uint8_t>* aliveOf(std::size_t i) const {
        return refined[i] ? &alive[i] : nullptr;
    }
};

class Guarantee : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = fs::temp_directory_path() / ("unilod_test_guarantee_" + std::to_string(getpid()));
        fs::create_directories(dir_);
        file_ = (dir_ / "jacksboro.ulod").string();
        // 64-cell blocks (6 x 7 blocks of ~5.3 km) instead of the default 256 (2 x 2): a view
        // then holds blocks at many distances and levels.
        const auto r =
            runCli("build -q --block-size 64 " + q(kAssets + "/jacksboro_dem.tif") + " " +
                   q(kAssets + "/jacksboro_rivers_grass.geojson") + " -o " + q(file_));
        ASSERT_EQ(r.code, 0) << r.err;
        reader_ = new format::Reader;
        std::string error;
        ASSERT_TRUE(reader_->open(file_, error)) << error;
        blocks_ = new std::vector<format::Block>(reader_->blocks().size());
        for (std::size_t i = 0; i < blocks_->size(); ++i)
            ASSERT_TRUE(reader_->readBlock(i, (*blocks_)[i], error)) << error;
        parent_ = new std::vector<std::size_t>(blocks_->size(), SIZE_MAX);
        for (std::size_t i = 0; i < blocks_->size(); ++i) {
            const format::Block& b = (*blocks_)[i];
            for (std::uint32_t c = 0; c < b.childCount; ++c) (*parent_)[b.firstChild + c] = i;
        }
    }
    static void TearDownTestSuite() {
        delete blocks_;
        delete parent_;
        delete reader_;
        blocks_ = nullptr;
        reader_ = nullptr;
        fs::remove_all(dir_);
    }

    // Camera over the data: eye = (centre x + dx, south edge + dy, top + dz).
    static std::string camera(double dx, double dy, double dz, double yaw, double pitch) {
        const format::Header& h = reader_->header();
        char text[256];
        std::snprintf(text, sizeof text, "%.3f,%.3f,%.3f,%.3f,%.3f", (h.minX + h.maxX) / 2 + dx,
                      h.minY + dy, h.maxZ + dz, yaw, pitch);
        return text;
    }

    // A validated capture (640x480, 60 degrees, `--metric max`) and the levels it chose.
    static Drawn capture(const std::string& name, const std::string& cameraText, double pixels,
                         const std::string& distance) {
        const fs::path out = dir_ / name;
        char p[64];
        std::snprintf(p, sizeof p, "%.17g", pixels);
        const auto r = runCli("capture " + q(file_) + " --validation --camera " + cameraText +
                              " --size 640x480 --fov 60 --metric max --pixels " + p +
                              " --distance " + distance + " --out " + q(out.string()));
        Drawn d;
        EXPECT_EQ(r.code, 0) << r.err;
        EXPECT_EQ(r.err.find("validation"), std::string::npos) << r.err;
        EXPECT_TRUE(readPng((out / "frame_0000.png").string(), d.image));
        d.json = nlohmann::json::parse(slurp((out / "frame_0000.json").string()), nullptr, false);
        EXPECT_FALSE(d.json.is_discarded());
        if (d.json.is_discarded()) return d;
        EXPECT_EQ(d.json["metric"], "max");
        EXPECT_EQ(d.json["distance"], distance);
        d.level.assign(blocks_->size(), SIZE_MAX);
        d.surfaces.resize(blocks_->size());
        d.refined.resize(blocks_->size());
        d.alive.resize(blocks_->size());
        d.file = blocks_;
        // The view the engine refined for (capture's options above).
        engine::ViewSpec view;
        std::sscanf(cameraText.c_str(), "%lf,%lf,%lf,%lf,%lf", &view.camera.eye[0],
                    &view.camera.eye[1], &view.camera.eye[2], &view.camera.yawDegrees,
                    &view.camera.pitchDegrees);
        view.camera.fovDegrees = 60;
        view.widthPixels = 640;
        view.heightPixels = 480;
        view.pixels = pixels;
        view.distance =
            distance == "centre" ? engine::DistanceMode::Centre : engine::DistanceMode::Nearest;
        // Frustum culling lists only the blocks in view (the deviation check below makes sure
        // no culled block has a point on screen); a capture settles, so none is a fallback.
        EXPECT_GT(d.json["blocks"].size(), 0u);
        EXPECT_LE(d.json["blocks"].size(), blocks_->size());
        for (const nlohmann::json& b : d.json["blocks"]) {
            // The file's directory index; position and tree level must agree with it.
            const std::size_t i = b["index"].get<std::size_t>();
            if (i >= blocks_->size() || (*blocks_)[i].col != b["col"] ||
                (*blocks_)[i].row != b["row"] || (*blocks_)[i].level != b["tree_level"]) {
                ADD_FAILURE() << "no such block " << b.dump();
                continue;
            }
            const format::Block& block = (*blocks_)[i];
            EXPECT_EQ(block.grid.size(), block.vertices.size());  // the build stores it
            if (block.grid.size() != block.vertices.size()) continue;
            EXPECT_FALSE(b["fallback"].get<bool>()) << b.dump();
            d.level[i] = b["level"].get<std::size_t>();
            EXPECT_LT(d.level[i], block.levels.size());
            if (d.level[i] >= block.levels.size()) continue;
            EXPECT_EQ(b["step"].get<std::uint32_t>(), block.levels[d.level[i]].step);
            if (b["refined"].get<bool>()) {
                engine::Refinement refinement;
                std::string why;
                EXPECT_TRUE(refinement.init(block, why)) << why;
                engine::RefinedMesh mesh;
                refinement.refine(view, mesh, b["step"].get<std::uint32_t>());
                EXPECT_EQ(b["steps_done"].get<std::uint32_t>(), mesh.stepsDone) << b.dump();
                EXPECT_EQ(b["triangles"].get<std::size_t>(), mesh.triangles.size());
                auto copy = std::make_unique<format::Block>(block);
                d.level[i] = refinement.appendAsLevel(mesh, *copy);
                d.alive[i].assign(block.vertices.size(), 1);
                for (std::size_t k = 0; k < refinement.steps(); ++k)
                    if (mesh.done[k + 1]) d.alive[i][block.steps[k].vertex] = 0;
                d.refined[i] = std::move(copy);
                ++d.refinedLeaves;
                d.refinedNodes += block.level > 0;
            }
            d.surfaces[i] = std::make_unique<Surface>(d.block(i), d.block(i).levels[d.level[i]]);
        }
        return d;
    }

    struct Deviation {
        double maxPixels = 0;     // largest on-screen distance between a point and its surface
        double maxOverBound = 0;  // largest (deviation - allowed)
        std::size_t checked = 0, total = 0, coarseBlocks = 0;
        std::size_t nodes = 0;            // drawn tree nodes (above the leaf blocks)
        std::size_t unlocated = 0;        // points not found in their block's level (a failure)
        std::size_t outside = 0;          // points outside their level's (moved) outline
        double maxMetresOverHs = -1e300;  // largest vertical distance minus the block's h_s
        // Original river vertices against the drawn river edge that replaced them.
        double riverMaxPixels = 0;
        std::size_t riverChecked = 0, riverTotal = 0;
    };

    // Every original point (every vertex of every leaf block: the model's full resolution)
    // against the surface drawn below it: the level the cut drew for the leaf itself or for the
    // tree node above it that was drawn instead (issue 18: a node's error bounds every original
    // point of its area). The segment from the point to the surface point, projected, when one end
    // is on screen and both are in front of the 1 m near plane (engine/lod/lod.h
    // effectiveDistance bounds exactly such segments). The deviation measured is the full
    // on-screen length of the projected segment, not only its vertical component: the bound there
    // is for that length (|d x p| <= |d| |p|), so this is the stronger check. Border points are
    // checked in every leaf that holds them.
    static Deviation deviation(const Drawn& d, double pixels) {
        const Projector cam(d.json);
        Deviation out;
        for (std::size_t i = 0; i < blocks_->size(); ++i) {
            if (!d.surfaces[i]) continue;
            const format::Block& drawn = d.block(i);
            const format::Level& level = drawn.levels[d.level[i]];
            if (level.step > 0 || drawn.level > 0) ++out.coarseBlocks;
            if (drawn.level > 0) ++out.nodes;
            // The drawn block's own river chains (a node's: its children's coarsest river edges).
            riverDeviation(cam, drawn, level, pixels, out, d.aliveOf(i));
        }
        for (std::size_t i = 0; i < blocks_->size(); ++i) {
            const format::Block& leaf = (*blocks_)[i];
            if (leaf.level != 0) continue;
            std::size_t at = i;
            while (at != SIZE_MAX && !d.surfaces[at]) at = (*parent_)[at];
            if (at == SIZE_MAX) {
                // Culled with every node above it: none of its points may be on screen.
                for (const format::Vertex& v : leaf.vertices) {
                    const auto a = cam.project(leaf.originX + double(v.x),
                                               leaf.originY + double(v.y), v.z);
                    EXPECT_FALSE(a.inside) << "culled block " << leaf.col << "," << leaf.row
                                           << " has a point on screen";
                    if (a.inside) break;
                }
                continue;
            }
            const format::Block& drawn = d.block(at);
            const format::Level& level = drawn.levels[d.level[at]];
            const double hs = drawn.errorMax[level.step];
            const double hsRiver = drawn.errorRiver[level.step];  // the outline's part
            for (std::size_t k = 0; k < leaf.vertices.size(); ++k) {
                const format::Vertex& v = leaf.vertices[k];
                ++out.total;
                // World position from the exact grid, and the same point on the drawn block's
                // grid (the leaf itself: its own integers).
                const double wx = leaf.originX + double(leaf.grid[k].x) * format::kGridUnit;
                const double wy = leaf.originY + double(leaf.grid[k].y) * format::kGridUnit;
                const double s =
                    at == i ? d.surfaces[at]->zGrid(leaf.grid[k].x, leaf.grid[k].y)
                            : d.surfaces[at]->z(wx - drawn.originX, wy - drawn.originY);
                if (std::isnan(s)) {
                    // Outside the level's domain (its outline moved, cdt.h "Domain"): the
                    // segment to the nearest point of the level's outline in 3D, projected.
                    const double p[2] = {wx, wy};
                    if (!outlineDeviation(cam, drawn, level, p, v.z, hsRiver, pixels, out) &&
                        ++out.unlocated <= 5)
                        ADD_FAILURE() << "point (" << v.x << ", " << v.y << ") of block "
                                      << leaf.col << "," << leaf.row
                                      << " is farther than h_s's river part from the outline of the drawn "
                                      << "block (" << drawn.col << "," << drawn.row
                                      << ") of tree level " << drawn.level;
                    continue;
                }
                const double h = std::abs(s - double(v.z));
                out.maxMetresOverHs = std::max(out.maxMetresOverHs, h - hs);
                const auto a = cam.project(wx, wy, v.z);
                const auto b = cam.project(wx, wy, s);
                // One end on screen suffices (engine/lod/lod.h: the bound needs one end within the
                // frustum's corner angle and the other in front of the eye).
                if (!(a.inside || b.inside) || !(a.depth >= 1.0 && b.depth >= 1.0)) continue;
                ++out.checked;
                const double dev = std::hypot(a.x - b.x, a.y - b.y);
                // Slack for float storage only: vertex z (and the surface z interpolated from
                // them) is a float, and h_s was computed and stored as float; 1 mm in the
                // model covers those roundings (float ulp at 1 km is 6e-5 m), converted to
                // pixels with this point's own magnification dev / h.
                const double slack = h > 0 ? dev / h * 1e-3 : 0;
                out.maxPixels = std::max(out.maxPixels, dev);
                out.maxOverBound = std::max(out.maxOverBound, dev - (pixels * (1 + 1e-6) + slack));
            }
            if (at != i) nodeRiverDeviation(cam, leaf, drawn, level, pixels, out);
        }
        return out;
    }

    // World point p at height z, outside `level`'s domain of `block` (its outline moved), against
    // the nearest point of the level's outline (edges of one triangle) horizontally: false when
    // that is farther than hs (1 mm slack); else the horizontal segment to it at the point's
    // height, projected, counts like a point's segment to its surface (the outline's planimetric
    // deviation is part of the `max` error, deletion.h; a horizontal displacement gets no sin phi
    // factor, engine/lod/lod.h).
    static bool outlineDeviation(const Projector& cam, const format::Block& block,
                                 const format::Level& level, const double p[2], double z,
                                 double hs, double pixels, Deviation& out) {
        std::set<std::pair<std::uint32_t, std::uint32_t>> directed;
        for (std::uint32_t t = 0; t < level.triangleCount; ++t) {
            const format::Triangle& tri = block.terrainIndices[level.triangleFirst + t];
            directed.insert({tri.a, tri.b}), directed.insert({tri.b, tri.c}),
                directed.insert({tri.c, tri.a});
        }
        auto world = [&](std::uint32_t v, double w[2]) {
            w[0] = block.originX + double(block.grid[v].x) * format::kGridUnit;
            w[1] = block.originY + double(block.grid[v].y) * format::kGridUnit;
        };
        double best[2] = {0, 0}, bestD2 = INFINITY;
        for (const auto& [u, w] : directed) {
            if (directed.count({w, u})) continue;
            double a[2], c[2];
            world(u, a), world(w, c);
            const double dx = c[0] - a[0], dy = c[1] - a[1], d2 = dx * dx + dy * dy;
            const double t =
                d2 > 0 ? std::clamp(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / d2, 0.0, 1.0)
                       : 0.0;
            const double q[2] = {a[0] + t * dx, a[1] + t * dy};
            const double e2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]);
            if (e2 < bestD2) bestD2 = e2, best[0] = q[0], best[1] = q[1];
        }
        const double metres = std::sqrt(bestD2);
        if (!(metres <= hs + 1e-3)) return false;
        ++out.outside;
        const auto sp = cam.project(p[0], p[1], z);
        const auto sq = cam.project(best[0], best[1], z);
        if (!(sp.inside || sq.inside) || !(sp.depth >= 1.0 && sq.depth >= 1.0)) return true;
        ++out.checked;
        const double dev = std::hypot(sp.x - sq.x, sp.y - sq.y);
        const double slack = metres > 0 ? dev / metres * 1e-3 : 0;
        out.maxPixels = std::max(out.maxPixels, dev);
        out.maxOverBound = std::max(out.maxOverBound, dev - (pixels * (1 + 1e-6) + slack));
        return true;
    }

    // The original river vertices of a leaf drawn through a tree node against the nearest river
    // edge the node draws (3D, projected like a point's segment). The edge that replaced a vertex
    // is within h_s of it (the node measures its river deviation against the original river
    // points each edge replaced: nodebuild.h, deletion.h RiverCover), so the nearest one is; this
    // is the weaker check of the two, the one that needs no chain through the node's vertices.
    static void nodeRiverDeviation(const Projector& cam, const format::Block& leaf,
                                   const format::Block& node, const format::Level& level,
                                   double pixels, Deviation& out) {
        const format::Level& full = leaf.levels.front();
        std::vector<std::uint8_t> degree(leaf.vertices.size(), 0);
        for (std::uint32_t e = full.riverFirst; e < full.riverFirst + full.riverCount; ++e) {
            ++degree[leaf.riverIndices[e].a];
            ++degree[leaf.riverIndices[e].b];
        }
        auto world = [](const format::Block& b, std::uint32_t v, double w[3]) {
            w[0] = b.originX + double(b.grid[v].x) * format::kGridUnit;
            w[1] = b.originY + double(b.grid[v].y) * format::kGridUnit;
            w[2] = b.vertices[v].z;
        };
        for (std::uint32_t v = 0; v < leaf.vertices.size(); ++v) {
            if (degree[v] == 0) continue;
            ++out.riverTotal;
            double p[3], best[3] = {0, 0, 0}, bestD2 = INFINITY;
            world(leaf, v, p);
            for (std::uint32_t e = level.riverFirst; e < level.riverFirst + level.riverCount; ++e) {
                double a[3], c[3];
                world(node, node.riverIndices[e].a, a), world(node, node.riverIndices[e].b, c);
                double d2 = 0, dot = 0;
                for (int k = 0; k < 3; ++k) {
                    d2 += (c[k] - a[k]) * (c[k] - a[k]);
                    dot += (p[k] - a[k]) * (c[k] - a[k]);
                }
                const double t = d2 > 0 ? std::clamp(dot / d2, 0.0, 1.0) : 0.0;
                double q[3], e2 = 0;
                for (int k = 0; k < 3; ++k) {
                    q[k] = a[k] + t * (c[k] - a[k]);
                    e2 += (p[k] - q[k]) * (p[k] - q[k]);
                }
                if (e2 < bestD2) bestD2 = e2, best[0] = q[0], best[1] = q[1], best[2] = q[2];
            }
            if (!std::isfinite(bestD2)) {
                ADD_FAILURE() << "block (" << node.col << "," << node.row << ") of tree level "
                              << node.level << " draws no river edge for a river of block ("
                              << leaf.col << "," << leaf.row << ")";
                return;
            }
            const auto sp = cam.project(p[0], p[1], p[2]);
            const auto sq = cam.project(best[0], best[1], best[2]);
            if (!(sp.inside || sq.inside) || !(sp.depth >= 1.0 && sq.depth >= 1.0)) continue;
            ++out.riverChecked;
            const double dev = std::hypot(sp.x - sq.x, sp.y - sq.y);
            const double metres = std::sqrt(bestD2);
            const double slack = metres > 0 ? dev / metres * 1e-3 : 0;  // float storage, 1 mm
            out.riverMaxPixels = std::max(out.riverMaxPixels, dev);
            out.maxOverBound = std::max(out.maxOverBound, dev - (pixels * (1 + 1e-6) + slack));
        }
    }

    // Every original river vertex deleted at the drawn level against the drawn river edge A-C
    // that replaced it (A, C: the nearest alive vertices along the full-resolution river chain):
    // the segment from the vertex to the nearest point of A-C in 3D, projected, when one end is
    // on screen. Its length bounds the on-screen distance to the drawn river line.
    // `alive`: the vertices alive (a refined leaf's); null: those below the level's vertexCount.
    static void riverDeviation(const Projector& cam, const format::Block& block,
                               const format::Level& level, double pixels, Deviation& out,
                               const std::vector<std::uint8_t>* alive = nullptr) {
        const auto isAlive = [&](std::uint32_t v) {
            return alive ? (*alive)[v] != 0 : v < level.vertexCount;
        };
        const format::Level& full = block.levels.front();
        std::vector<std::vector<std::uint32_t>> next(block.vertices.size());
        for (std::uint32_t e = full.riverFirst; e < full.riverFirst + full.riverCount; ++e) {
            const format::Edge& edge = block.riverIndices[e];
            next[edge.a].push_back(edge.b);
            next[edge.b].push_back(edge.a);
        }
        auto world = [&](std::uint32_t v, double w[3]) {
            w[0] = block.originX + double(block.grid[v].x) * format::kGridUnit;
            w[1] = block.originY + double(block.grid[v].y) * format::kGridUnit;
            w[2] = block.vertices[v].z;
        };
        for (std::uint32_t v = 0; v < block.vertices.size(); ++v) {
            if (isAlive(v)) continue;
            if (next[v].size() != 2) continue;  // a DEM point (or a kept end / junction)
            ++out.riverTotal;
            std::uint32_t ends[2];
            for (int side = 0; side < 2; ++side) {
                std::uint32_t prev = v, cur = next[v][std::size_t(side)];
                while (!isAlive(cur)) {
                    const std::uint32_t n = next[cur][0] == prev ? next[cur][1] : next[cur][0];
                    prev = cur, cur = n;
                }
                ends[side] = cur;
            }
            double p[3], a[3], c[3];
            world(v, p), world(ends[0], a), world(ends[1], c);
            double d2 = 0, dot = 0;
            for (int k = 0; k < 3; ++k) {
                d2 += (c[k] - a[k]) * (c[k] - a[k]);
                dot += (p[k] - a[k]) * (c[k] - a[k]);
            }
            const double t = d2 > 0 ? std::clamp(dot / d2, 0.0, 1.0) : 0.0;
            double q[3];
            for (int k = 0; k < 3; ++k)
                q[k] = a[k] + t * (c[k] - a[k]);
            const auto sp = cam.project(p[0], p[1], p[2]);
            const auto sq = cam.project(q[0], q[1], q[2]);
            if (!(sp.inside || sq.inside) || !(sp.depth >= 1.0 && sq.depth >= 1.0)) continue;
            ++out.riverChecked;
            const double dev = std::hypot(sp.x - sq.x, sp.y - sq.y);
            const double metres = std::sqrt((p[0] - q[0]) * (p[0] - q[0]) +
                                            (p[1] - q[1]) * (p[1] - q[1]) +
                                            (p[2] - q[2]) * (p[2] - q[2]));
            const double slack = metres > 0 ? dev / metres * 1e-3 : 0;  // float storage, 1 mm
            out.riverMaxPixels = std::max(out.riverMaxPixels, dev);
            out.maxOverBound = std::max(out.maxOverBound, dev - (pixels * (1 + 1e-6) + slack));
        }
    }

    static void print(const char* what, const Deviation& dev, double pixels) {
        std::printf(
            "[ guarantee ] %s: P = %g px, max deviation %.4f px, %zu of %zu points checked, "
            "%zu blocks coarser than full resolution (%zu tree nodes); rivers: max deviation "
            "%.4f px, %zu of %zu river vertices checked\n",
            what, pixels, dev.maxPixels, dev.checked, dev.total, dev.coarseBlocks, dev.nodes,
            dev.riverMaxPixels, dev.riverChecked, dev.riverTotal);
    }

    // The guarantee and its non-vacuity.
    static void expectGuarantee(const char* what, const Drawn& d, double pixels) {
        const Deviation dev = deviation(d, pixels);
        print(what, dev, pixels);
        EXPECT_EQ(dev.unlocated, 0u) << what;
        EXPECT_LE(dev.maxOverBound, 0.0) << what << ": max deviation " << dev.maxPixels << " px";
        // The stored h_s is the level's true maximum vertical error (float slack 1 mm).
        EXPECT_LE(dev.maxMetresOverHs, 1e-3) << what;
        EXPECT_GT(dev.checked, dev.total / 2) << what;
        EXPECT_GT(dev.coarseBlocks, 0u) << what;
        // Across tree levels (issue 18): the cut draws tree nodes next to leaf blocks.
        EXPECT_GT(dev.nodes, 0u) << what;
        EXPECT_LT(dev.nodes, d.json["blocks"].size()) << what;
        // The bound is exercised: observed 0.45-0.67 P (DEM points) with the tree's hand-over
        // (nodebuild.h; 0.92 P on the flat block grid): a node is drawn at the tolerance of its
        // nearest point, so its farther points keep a margin.
        EXPECT_GT(std::max(dev.maxPixels, dev.riverMaxPixels), 0.3 * pixels) << what;
        EXPECT_GT(dev.riverChecked, 100u) << what;
        // The default draws the leaves refined from their records (lod/refine.h): the bound
        // holds for those meshes too.
        if (d.json["distance"] == "nearest") {
            EXPECT_GT(d.refinedLeaves, 0u) << what;
        }
    }

    // Oblique: 3 km south of the data, 3 km above its top, looking north 25 degrees down; the
    // data spans ~3..35 km from the eye, so near blocks are fine and far ones coarse.
    static std::string oblique() { return camera(0, -3000, 3000, 0, -25); }
    // The same, closer and lower (1 km south, 1 km above the top): at P = 3 the far part is
    // drawn by tree nodes, the near part by leaves.
    static std::string obliqueNear() { return camera(0, -1000, 1000, 0, -25); }

    // Height of the drawn surface at world (x, y): the highest over the blocks holding the point
    // (they agree on shared borders); -inf outside the data.
    static double surfaceZ(const Drawn& d, double x, double y) {
        double z = -std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < blocks_->size(); ++i) {
            const format::Block& b = (*blocks_)[i];
            if (!d.surfaces[i] || x < b.minX || x > b.maxX || y < b.minY || y > b.maxY) continue;
            const double s = d.surfaces[i]->z(x - b.originX, y - b.originY);
            if (!std::isnan(s)) z = std::max(z, s);
        }
        return z;
    }

    static fs::path dir_;
    static std::string file_;
    static format::Reader* reader_;
    static std::vector<format::Block>* blocks_;
    static std::vector<std::size_t>* parent_;  // per directory entry: its tree parent or SIZE_MAX
};

fs::path Guarantee::dir_;
std::string Guarantee::file_;
format::Reader* Guarantee::reader_ = nullptr;
std::vector<format::Block>* Guarantee::blocks_ = nullptr;
std::vector<std::size_t>* Guarantee::parent_ = nullptr;

TEST_F(Guarantee, ObliqueView) {
    const Drawn d = capture("oblique", oblique(), 1, "nearest");
    expectGuarantee("oblique", d, 1);
}

// Top-down from 22 km: every point is 22-30 km away, so the cut mixes tree levels only where the
// nodes' starting errors lie in that narrow band of tolerances: P = 0.4 (P = 1 draws the root
// alone, P = 0.3 leaves only, with today's hand-over, nodebuild.h).
TEST_F(Guarantee, TopDownView) {
    const format::Header& h = reader_->header();
    const Drawn d =
        capture("topdown", camera(0, (h.maxY - h.minY) / 2, 22000, 0, -90), 0.4, "nearest");
    expectGuarantee("top-down", d, 0.4);
    EXPECT_GT(d.refinedNodes, 0u);  // tree nodes drawn refined too (their stored errors)
}

TEST_F(Guarantee, ThreePixels) {
    const Drawn d = capture("three", obliqueNear(), 3, "nearest");
    expectGuarantee("oblique, P = 3", d, 3);
}

// No crack where drawn blocks of different tree levels meet: a capture at P = 1 and at P = 3
// (cuts with nodes and leaves side by side) against a reference at P = 0.02 (leaves at full
// resolution, the original surface within 0.02 px): a background pixel of the capture must have a
// background pixel of the reference within ceil(P) + 1 px (the silhouette and the model's
// outline move by at most P px: the guarantee above; 1 px for rasterisation). Anything else is a
// hole in the terrain.
TEST_F(Guarantee, CutHasNoCracks) {
    const Drawn reference = capture("reference", obliqueNear(), 0.02, "nearest");
    ASSERT_FALSE(reference.json.is_discarded());
    const auto background = [](const Image& image, int x, int y) {
        const std::uint8_t* p = &image.rgba[(std::size_t(y) * image.width + x) * 4];
        return p[0] == 0 && p[1] == 0 && p[2] == 0;
    };
    std::size_t terrain = 0;
    for (int y = 0; y < int(reference.image.height); ++y)
        for (int x = 0; x < int(reference.image.width); ++x) terrain += !background(reference.image, x, y);
    // Non-vacuous: the terrain fills most of the view, and the sky is there too.
    EXPECT_GT(terrain, reference.image.rgba.size() / 4 / 2);
    for (const double pixels : {1.0, 3.0}) {
        const Drawn d =
            capture(pixels == 1 ? "cracks1" : "cracks3", obliqueNear(), pixels, "nearest");
        ASSERT_FALSE(d.json.is_discarded());
        ASSERT_EQ(d.image.width, reference.image.width);
        ASSERT_EQ(d.image.height, reference.image.height);
        std::size_t nodes = 0;
        for (const nlohmann::json& b : d.json["blocks"]) nodes += b["tree_level"].get<int>() > 0;
        EXPECT_GT(nodes, 0u) << "P = " << pixels;
        EXPECT_LT(nodes, d.json["blocks"].size()) << "P = " << pixels;
        const int r = int(std::ceil(pixels)) + 1;
        const int w = int(d.image.width), h = int(d.image.height);
        std::size_t holes = 0;
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                if (!background(d.image, x, y)) continue;
                bool near = false;
                for (int dy = -r; dy <= r && !near; ++dy)
                    for (int dx = -r; dx <= r && !near; ++dx) {
                        const int xx = x + dx, yy = y + dy;
                        near = xx < 0 || yy < 0 || xx >= w || yy >= h ||
                               background(reference.image, xx, yy);
                    }
                if (!near && ++holes <= 5)
                    ADD_FAILURE() << "P = " << pixels << ": background pixel (" << x << ", " << y
                                  << ") inside the terrain";
            }
        }
        std::printf("[ cracks    ] P = %g: %zu drawn (%zu tree nodes), %zu holes\n", pixels,
                    std::size_t(d.json["blocks"].size()), nodes, holes);
        EXPECT_EQ(holes, 0u);
    }
}

// Negative control: the paper's S (distance to the block centre) gives no guarantee; the
// deviation is measured and printed only.
TEST_F(Guarantee, CentreDistanceIsMeasured) {
    const Drawn d = capture("centre", oblique(), 1, "centre");
    const Deviation dev = deviation(d, 1);
    print("oblique, --distance centre (no guarantee)", dev, 1);
    EXPECT_GT(dev.checked, dev.total / 2);
}

}  // namespace

namespace {

bool riverPixel(const Image& image, int x, int y) {
    if (x < 0 || y < 0 || x >= int(image.width) || y >= int(image.height)) return false;
    const std::uint8_t* p = &image.rgba[(std::size_t(y) * image.width + x) * 4];
    const int r = int(std::lround(engine::shader::kRiverColour.r * 255));
    const int g = int(std::lround(engine::shader::kRiverColour.g * 255));
    const int b = int(std::lround(engine::shader::kRiverColour.b * 255));
    return std::abs(p[0] - r) <= 2 && std::abs(p[1] - g) <= 2 && std::abs(p[2] - b) <= 2;
}

// A river-coloured pixel within 1 px (3 x 3 neighbourhood) of the screen point.
bool riverNear(const Image& image, double x, double y) {
    const int cx = int(std::floor(x)), cy = int(std::floor(y));
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
            if (riverPixel(image, cx + dx, cy + dy)) return true;
    return false;
}

}  // namespace

namespace {

// Rivers are drawn where the renderer says: every drawn river edge of the chosen levels is
// sampled at 10%, 20%, ..., 90%, projected with the test's own camera, and the samples that the
// drawn terrain does not hide must land on river-coloured pixels. This also checks the test's
// projection against the renderer's.
TEST_F(Guarantee, RiversAreDrawn) {
    const Drawn d = capture("rivers", oblique(), 1, "nearest");
    ASSERT_FALSE(d.json.is_discarded());
    ASSERT_EQ(d.image.width, 640u);
    ASSERT_EQ(d.image.height, 480u);
    const Projector cam(d.json);
    const double topZ = reader_->header().maxZ;
    std::size_t samples = 0, hits = 0, shiftedHits = 0, occluded = 0;
    for (std::size_t i = 0; i < blocks_->size(); ++i) {
        if (!d.surfaces[i]) continue;
        const format::Block& block = d.block(i);
        const format::Level& level = block.levels[d.level[i]];
        for (std::uint32_t e = level.riverFirst; e < level.riverFirst + level.riverCount; ++e) {
            const format::Vertex& a = block.vertices[block.riverIndices[e].a];
            const format::Vertex& b = block.vertices[block.riverIndices[e].b];
            for (int k = 1; k <= 9; ++k) {
                const double t = k / 10.0;
                const double p[3] = {block.originX + a.x + t * (double(b.x) - a.x),
                                     block.originY + a.y + t * (double(b.y) - a.y),
                                     a.z + t * (double(b.z) - a.z)};
                const auto s = cam.project(p[0], p[1], p[2]);
                if (!s.inside || s.x < 2 || s.y < 2 || s.x > cam.width - 2 || s.y > cam.height - 2)
                    continue;
                // Occlusion on the CPU: march from the eye towards the sample (only where the
                // ray is below the data's top) and call the sample hidden if the drawn surface
                // comes within 0.5 m of the ray. The march stops 0.4% short of the sample: the
                // renderer pulls rivers 0.2% of their distance towards the eye (kRiverDepthBias),
                // so terrain that close to the sample does not hide it, and the sample's own
                // triangles (the river edge is one of their edges) must not count. Steps of
                // 20 m are a fraction of the DEM's 74 x 93 m cells.
                const double ray[3] = {p[0] - cam.eye[0], p[1] - cam.eye[1], p[2] - cam.eye[2]};
                const double length =
                    std::sqrt(ray[0] * ray[0] + ray[1] * ray[1] + ray[2] * ray[2]);
                double t0 = 0;
                if (cam.eye[2] > topZ && ray[2] < 0) t0 = (cam.eye[2] - topZ) / -ray[2];
                const double t1 = 1 - 2.0 * engine::shader::kRiverDepthBias;
                bool hidden = false;
                for (double tt = t0; tt < t1 && !hidden; tt += 20.0 / length) {
                    const double x = cam.eye[0] + tt * ray[0], y = cam.eye[1] + tt * ray[1];
                    hidden = surfaceZ(d, x, y) > cam.eye[2] + tt * ray[2] - 0.5;
                }
                if (hidden) {
                    ++occluded;
                    continue;
                }
                ++samples;
                if (riverNear(d.image, s.x, s.y)) ++hits;
                if (riverNear(d.image, s.x + 12, s.y)) ++shiftedHits;
            }
        }
    }
    // Threshold 90%: a miss comes from the CPU's occlusion proxy (a 20 m march that stops short
    // of the sample and ignores the depth-buffer precision) and from 1-px line rasterisation at
    // grazing angles, where the terrain's own depth at a neighbouring pixel can still win; the
    // observed rate is ~96%. A broken river pass (not drawn, wrong colour, wrong transform,
    // lost depth bias) drops it far below: a 12 px shift, for instance, gives ~23%.
    std::printf(
        "[ rivers    ] %zu unoccluded samples (%zu hidden), %zu on river pixels (%.1f%%); "
        "control 12 px to the right: %zu (%.1f%%)\n",
        samples, occluded, hits, 100.0 * hits / std::max<std::size_t>(samples, 1), shiftedHits,
        100.0 * shiftedHits / std::max<std::size_t>(samples, 1));
    EXPECT_GE(samples, 100u);
    EXPECT_GE(double(hits), 0.9 * double(samples));
    // Control: the same samples moved off the rivers mostly miss them, so the hits above are
    // not an image that is river-coloured everywhere.
    EXPECT_LT(double(shiftedHits), 0.5 * double(samples));
}

}  // namespace
