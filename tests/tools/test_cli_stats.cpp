// `unilod stats` and computeStats (preprocess/stats.h): the paper's Tables 2 and 3 on a small
// synthetic model with a 4x4 block grid. Every column is recomputed here straight from the file
// (format::Reader) with the formulas written out again, and compared with the library and with
// the CLI's CSV; plus monotonicity in distance and pixels, text output and usage errors.
#include <gtest/gtest.h>

#include "tools/cliutil.h"
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <nlohmann/json.hpp>
#include <sstream>

#include "build.h"
#include "stats.h"
#include "synthetic.h"
#include "ulod.h"
#include "ulodbytes.h"

using namespace unilod;
namespace fs = std::filesystem;

namespace {

using unilod::test::q;
using unilod::test::slurp;
using Result = unilod::test::CliResult;
Result run(const std::string& args) { return unilod::test::runCli(args); }

std::vector<std::string> split(const std::string& line, char sep) {
    std::vector<std::string> fields;
    std::stringstream s(line);
    std::string f;
    while (std::getline(s, f, sep))
        fields.push_back(f);
    return fields;
}

// Expected values, computed from the file without the library's code.
struct Expected {
    double hEdge, hCorner, hMiddle, retention;
    std::uint64_t points = 0, riverEdges = 0, triangles = 0;
};

class StatsTest : public ::testing::Test {
protected:
    static inline fs::path dir;
    static inline std::string model;
    static inline std::vector<format::Block> blocks;
    static inline format::Header header;
    static inline int demCells = 0;  // the longer side of the DEM

    static void SetUpTestSuite() {
        dir = fs::temp_directory_path() / ("unilod_test_stats_" + std::to_string(getpid()));
        fs::remove_all(dir);
        SyntheticOptions so;
        so.targetPoints = 3000;
        so.seed = 7;
        const SyntheticData data = generateSyntheticData(so);
        std::string error;
        ASSERT_TRUE(writeSyntheticData(data, dir.string(), error)) << error;
        demCells = std::max(data.dem.width, data.dem.height);
        BuildOptions bo;
        bo.demPath = (dir / "dem.tif").string();
        bo.riversPath = (dir / "rivers.geojson").string();
        bo.outPath = (dir / "model.ulod").string();
        bo.blockSize = (std::max(data.dem.width, data.dem.height) - 1) / 4;  // about 4 x 4 blocks
        bo.threads = 2;
        bo.paperMetric = true;  // both metrics: the paper-metric rows are tested below
        BuildSummary summary;
        ASSERT_TRUE(runBuild(bo, summary, error)) << error;
        model = bo.outPath;

        format::Reader reader;
        ASSERT_TRUE(reader.open(model, error)) << error;
        header = reader.header();
        blocks.resize(reader.blocks().size());
        for (std::size_t i = 0; i < blocks.size(); ++i) {
            ASSERT_TRUE(reader.readBlock(i, blocks[i], error)) << error;
        }
    }
    static void TearDownTestSuite() {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }

    static const format::Block& blockAt(std::uint32_t col, std::uint32_t row) {
        for (const format::Block& b : blocks) {
            if (b.col == col && b.row == row) return b;
        }
        ADD_FAILURE() << "no block (" << col << "," << row << ")";
        return blocks.front();
    }

    static Expected expected(double distance, double pixels, bool paper = false, double fov = 60.0,
                             double height = 1080.0) {
        // Eye above the extent's centre, `distance` above the highest point.
        const double ex = (header.minX + header.maxX) / 2, ey = (header.minY + header.maxY) / 2;
        const double ez = header.maxZ + distance;
        auto hlim = [&](const format::Block& b) {
            const double dx = (b.minX + b.maxX) / 2 - ex, dy = (b.minY + b.maxY) / 2 - ey;
            const double dz = (b.minZ + b.maxZ) / 2 - ez;
            const double s = std::sqrt(dx * dx + dy * dy + dz * dz);
            return 2 * pixels * s * std::tan(fov / 2 * M_PI / 180) / height;
        };
        Expected e;
        std::uint64_t full = 0;
        for (const format::Block& b : blocks) {
            const std::vector<float>& err = paper ? b.errorPaper : b.errorMax;
            const double limit = hlim(b);
            std::size_t k = 0;
            for (std::size_t s = 0; s < err.size(); ++s) {
                if (err[s] <= limit) k = s;
            }
            e.points += b.vertices.size() - k;
            e.riverEdges += k == 0 ? b.levels[0].riverCount : b.steps[k - 1].riverEdgesAlive;
            e.triangles += k == 0 ? b.levels[0].triangleCount : b.steps[k - 1].trianglesAlive;
            full += b.vertices.size();
        }
        e.retention = 100.0 * double(e.points) / double(full);
        const std::uint32_t mc = (header.blocksX - 1) / 2, mr = (header.blocksY - 1) / 2;
        e.hCorner = hlim(blockAt(0, 0));
        e.hEdge = hlim(blockAt(mc, 0));
        e.hMiddle = hlim(blockAt(mc, mr));
        return e;
    }
};

const std::vector<double> kDistances = {500, 2000, 10e3, 50e3, 200e3};
const std::vector<double> kPixels = {1, 2, 3};

TEST_F(StatsTest, GridIsAtLeastThreeByThree) {
    EXPECT_GE(header.blocksX, 3u);
    EXPECT_GE(header.blocksY, 3u);
    EXPECT_EQ(blocks.size(), std::size_t(header.blocksX) * header.blocksY);
}

TEST_F(StatsTest, EveryColumnMatchesAHandComputation) {
    StatsOptions o;
    o.distances = kDistances;
    o.pixels = kPixels;
    StatsTable t;
    std::string error;
    ASSERT_TRUE(computeStats(model, o, t, error)) << error;
    EXPECT_EQ(t.metric, header.defaultMetric);
    ASSERT_EQ(t.rows.size(), kDistances.size() * kPixels.size());
    std::uint64_t full = 0;
    for (const format::Block& b : blocks)
        full += b.vertices.size();
    EXPECT_EQ(t.fullPoints, full);
    EXPECT_EQ(t.cornerCol, 0u);
    EXPECT_EQ(t.cornerRow, 0u);
    EXPECT_EQ(t.edgeCol, (header.blocksX - 1) / 2);
    EXPECT_EQ(t.edgeRow, 0u);
    EXPECT_EQ(t.middleCol, (header.blocksX - 1) / 2);
    EXPECT_EQ(t.middleRow, (header.blocksY - 1) / 2);
    std::set<std::uint64_t> distinctPoints;
    std::size_t i = 0;
    for (double d : kDistances) {
        for (double p : kPixels) {
            const StatsRow& r = t.rows[i++];
            const Expected e = expected(d, p);
            EXPECT_EQ(r.distance, d);
            EXPECT_EQ(r.pixels, p);
            EXPECT_NEAR(r.hEdge, e.hEdge, 1e-9 * e.hEdge);
            EXPECT_NEAR(r.hCorner, e.hCorner, 1e-9 * e.hCorner);
            EXPECT_NEAR(r.hMiddle, e.hMiddle, 1e-9 * e.hMiddle);
            EXPECT_EQ(r.points, e.points) << "D " << d << " P " << p;
            EXPECT_EQ(r.riverEdges, e.riverEdges) << "D " << d << " P " << p;
            EXPECT_EQ(r.triangles, e.triangles) << "D " << d << " P " << p;
            EXPECT_NEAR(r.retention, e.retention, 1e-9);
            distinctPoints.insert(r.points);
        }
    }
    // The distances were chosen to span fine to coarse: the table is not trivially constant.
    EXPECT_GE(distinctPoints.size(), 3u);
}

TEST_F(StatsTest, PaperMetricAndViewport) {
    StatsOptions o;
    o.distances = {3000, 30e3};
    o.pixels = {1.5};
    o.metric = format::kMetricPaper;
    o.fovDegrees = 45;
    o.heightPixels = 720;
    StatsTable t;
    std::string error;
    ASSERT_TRUE(computeStats(model, o, t, error)) << error;
    EXPECT_EQ(t.metric, std::uint32_t(format::kMetricPaper));
    ASSERT_EQ(t.rows.size(), 2u);
    for (std::size_t i = 0; i < 2; ++i) {
        const Expected e = expected(o.distances[i], 1.5, true, 45, 720);
        EXPECT_NEAR(t.rows[i].hEdge, e.hEdge, 1e-9 * e.hEdge);
        EXPECT_EQ(t.rows[i].points, e.points);
        EXPECT_EQ(t.rows[i].riverEdges, e.riverEdges);
        EXPECT_EQ(t.rows[i].triangles, e.triangles);
    }
}

TEST_F(StatsTest, MonotonicInDistanceAndPixels) {
    StatsOptions o;
    o.distances = {200, 1000, 3000, 10e3, 30e3, 100e3, 1000e3};
    o.pixels = {0.5, 1, 2, 3, 8};
    StatsTable t;
    std::string error;
    ASSERT_TRUE(computeStats(model, o, t, error)) << error;
    const std::size_t np = o.pixels.size();
    for (std::size_t di = 0; di < o.distances.size(); ++di) {
        for (std::size_t pi = 0; pi < np; ++pi) {
            const StatsRow& r = t.rows[di * np + pi];
            EXPECT_LE(r.points, t.fullPoints);
            if (di > 0) {
                const StatsRow& nearer = t.rows[(di - 1) * np + pi];
                EXPECT_LE(r.points, nearer.points);
                EXPECT_LE(r.triangles, nearer.triangles);
                EXPECT_GT(r.hMiddle, nearer.hMiddle);
            }
            if (pi > 0) {
                const StatsRow& finer = t.rows[di * np + pi - 1];
                EXPECT_LE(r.points, finer.points);
                EXPECT_LE(r.triangles, finer.triangles);
            }
        }
    }
    // Nearest view at half a pixel: full resolution almost everywhere; farthest: far coarser.
    EXPECT_LT(t.rows.back().points, t.rows.front().points);
}

TEST_F(StatsTest, CsvMatchesTheHandComputation) {
    const Result r =
        run("stats '" + model + "' --distance 500m,2km,10km,50km,200km --pixels 1,2,3 --csv");
    ASSERT_EQ(r.code, 0) << r.err;
    std::stringstream in(r.out);
    std::string line;
    ASSERT_TRUE(std::getline(in, line));
    EXPECT_EQ(line,
              "view_distance_m,pixels,hlim_edge_m,hlim_corner_m,hlim_middle_m,points,"
              "river_bound_edges,triangles,retention_percent,nodes");
    std::size_t rows = 0;
    for (double d : kDistances) {
        for (double p : kPixels) {
            ASSERT_TRUE(std::getline(in, line));
            const auto f = split(line, ',');
            ASSERT_EQ(f.size(), 10u) << line;
            const Expected e = expected(d, p);
            EXPECT_DOUBLE_EQ(std::stod(f[0]), d);
            EXPECT_DOUBLE_EQ(std::stod(f[1]), p);
            EXPECT_NEAR(std::stod(f[2]), e.hEdge, 1e-9 * e.hEdge);
            EXPECT_NEAR(std::stod(f[3]), e.hCorner, 1e-9 * e.hCorner);
            EXPECT_NEAR(std::stod(f[4]), e.hMiddle, 1e-9 * e.hMiddle);
            EXPECT_EQ(std::stoull(f[5]), e.points);
            EXPECT_EQ(std::stoull(f[6]), e.riverEdges);
            EXPECT_EQ(std::stoull(f[7]), e.triangles);
            EXPECT_NEAR(std::stod(f[8]), e.retention, 1e-9);
            ++rows;
        }
    }
    EXPECT_EQ(rows, 15u);
    EXPECT_FALSE(std::getline(in, line)) << "extra line: " << line;
}

TEST_F(StatsTest, TextTableHasThePaperColumns) {
    const Result r = run("stats '" + model + "' --distance 1km,100km --pixels 2");
    ASSERT_EQ(r.code, 0) << r.err;
    for (const char* h :
         {"View distance (km)", "The tolerance of screen projection error (Pixel)",
          "The tolerance of model space error (m)", "The number of points to construct a network",
          "The number of river bound edges", "Total number of triangles",
          "Percentage of data retention (%)", "(edge)", "(corner)", "(middle)"}) {
        EXPECT_NE(r.out.find(h), std::string::npos) << h << "\n" << r.out;
    }
    // Header + title + three lines per (D, P) row.
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 2 + 3 * 2);
}

TEST_F(StatsTest, DefaultsAreThePaperDistances) {
    const Result r = run("stats '" + model + "' --csv");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto lines = split(r.out, '\n');
    ASSERT_EQ(lines.size(), 6u);
    const double expectedD[] = {100e3, 200e3, 500e3, 1000e3, 1500e3};
    for (std::size_t i = 0; i < 5; ++i) {
        EXPECT_DOUBLE_EQ(std::stod(split(lines[i + 1], ',')[0]), expectedD[i]);
        EXPECT_DOUBLE_EQ(std::stod(split(lines[i + 1], ',')[1]), 1.0);
    }
}

// A metric the file does not store: every command that chooses levels refuses it with the same
// message naming the file (one rule, format::resolveMetric) and writes nothing; the file's own
// metric is taken when --metric is not given.
TEST_F(StatsTest, MetricTheFileLacksRefusedByEveryCommand) {
    BuildOptions bo;
    bo.demPath = (dir / "dem.tif").string();
    bo.riversPath = (dir / "rivers.geojson").string();
    bo.outPath = (dir / "max_only.ulod").string();
    bo.threads = 2;
    BuildSummary summary;
    std::string error;
    ASSERT_TRUE(runBuild(bo, summary, error)) << error;
    const std::string file = q(bo.outPath), out = (dir / "metric_out").string();
    for (const std::string& command :
         {"stats " + file, "stats " + file + " --error 5", "export " + file + " -o " + q(out),
          "export " + file + " --3dtiles " + q(out),
          "report " + file + " -o " + q(out) + " --no-rivers --bench-frames 0",
          "capture " + file + " -o " + q(out) + " --size 16x16"}) {
        SCOPED_TRACE(command);
        const Result r = run(command + " -q --metric paper");
        EXPECT_EQ(r.code, 1) << r.out << r.err;
        EXPECT_NE(r.err.find(bo.outPath + ": the file has no 'paper' error metric"),
                  std::string::npos)
            << r.err;
        EXPECT_FALSE(fs::exists(out));
    }
    const Result ok = run("stats " + file + " --distance 1km --csv");
    EXPECT_EQ(ok.code, 0) << ok.err;
    const Result both = run("stats " + q(model) + " --distance 1km --metric paper --csv");
    EXPECT_EQ(both.code, 0) << both.err;
}

// The blocks are read on --threads threads with a progress line on stderr (silent and on one
// thread until 2026-12-03); the tables are the same for any number of threads, and -q silences
// the progress.
TEST_F(StatsTest, BlocksReadOnThreadsWithProgress) {
    for (const std::string& table : {std::string(" --error 0,2,20"), std::string(" --csv")}) {
        SCOPED_TRACE(table);
        const Result one = run("stats " + q(model) + table + " --threads 1");
        ASSERT_EQ(one.code, 0) << one.err;
        EXPECT_NE(one.err.find("stats: reading blocks"), std::string::npos) << one.err;
        // The fixture's flat grid (paper metric: no tree) draws every block at any distance and
        // error: every block read, and counted.
        EXPECT_NE(one.err.find("/" + std::to_string(blocks.size()) + "  100 %"), std::string::npos)
            << one.err;
        for (const char* threads : {"2", "5", "0"}) {
            const Result many = run("stats " + q(model) + table + " --threads " + threads);
            EXPECT_EQ(many.code, 0) << many.err;
            EXPECT_EQ(many.out, one.out) << threads;
        }
        const Result quiet = run("stats " + q(model) + table + " -q");
        EXPECT_EQ(quiet.out, one.out);
        EXPECT_EQ(quiet.err, "");
    }
}

TEST_F(StatsTest, UsageErrorsExitTwo) {
    for (const char* bad :
         {"--distance 0km", "--distance -5km", "--distance 10furlongs", "--distance km",
          "--pixels 0", "--pixels -1", "--pixels 1,0", "--fov 0", "--fov 180", "--fov -3",
          "--fov abc", "--height 0", "--height 0.5", "--metric median"}) {
        const Result r = run("stats '" + model + "' " + bad);
        EXPECT_EQ(r.code, 2) << bad << "\n" << r.err;
        EXPECT_TRUE(r.out.empty()) << bad;
    }
    EXPECT_EQ(run("stats").code, 2);
}

TEST_F(StatsTest, DataErrorsExitOneAndNameTheFile) {
    const std::string missing = (dir / "missing.ulod").string();
    Result r = run("stats '" + missing + "'");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;
    const std::string junk = (dir / "junk.ulod").string();
    std::ofstream(junk) << "not a ulod file\n";
    r = run("stats '" + junk + "'");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(junk), std::string::npos) << r.err;
}

// The cut is taken from the directory (format version 5): `stats` reads only the blocks the cut
// draws, for their per-step counts. Every entry but the root damaged (its bytes, not the
// directory): a far view, which draws the root alone, gives the same table as the intact file;
// `--error 0`, whose cut is the leaves, reads a damaged one and fails naming the file and the
// block. Only the root damaged: the far view fails naming it.
TEST_F(StatsTest, OnlyTheDrawnNodesAreReadAndADamagedOneFails) {
    BuildOptions bo;
    bo.demPath = (dir / "dem.tif").string();
    bo.riversPath = (dir / "rivers.geojson").string();
    bo.outPath = (dir / "tree.ulod").string();
    bo.blockSize = (demCells - 1) / 4;
    bo.threads = 2;
    BuildSummary summary;
    std::string error;
    ASSERT_TRUE(runBuild(bo, summary, error)) << error;
    ASSERT_GT(summary.nodes, 0u) << "the default build makes a tree";
    format::Reader reader;
    ASSERT_TRUE(reader.open(bo.outPath, error)) << error;
    const std::size_t count = reader.blocks().size();
    ASSERT_EQ(reader.blocks().back().firstChild + reader.blocks().back().childCount, count - 1)
        << "the root is the last entry";
    const std::string damaged = (dir / "tree_damaged.ulod").string();
    test::UlodBytes f = test::UlodBytes::load(bo.outPath);
    for (std::size_t i = 0; i + 1 < count; ++i)
        f.bytes[f.blockAt(i) + f.blockSize(i) / 2] ^= 0x5a;
    ASSERT_TRUE(f.save(damaged));
    const Result intact = run("stats " + q(bo.outPath) + " --distance 1500km");
    ASSERT_EQ(intact.code, 0) << intact.err;
    const Result far = run("stats " + q(damaged) + " --distance 1500km");
    EXPECT_EQ(far.code, 0) << far.err;
    const auto body = [](const std::string& out) { return out.substr(out.find('\n')); };
    EXPECT_EQ(body(far.out), body(intact.out));  // the first line names the file
    const Result exact = run("stats " + q(damaged) + " --error 0");
    EXPECT_EQ(exact.code, 1) << exact.out;
    EXPECT_NE(exact.err.find(damaged + ": block ("), std::string::npos) << exact.err;
    EXPECT_NE(exact.err.find("checksum mismatch"), std::string::npos) << exact.err;
    // Only the root damaged: the far view reads it and fails.
    test::UlodBytes g = test::UlodBytes::load(bo.outPath);
    g.bytes[g.blockAt(count - 1) + g.blockSize(count - 1) / 2] ^= 0x5a;
    ASSERT_TRUE(g.save(damaged));
    const Result root = run("stats " + q(damaged) + " --distance 1500km");
    EXPECT_EQ(root.code, 1) << root.out;
    EXPECT_NE(root.err.find(damaged + ": node ("), std::string::npos) << root.err;
    EXPECT_NE(root.err.find("checksum mismatch"), std::string::npos) << root.err;
}

TEST_F(StatsTest, SmallGridsNameBlockZeroForAll) {
    // A 2 x 2 grid of the same data: corner, edge and middle are all block (0, 0) (stats.h).
    BuildOptions bo;
    bo.demPath = (dir / "dem.tif").string();
    bo.riversPath = (dir / "rivers.geojson").string();
    bo.outPath = (dir / "model2x2.ulod").string();
    std::string error;
    bo.blockSize = (demCells - 1) / 2 + 1;
    BuildSummary summary;
    ASSERT_TRUE(runBuild(bo, summary, error)) << error;
    StatsOptions o;
    o.distances = {1000};
    StatsTable t;
    ASSERT_TRUE(computeStats(bo.outPath, o, t, error)) << error;
    ASSERT_EQ(t.blocksX, 2u);
    ASSERT_EQ(t.blocksY, 2u);
    for (std::uint32_t v :
         {t.cornerCol, t.cornerRow, t.edgeCol, t.edgeRow, t.middleCol, t.middleRow})
        EXPECT_EQ(v, 0u);
    EXPECT_EQ(t.rows[0].hEdge, t.rows[0].hCorner);
    EXPECT_EQ(t.rows[0].hMiddle, t.rows[0].hCorner);
}

// --- `unilod stats --error` (computeErrorStats): uniform model-error thresholds.

// Expected values for one threshold, from the file's own arrays without the library's code.
struct ExpectedError {
    std::uint64_t exactPoints = 0, exactTriangles = 0, levelPoints = 0, levelTriangles = 0;
};

ExpectedError expectedForError(const std::vector<format::Block>& blocks, double e, bool paper) {
    ExpectedError x;
    for (const format::Block& b : blocks) {
        const std::vector<float>& err = paper ? b.errorPaper : b.errorMax;
        std::size_t k = 0;
        for (std::size_t s = 0; s < err.size(); ++s) {
            if (err[s] <= e) k = s;
        }
        x.exactPoints += b.vertices.size() - k;
        x.exactTriangles += k == 0 ? b.levels[0].triangleCount : b.steps[k - 1].trianglesAlive;
        // The engine's rule, written out: the last level whose stored error is within e.
        std::size_t level = 0;
        for (std::size_t i = 0; i < b.levels.size(); ++i) {
            if ((paper ? b.levels[i].errorPaper : b.levels[i].errorMax) <= e) level = i;
        }
        x.levelPoints += b.levels[level].vertexCount;
        x.levelTriangles += b.levels[level].triangleCount;
    }
    return x;
}

const std::vector<double> kErrors = {0, 0.5, 2, 5, 10, 20, 50, 1e4};

TEST_F(StatsTest, ErrorRowsMatchTheFilesArrays) {
    for (const bool paper : {false, true}) {
        ErrorStatsTable t;
        std::string error;
        ASSERT_TRUE(computeErrorStats(model, kErrors,
                                      paper ? format::kMetricPaper : format::kMetricMax, t, error))
            << error;
        ASSERT_EQ(t.rows.size(), kErrors.size());
        EXPECT_EQ(t.blocks, blocks.size());
        std::set<std::uint64_t> distinct;
        for (std::size_t i = 0; i < kErrors.size(); ++i) {
            const ExpectedError x = expectedForError(blocks, kErrors[i], paper);
            const ErrorStatsRow& r = t.rows[i];
            EXPECT_EQ(r.error, kErrors[i]);
            EXPECT_EQ(r.exactPoints, x.exactPoints) << "e " << kErrors[i];
            EXPECT_EQ(r.exactTriangles, x.exactTriangles) << "e " << kErrors[i];
            EXPECT_EQ(r.levelPoints, x.levelPoints) << "e " << kErrors[i];
            EXPECT_EQ(r.levelTriangles, x.levelTriangles) << "e " << kErrors[i];
            // A stored level is one of the steps up to k*: never finer than the exact state.
            EXPECT_GE(r.levelTriangles, r.exactTriangles);
            EXPECT_GE(r.levelPoints, r.exactPoints);
            distinct.insert(r.exactTriangles);
            if (i > 0) {
                EXPECT_LE(r.exactTriangles, t.rows[i - 1].exactTriangles);
                EXPECT_LE(r.exactPoints, t.rows[i - 1].exactPoints);
                EXPECT_LE(r.levelTriangles, t.rows[i - 1].levelTriangles);
            }
        }
        EXPECT_LE(t.rows.front().exactTriangles, t.fullTriangles);
        EXPECT_GE(distinct.size(), 3u) << "the thresholds span fine to coarse";
    }
}

TEST_F(StatsTest, ErrorJsonHasTheDocumentedKeys) {
    const Result r = run("stats '" + model + "' --error 0.5,5,10m,0.02km --json");
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    ASSERT_TRUE(j.contains("rows"));
    ASSERT_EQ(j["rows"].size(), 4u);
    const double expectedE[] = {0.5, 5, 10, 20};
    for (std::size_t i = 0; i < 4; ++i) {
        const nlohmann::json& row = j["rows"][i];
        std::set<std::string> keys;
        for (auto it = row.begin(); it != row.end(); ++it)
            keys.insert(it.key());
        EXPECT_EQ(keys, (std::set<std::string>{"error_m", "exact_points", "exact_triangles",
                                               "level_points", "level_triangles", "nodes"}));
        EXPECT_DOUBLE_EQ(row["error_m"].get<double>(), expectedE[i]);
        const ExpectedError x = expectedForError(blocks, expectedE[i], false);
        EXPECT_EQ(row["exact_points"].get<std::uint64_t>(), x.exactPoints);
        EXPECT_EQ(row["exact_triangles"].get<std::uint64_t>(), x.exactTriangles);
        EXPECT_EQ(row["level_points"].get<std::uint64_t>(), x.levelPoints);
        EXPECT_EQ(row["level_triangles"].get<std::uint64_t>(), x.levelTriangles);
    }
    EXPECT_EQ(j["metric"], "max");
}

TEST_F(StatsTest, ErrorTextReplacesTheDistanceTable) {
    const Result r = run("stats '" + model + "' --error 5,10,20 --metric paper");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out.find("View distance"), std::string::npos) << r.out;
    for (const char* h : {"error (m)", "exact points", "exact triangles", "level points",
                          "level triangles", "paper metric"})
        EXPECT_NE(r.out.find(h), std::string::npos) << h << "\n" << r.out;
    // Title + header + one line per threshold.
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 2 + 3);
}

TEST_F(StatsTest, BadErrorValuesExitTwo) {
    for (const char* bad : {"--error -5", "--error abc", "--error 5,x", "--error 10furlongs",
                            "--error nan", "--error", "--json", "--error 5 --csv",
                            "--error 5 --distance 10km", "--error 5 --pixels 2"}) {
        const Result r = run("stats '" + model + "' " + bad);
        EXPECT_EQ(r.code, 2) << bad << "\n" << r.err;
        EXPECT_TRUE(r.out.empty()) << bad;
    }
    ErrorStatsTable t;
    std::string error;
    EXPECT_FALSE(computeErrorStats(model, {-1.0}, 0, t, error));
    EXPECT_FALSE(computeErrorStats((dir / "missing.ulod").string(), {5.0}, 0, t, error));
    EXPECT_NE(error.find("missing.ulod"), std::string::npos) << error;
}

TEST(StatsParse, Distances) {
    double m = 0;
    EXPECT_TRUE(parseDistance("100km", m));
    EXPECT_DOUBLE_EQ(m, 100e3);
    EXPECT_TRUE(parseDistance("2.5km", m));
    EXPECT_DOUBLE_EQ(m, 2500);
    EXPECT_TRUE(parseDistance("750m", m));
    EXPECT_DOUBLE_EQ(m, 750);
    EXPECT_TRUE(parseDistance("1500", m));
    EXPECT_DOUBLE_EQ(m, 1500);
    EXPECT_FALSE(parseDistance("", m));
    EXPECT_FALSE(parseDistance("km", m));
    EXPECT_FALSE(parseDistance("10 miles", m));
    EXPECT_FALSE(parseDistance("1e400km", m));
    EXPECT_FALSE(parseDistance("1e308km", m)) << "finite, but not in metres";
    EXPECT_FALSE(parseDistance("0x10", m)) << "hexadecimal";
    EXPECT_FALSE(parseDistance("0x1p3km", m));
    EXPECT_FALSE(parseDistance(" 5km", m));
}

TEST(StatsParse, RowViewIsEquation11AtTheBlockCentre) {
    // The eye is above the data's centre at D over its maximum z; S = the distance to a block's
    // box centre; h_lim = 2·P·S·tan(α/2)/H. A flat block centred below the eye: S = D.
    format::Header h;
    h.minX = 1000, h.maxX = 3000, h.minY = -500, h.maxY = 500, h.minZ = 0, h.maxZ = 200;
    StatsOptions o;
    engine::LodNode below;
    const double lo[3] = {1900, -100, 200}, hi[3] = {2100, 100, 200};
    std::copy(lo, lo + 3, below.boxMin);
    std::copy(hi, hi + 3, below.boxMax);
    const engine::ViewSpec one = statsView(h, o, 100e3, 1);
    double s = 0;
    EXPECT_NEAR(engine::nodeTolerance(one, below, &s), 2e5 * std::tan(M_PI / 6) / 1080, 1e-9);
    EXPECT_NEAR(s, 100e3, 1e-9);
    const engine::ViewSpec three = statsView(h, o, 100e3, 3);
    EXPECT_NEAR(engine::nodeTolerance(three, below), 3 * engine::nodeTolerance(one, below), 1e-9);
    // A block off to the side: S is the 3D distance to its centre, whatever the river flag.
    engine::LodNode side = below;
    side.boxMin[0] = side.boxMax[0] = 2000 + 3000;
    side.horizontal = true;
    EXPECT_NEAR(engine::nodeTolerance(one, side, &s),
                2 * std::hypot(3000.0, 100e3) * std::tan(M_PI / 6) / 1080, 1e-9);
    EXPECT_NEAR(s, std::hypot(3000.0, 100e3), 1e-6);
}

}  // namespace
