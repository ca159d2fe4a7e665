// `unilod report` (tools/report/report.h) on the bundled Jacksboro model: every file is written;
// tables.csv is byte-identical to `unilod stats --csv`; the grid diagrams have the requested
// size, are not blank, draw exactly the cut's nodes at the stored levels it picks at the stats
// viewpoint (counts recomputed here), never fewer points or triangles than tables.md counts (both
// outputs say why), fewer edges far than near, and carry a title band (diagrams whose wireframes
// are equal are named in report.md); --no-annotate changes only the annotation corners; the
// frame-time plot has a line per benchmark run; the curves match the file's error arrays; the
// river comparison has rows for the landform classes present and is exact at a 100 % budget;
// failures leave no folder behind; a terrain-only model's river tables are empty.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "annotate.h"
#include "cut.h"
#include "lod.h"
#include "pngread.h"
#include "report.h"
#include "stats.h"
#include "testutil.h"
#include "tools/cliutil.h"
#include "ulod.h"

using namespace unilod;
namespace fs = std::filesystem;
using unilod::test::q;
using unilod::test::runCli;
using unilod::test::slurp;

namespace {

const std::string kDem = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif";
const std::string kRivers = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson";

std::vector<std::vector<std::string>> readCsv(const std::string& path) {
    std::vector<std::vector<std::string>> rows;
    std::istringstream in(slurp(path));
    std::string line;
    while (std::getline(in, line)) {
        std::vector<std::string> f;
        std::stringstream s(line);
        std::string x;
        while (std::getline(s, x, ','))
            f.push_back(x);
        rows.push_back(f);
    }
    return rows;
}

using unilod::test::Image;
using unilod::test::readPng;

class ReportTest : public ::testing::Test {
protected:
    static inline test::TempDir* dir = nullptr;
    static inline std::string model, out;
    static inline format::Header header;
    static inline std::vector<format::Block> blocks;
    static inline std::vector<format::BlockInfo> infos;
    static inline test::CliResult result;
    static constexpr const char* kDistances = "5km,30km,1000km";

    static void SetUpTestSuite() {
        dir = new test::TempDir("report");
        model = dir->file("j.ulod");
        // Both metrics: the curves of both are checked against the file.
        const auto r = runCli("build -q --paper-metric " + q(kDem) + " " + q(kRivers) + " -o " +
                              q(model));
        ASSERT_EQ(r.code, 0) << r.err;
        test::Model m;
        std::string error;
        ASSERT_TRUE(test::readModel(model, m, error)) << error;
        header = m.header;
        infos = std::move(m.infos);
        blocks = std::move(m.blocks);
        out = dir->file("report");
        result = runCli("report " + q(model) + " -o " + q(out) + " --distance " + kDistances +
                        " --budget 10,100 --image-size 300 --bench-frames 4 --bench-size 160x90"
                        " --validation");
    }
    static void TearDownTestSuite() {
        delete dir;
        dir = nullptr;
    }
};

}  // namespace

TEST_F(ReportTest, WritesEveryFile) {
    ASSERT_EQ(result.code, 0) << result.err;
    for (const char* f : {"report.md", "report.json", "tables.md", "tables.csv", "curves.svg",
                          "curves.csv", "rivers.md", "rivers.csv", "grid.csv", "grid_5km.png",
                          "grid_30km.png", "grid_1000km.png", "frametime.png", "frametime.csv"}) {
        EXPECT_TRUE(fs::is_regular_file(fs::path(out) / f)) << f;
        EXPECT_GT(fs::file_size(fs::path(out) / f), 0u) << f;
        EXPECT_NE(result.out.find(f), std::string::npos) << "the CLI names " << f;
        if (std::string(f) != "report.md") {
            EXPECT_NE(slurp(out + "/report.md").find(f), std::string::npos) << f;
        }
    }
    EXPECT_NE(result.err.find("grid diagram"), std::string::npos);  // progress
    EXPECT_EQ(std::distance(fs::directory_iterator(dir->path), fs::directory_iterator{}), 2)
        << "only the model and the report folder (no temporary folder left)";
}

TEST_F(ReportTest, OverwriteReplacesOnlyTheReportsOwnFiles) {
    ASSERT_EQ(result.code, 0) << result.err;
    // Every file of a whole report (rivers, grids, frame times) is its own: --overwrite may
    // replace it (a file runReport writes under a name isReportFileName lacks would fail here,
    // and an assertion in the sanitizer build).
    const auto own = report::reportForeignPart(out);
    std::size_t entries = 0;
    for (const auto& e : fs::directory_iterator(out)) {
        EXPECT_EQ(own(e), "") << e.path();
        ++entries;
    }
    EXPECT_EQ(entries, 14u);
    for (const char* name : {"grid_5km.png", "grid_0.25km.png", "grid_1e+06km.png", "tables.csv"})
        EXPECT_TRUE(report::isReportFileName(name)) << name;
    for (const char* name : {"grid_km.png", "grid_/../km.png", "notes.txt", "report", "..", ""})
        EXPECT_FALSE(report::isReportFileName(name)) << name;

    // A report.json placed by hand (or edited) does not make other files the report's: until
    // 2026-12-08 a folder whose report.json listed "notes.txt" or "photos" lost them to
    // `report --overwrite`.
    const fs::path folder = fs::path(dir->file("handmade"));
    fs::create_directories(folder / "photos");
    fs::create_directories(folder / "tables.csv");  // a report's name, but a folder
    std::ofstream(folder / "notes.txt") << "mine";
    std::ofstream(folder / "photos" / "a.jpg") << "jpg";
    std::ofstream(folder / "grid.csv") << "a report's file";
    std::ofstream(folder / "report.json")
        << R"({"source": "m.ulod", "files": ["notes.txt", "photos", "tables.csv", "grid.csv"]})";
    std::set<std::string> foreign;
    const auto handmade = report::reportForeignPart(folder.string());
    for (const auto& e : fs::directory_iterator(folder)) {
        const std::string name = handmade(e);
        if (!name.empty()) foreign.insert(name);
    }
    EXPECT_EQ(foreign, (std::set<std::string>{"notes.txt", "photos", "tables.csv"}));
    // Without a report.json of runReport's shape nothing is the report's, report.md included.
    std::ofstream(folder / "report.json") << R"({"files": ["grid.csv"]})";
    std::ofstream(folder / "report.md") << "# mine";
    const auto noReport = report::reportForeignPart(folder.string());
    EXPECT_EQ(noReport(fs::directory_entry(folder / "grid.csv")), "grid.csv");
    EXPECT_EQ(noReport(fs::directory_entry(folder / "report.md")), "report.md");
    // The command: refused, naming the file, nothing removed.
    std::ofstream(folder / "report.json") << R"({"source": "m.ulod", "files": ["notes.txt"]})";
    fs::remove_all(folder / "photos");
    fs::remove_all(folder / "tables.csv");
    const auto r = runCli("report -q " + q(model) + " -o " + q(folder.string()) +
                              " --overwrite --no-rivers --distance 100km --image-size 64 "
                              "--bench-frames 0",
                          "ASAN_OPTIONS=detect_leaks=0");
    EXPECT_EQ(r.code, 1);
    // grid.csv is a report's name, but this report.json does not list it.
    EXPECT_NE(r.err.find("holds 'grid.csv', 'notes.txt', not of a report: refusing to replace "
                         "the folder"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(slurp((folder / "notes.txt").string()), "mine");
    EXPECT_EQ(slurp((folder / "grid.csv").string()), "a report's file");
}

TEST_F(ReportTest, TablesEqualStats) {
    ASSERT_EQ(result.code, 0) << result.err;
    const auto stats = runCli("stats " + q(model) + " --csv --distance " + kDistances);
    ASSERT_EQ(stats.code, 0) << stats.err;
    EXPECT_EQ(slurp(out + "/tables.csv"), stats.out);
    const std::string md = slurp(out + "/tables.md");
    const auto rows = readCsv(out + "/tables.csv");
    ASSERT_EQ(rows.size(), 4u);
    for (std::size_t i = 1; i < rows.size(); ++i)
        EXPECT_NE(md.find("| " + rows[i][5] + " | "), std::string::npos) << rows[i][5];
}

TEST_F(ReportTest, GridDiagrams) {
    ASSERT_EQ(result.code, 0) << result.err;
    const auto rows = readCsv(out + "/grid.csv");
    ASSERT_EQ(rows.size(), 4u);
    ASSERT_EQ(rows[0][3], "nodes");
    const auto tables = readCsv(out + "/tables.csv");
    std::vector<engine::LodNode> nodes;
    for (const format::Block& b : blocks)
        nodes.push_back(engine::lodNode(b));
    std::vector<std::uint64_t> edges;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const double d = std::stod(rows[i][0]);
        SCOPED_TRACE(rows[i][2]);
        EXPECT_EQ(std::stod(rows[i][1]), 1.0);  // P: the first pixel tolerance
        // The stats view, the cut through the hierarchy, the stored level of each drawn node.
        std::vector<engine::NodeChoice> cut;
        engine::selectCut(statsView(header, StatsOptions{}, d, 1.0), nodes, header.defaultMetric,
                          cut);
        std::uint64_t points = 0, triangles = 0, river = 0;
        for (const engine::NodeChoice& c : cut) {
            const format::Level& level = blocks[c.block].levels[c.wanted.level];
            points += level.vertexCount;
            triangles += level.triangleCount;
            river += level.riverCount;
        }
        EXPECT_EQ(std::stoull(rows[i][3]), cut.size());
        EXPECT_EQ(std::stoull(rows[i][4]), points);
        EXPECT_EQ(std::stoull(rows[i][5]), triangles);
        EXPECT_EQ(std::stoull(rows[i][7]), river);
        // The same nodes as tables.csv (its `nodes` column), at stored levels: the largest
        // stored step <= the exact step, so never fewer points or triangles.
        ASSERT_EQ(tables[i][0], rows[i][0]);
        EXPECT_EQ(tables[i][9], rows[i][3]);
        EXPECT_GE(points, std::stoull(tables[i][5]));
        EXPECT_GE(triangles, std::stoull(tables[i][7]));
        edges.push_back(std::stoull(rows[i][6]));
        // Every triangle has 3 edges, shared ones counted once per block.
        EXPECT_GT(edges.back(), triangles);
        EXPECT_LT(edges.back(), 3 * triangles);

        Image img;
        ASSERT_TRUE(readPng(out + "/" + rows[i][2], img));
        EXPECT_EQ(img.width, 300u);
        EXPECT_EQ(img.height, 300u);
        std::size_t grey = 0, blue = 0;
        for (std::size_t p = 0; p < img.rgba.size(); p += 4) {
            const std::uint8_t r = img.rgba[p], g = img.rgba[p + 1], b = img.rgba[p + 2];
            grey += r == g && g == b && r < 200;
            blue += b > 200 && r < 50;
        }
        EXPECT_GT(grey, 1000u);
        EXPECT_GT(blue, 100u);
        EXPECT_NE(slurp(out + "/report.md").find("| " + rows[i][5] + " |"), std::string::npos);
        // The title band: dark text on white in the top rows, nothing of the wireframe there.
        std::size_t dark = 0, blueInBand = 0;
        for (std::uint32_t y = 0; y < 24; ++y) {
            for (std::uint32_t x = 0; x < img.width; ++x) {
                const std::uint8_t* p = &img.rgba[(std::size_t(y) * img.width + x) * 4];
                dark += p[0] < 100 && p[1] < 100 && p[2] < 100;
                blueInBand += p[2] > 200 && p[0] < 50;
            }
        }
        EXPECT_GT(dark, 50u);
        EXPECT_EQ(blueInBand, 0u);
    }
    EXPECT_GT(edges[0], edges[1]);
    EXPECT_GT(edges[1], edges[2]);
    // Both outputs say how their counts differ.
    EXPECT_NE(slurp(out + "/tables.md").find("EXACT deletion step"), std::string::npos);
    EXPECT_NE(slurp(out + "/report.md").find("exact deletion step k*"), std::string::npos);
}

// The titles make every diagram distinct; equal wireframes are named in report.md.
TEST_F(ReportTest, GridTitlesAndEqualDiagrams) {
    ASSERT_EQ(result.code, 0) << result.err;
    const std::string md = slurp(out + "/report.md");
    const char* files[] = {"grid_5km.png", "grid_30km.png", "grid_1000km.png"};
    std::vector<std::string> bytes;
    for (const char* f : files)
        bytes.push_back(slurp(out + "/" + f));
    for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t k = i + 1; k < 3; ++k)
            EXPECT_NE(bytes[i], bytes[k]) << files[i] << " vs " << files[k];
    // Far away every node of the cut is at its coarsest stored level: 3000 km and 10000 km draw
    // the same wireframe and report.md says so; 1000 km draws finer levels. The wireframe (below
    // the title band) is equal exactly when report.md names the pair.
    const std::string other = dir->file("far");
    const auto r = runCli("report -q " + q(model) + " -o " + q(other) +
                          " --no-rivers --bench-frames 0 --distance 1000km,3000km,10000km "
                          "--image-size 200");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto grid = readCsv(other + "/grid.csv");
    ASSERT_EQ(grid.size(), 4u);
    const std::string otherMd = slurp(other + "/report.md");
    const std::size_t band = engine::titleBandHeight(200, 2);
    const char* km[] = {"1000", "3000", "10000"};
    Image images[3];
    for (int i = 0; i < 3; ++i)
        ASSERT_TRUE(readPng(other + "/grid_" + km[i] + "km.png", images[i]));
    for (int i = 0; i < 3; ++i) {
        for (int k = i + 1; k < 3; ++k) {
            SCOPED_TRACE(std::string(km[i]) + " vs " + km[k]);
            const Image& a = images[i];
            const Image& b = images[k];
            const auto split = std::ptrdiff_t(band * a.width * 4);
            EXPECT_FALSE(std::equal(a.rgba.begin(), a.rgba.begin() + split, b.rgba.begin()))
                << "the titles differ";
            const bool sameBelowBand =
                std::equal(a.rgba.begin() + split, a.rgba.end(), b.rgba.begin() + split);
            const bool told = otherMd.find(std::string("D = ") + km[i] + " km and " + km[k] +
                                           " km draw the same nodes") != std::string::npos;
            EXPECT_EQ(sameBelowBand, told) << otherMd;
            EXPECT_EQ(told, i > 0) << otherMd;  // only 3000 km and 10000 km
        }
    }
    EXPECT_EQ(grid[2][4], grid[3][4]);  // the same points drawn
    EXPECT_NE(grid[1][4], grid[2][4]);
}

// --no-annotate: the same diagram without the scale bar and north arrow; they sit in the left
// corners below the title band (scale bar bottom left, north arrow top left).
TEST_F(ReportTest, NoAnnotateChangesOnlyTheCorners) {
    ASSERT_EQ(result.code, 0) << result.err;
    const std::string plain = dir->file("plain");
    const auto r = runCli("report -q " + q(model) + " -o " + q(plain) +
                          " --no-rivers --bench-frames 0 --no-annotate --distance 30km "
                          "--image-size 300");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_FALSE(fs::exists(plain + "/frametime.png"));
    Image annotated, bare;
    ASSERT_TRUE(readPng(out + "/grid_30km.png", annotated));
    ASSERT_TRUE(readPng(plain + "/grid_30km.png", bare));
    ASSERT_EQ(annotated.rgba.size(), bare.rgba.size());
    std::size_t differ = 0, outside = 0, inScaleBar = 0, inArrow = 0;
    for (std::uint32_t y = 0; y < bare.height; ++y) {
        for (std::uint32_t x = 0; x < bare.width; ++x) {
            const std::size_t i = (std::size_t(y) * bare.width + x) * 4;
            if (std::equal(&bare.rgba[i], &bare.rgba[i] + 4, &annotated.rgba[i])) continue;
            ++differ;
            const bool left = x < bare.width / 2;
            inScaleBar += left && y > bare.height * 3 / 4;
            inArrow += left && y < bare.height / 3;
            outside += !(left && (y > bare.height * 3 / 4 || y < bare.height / 3));
        }
    }
    EXPECT_GT(inScaleBar, 100u);
    EXPECT_GT(inArrow, 100u);
    EXPECT_EQ(outside, 0u) << differ;
}

TEST_F(ReportTest, FrameTimePlot) {
    ASSERT_EQ(result.code, 0) << result.err;
    const auto rows = readCsv(out + "/frametime.csv");
    ASSERT_EQ(rows.size(), 5u);  // header + 4 frames
    EXPECT_EQ(rows[0], (std::vector<std::string>{"frame", "lod_frame_ms", "resident_frame_ms",
                                                 "bare_frame_ms", "full_frame_ms"}));
    std::vector<double> sums(5, 0.0);
    for (std::size_t i = 1; i < rows.size(); ++i) {
        ASSERT_EQ(rows[i].size(), 5u);
        for (std::size_t c = 1; c < 5; ++c) {
            EXPECT_GE(std::stod(rows[i][c]), 0.0);
            sums[c] += std::stod(rows[i][c]);
        }
    }
    for (std::size_t c = 1; c < 5; ++c)
        EXPECT_GT(sums[c], 0.0) << rows[0][c];
    const nlohmann::json j = nlohmann::json::parse(slurp(out + "/report.json"));
    ASSERT_TRUE(j.contains("frame_times"));
    EXPECT_EQ(j["frame_times"]["size"], nlohmann::json({160, 90}));
    EXPECT_EQ(j["frame_times"]["runs"]["lod"]["frame_ms"].size(), 4u);
    EXPECT_NE(slurp(out + "/report.md").find("![frame time](frametime.png)"), std::string::npos);
    Image img;
    ASSERT_TRUE(readPng(out + "/frametime.png", img));
    EXPECT_EQ(img.width, 900u);
    EXPECT_EQ(img.height, 480u);
    // A line (and a legend mark) per run, in its colour (frametimes.cpp kRuns).
    const std::uint8_t colours[4][3] = {{204, 38, 38}, {230, 140, 26}, {38, 153, 64},
                                        {31, 77, 204}};
    for (const auto& c : colours) {
        std::size_t n = 0;
        for (std::size_t p = 0; p < img.rgba.size(); p += 4) {
            n += std::abs(img.rgba[p] - c[0]) <= 2 && std::abs(img.rgba[p + 1] - c[1]) <= 2 &&
                 std::abs(img.rgba[p + 2] - c[2]) <= 2;
        }
        EXPECT_GT(n, 40u) << int(c[0]) << "," << int(c[1]) << "," << int(c[2]);
    }
}

TEST_F(ReportTest, CurvesMatchTheFile) {
    ASSERT_EQ(result.code, 0) << result.err;
    const auto rows = readCsv(out + "/curves.csv");
    ASSERT_EQ(rows.size(), 101u);
    ASSERT_EQ(rows[0].size(), 5u);
    for (int r : {1, 37, 50, 100}) {
        SCOPED_TRACE(r);
        const auto& row = rows[std::size_t(r)];
        ASSERT_EQ(std::stod(row[0]), r);
        double maxMax = 0, meanMax = 0, maxPaper = 0, meanPaper = 0;
        for (const format::Block& b : blocks) {
            const std::size_t removable =
                std::size_t(std::floor((1 - r / 100.0) * double(b.vertices.size()) + 1e-9));
            const std::size_t k = std::min(b.steps.size(), removable);
            maxMax = std::max(maxMax, double(b.errorMax[k]));
            meanMax += b.errorMax[k] / double(blocks.size());
            maxPaper = std::max(maxPaper, double(b.errorPaper[k]));
            meanPaper += b.errorPaper[k] / double(blocks.size());
        }
        EXPECT_NEAR(std::stod(row[1]), maxMax, 1e-6 * (1 + maxMax));
        EXPECT_NEAR(std::stod(row[2]), meanMax, 1e-6 * (1 + meanMax));
        EXPECT_NEAR(std::stod(row[3]), maxPaper, 1e-6 * (1 + maxPaper));
        EXPECT_NEAR(std::stod(row[4]), meanPaper, 1e-6 * (1 + meanPaper));
    }
    for (std::size_t i = 2; i < rows.size(); ++i)  // less error with more points kept
        EXPECT_LE(std::stod(rows[i][1]), std::stod(rows[i - 1][1]));
    EXPECT_GT(std::stod(rows[1][1]), std::stod(rows[100][1]));
    const std::string svg = slurp(out + "/curves.svg");
    std::size_t polylines = 0;
    for (std::size_t at = svg.find("<polyline"); at != std::string::npos;
         at = svg.find("<polyline", at + 1))
        ++polylines;
    EXPECT_EQ(polylines, 4u);
    EXPECT_NE(svg.find("Retention"), std::string::npos);
}

// The curve's blocks are read on threads: the same curve, bit for bit, for any number, and every
// block counted once.
TEST_F(ReportTest, CurveTheSameOnAnyNumberOfThreads) {
    std::vector<report::CurvePoint> one, many;
    bool hasMax = false, hasPaper = false;
    std::string error;
    ASSERT_TRUE(report::computeCurve(model, one, hasMax, hasPaper, error, {1, {}})) << error;
    for (std::size_t threads : {2u, 3u, 0u}) {
        std::vector<std::size_t> counts;
        StatsReading reading{threads, [&](std::size_t done, std::size_t total) {
                                 EXPECT_EQ(total, infos.size());
                                 counts.push_back(done);
                             }};
        ASSERT_TRUE(report::computeCurve(model, many, hasMax, hasPaper, error, reading)) << error;
        ASSERT_EQ(many.size(), one.size());
        for (std::size_t i = 0; i < one.size(); ++i) {
            EXPECT_EQ(many[i].maxOfMax, one[i].maxOfMax) << i;
            EXPECT_EQ(many[i].meanOfMax, one[i].meanOfMax) << i;
            EXPECT_EQ(many[i].maxOfPaper, one[i].maxOfPaper) << i;
            EXPECT_EQ(many[i].meanOfPaper, one[i].meanOfPaper) << i;
        }
        ASSERT_EQ(counts.size(), infos.size() + 1);  // 0, then one per block
        for (std::size_t i = 0; i < counts.size(); ++i)
            EXPECT_EQ(counts[i], i);
    }
}

TEST_F(ReportTest, RiverComparison) {
    ASSERT_EQ(result.code, 0) << result.err;
    const auto rows = readCsv(out + "/rivers.csv");
    ASSERT_EQ(rows.size(), 1u + 3 * 2);  // 3 classes x 2 budgets
    std::uint64_t rivers10 = 0, rivers100 = 0;
    std::set<std::string> classes;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const auto& r = rows[i];
        const std::uint64_t n = std::stoull(r[4]), original = std::stoull(r[5]),
                            kept = std::stoull(r[6]);
        if (n > 0) classes.insert(r[0]);
        const double meanBai = std::stod(r[7]), meanPlain = std::stod(r[8]);
        const double maxBai = std::stod(r[9]), maxPlain = std::stod(r[10]);
        if (r[3] == "100") {
            rivers100 += n;
            EXPECT_EQ(kept, original);  // everything kept: the original polyline
            EXPECT_EQ(maxBai, 0.0);
            EXPECT_EQ(maxPlain, 0.0);
        } else {
            ASSERT_EQ(r[3], "10");
            rivers10 += n;
            EXPECT_LE(kept, original);
            if (n > 0) {
                EXPECT_LT(kept, original);
                EXPECT_GT(maxBai, 0.0);
                EXPECT_GT(maxPlain, 0.0);
                EXPECT_LE(meanBai, maxBai);
                EXPECT_LE(meanPlain, maxPlain);
            }
        }
    }
    EXPECT_EQ(rivers10, rivers100);
    EXPECT_GT(rivers10, 100u);  // the bundled network has 142 lines, cut at block borders
    // Jacksboro: rivers in the 0-500 m and 500-1000 m classes (z 245..1072 m).
    EXPECT_TRUE(classes.count("0"));
    EXPECT_TRUE(classes.count("1"));
    const std::string md = slurp(out + "/rivers.md");
    EXPECT_NE(md.find("| 0-500 m | 10 |"), std::string::npos);
    EXPECT_NE(md.find("| 500-1000 m | 10 |"), std::string::npos);
}

// The comparison ranks the build's own blocks (so its memory and time are a block's, not the
// whole DEM's): smaller blocks cut the rivers into more pieces, each counted once per budget;
// the rows do not depend on the number of threads.
TEST_F(ReportTest, RiverComparisonRanksTheBuildsBlocks) {
    ASSERT_EQ(result.code, 0) << result.err;
    const std::string small = dir->file("j64.ulod");
    auto r = runCli("build -q --block-size 64 " + q(kDem) + " " + q(kRivers) + " -o " + q(small));
    ASSERT_EQ(r.code, 0) << r.err;
    const auto pieces = [](const std::string& csv) {
        std::uint64_t n = 0;
        for (const auto& row : readCsv(csv)) {
            if (row.size() > 4 && row[3] == "100") n += std::stoull(row[4]);
        }
        return n;
    };
    std::string csv[2];
    for (int threads : {1, 2}) {
        const std::string folder = dir->file("rivers64_" + std::to_string(threads));
        r = runCli("report -q " + q(small) + " -o " + q(folder) +
                   " --budget 10,100 --distance 30km --image-size 64 --bench-frames 0 --threads " +
                   std::to_string(threads));
        ASSERT_EQ(r.code, 0) << r.err;
        csv[threads - 1] = folder + "/rivers.csv";
    }
    EXPECT_EQ(slurp(csv[0]), slurp(csv[1]));
    // 142 lines; the default 256-cell blocks (2 x 2 here) cut a few of them, 64-cell blocks
    // (7 x 7) many more.
    const std::uint64_t big = pieces(out + "/rivers.csv"), many = pieces(csv[0]);
    EXPECT_GE(big, 142u);
    EXPECT_GT(many, big + 40) << big;

    // The model's blocks must fit the exact grid on the DEM given: 64 cells of 20 km do not.
    std::string asc = "ncols 100\nnrows 100\nxllcorner 0\nyllcorner 0\ncellsize 20000\n";
    for (int j = 0; j < 100; ++j) {
        for (int i = 0; i < 100; ++i)
            asc += std::to_string((i * 7 + j * 13) % 97) + (i + 1 < 100 ? " " : "\n");
    }
    const std::string coarse = dir->file("coarse.asc"), line = dir->file("line.geojson");
    dir->write("coarse.asc", asc);
    dir->write("line.geojson",
               R"({"type":"FeatureCollection","features":[{"type":"Feature","properties":{},)"
               R"("geometry":{"type":"LineString","coordinates":[[1e4,1e4],[9e5,7e5]]}}]})");
    const std::string folder = dir->file("coarse_report");
    r = runCli("report -q " + q(small) + " -o " + q(folder) + " --dem " + q(coarse) + " --rivers " +
               q(line) + " --bench-frames 0");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("the model's block size does not fit it"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(folder));
}

TEST_F(ReportTest, FailuresLeaveNothing) {
    ASSERT_EQ(result.code, 0) << result.err;
    // An existing non-empty folder is refused and left as it is.
    const std::string before = slurp(out + "/tables.csv");
    auto r = runCli("report -q " + q(model) + " -o " + q(out) + " --no-rivers");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("not an empty folder"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(out + "/tables.csv"), before);

    const std::string other = dir->file("other");
    struct Case {
        std::string args;
        int code;
    };
    const Case cases[] = {
        {"report -q " + q(model) + " -o " + q(other) + " --dem " + q(dir->file("no.tif")), 1},
        {"report -q " + q(model) + " -o " + q(other) + " --rivers " + q(dir->file("no.json")), 1},
        {"report -q " + q(dir->file("missing.ulod")) + " -o " + q(other), 1},
        {"report -q " + q(model) + " -o " + q(other) + " --distance 500m,0.5km", 1},
        {"report -q " + q(model) + " -o " + q(other) + " --budget 150", 2},
        {"report -q " + q(model) + " -o " + q(other) + " --distance 0km", 2},
        {"report -q " + q(model) + " -o " + q(other) + " --image-size 0", 2},
        {"report -q " + q(model), 2},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.args);
        r = runCli(c.args);
        EXPECT_EQ(r.code, c.code) << r.err;
        EXPECT_FALSE(r.err.empty());
        EXPECT_FALSE(fs::exists(other));
    }
    for (const auto& e : fs::directory_iterator(dir->path))
        EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();

    // The hint says where the failing input came from (a path given with --dem used to be called
    // one "named by the build info").
    const std::string noDem = dir->file("no.tif"), noRivers = dir->file("no.json");
    r = runCli("report -q " + q(model) + " -o " + q(other) + " --dem " + q(noDem));
    EXPECT_NE(r.err.find(noDem), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(the DEM given by --dem; the rivers named by the build info of"),
              std::string::npos)
        << r.err;
    r = runCli("report -q " + q(model) + " -o " + q(other) + " --dem " + q(noDem) + " --rivers " +
               q(noRivers));
    EXPECT_NE(r.err.find("(the inputs given by --dem and --rivers)"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("build info"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(other));

    // Without the river comparison no DEM or rivers are needed and no rivers.* is written.
    r = runCli("report -q " + q(model) + " -o " + q(other) + " --no-rivers --dem " +
               q(dir->file("no.tif")) + " --distance 50km --image-size 64 --bench-frames 0");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(other + "/tables.csv"));
    EXPECT_TRUE(fs::exists(other + "/grid_50km.png"));
    EXPECT_FALSE(fs::exists(other + "/rivers.csv"));
    EXPECT_EQ(runCli("report --help").code, 0);
}

// A terrain-only model (`build DEM` without RIVERS) has no rivers to compare: the report is
// written, its river tables empty and saying so.
TEST(ReportTerrainOnly, NoRiversToCompare) {
    test::TempDir dir("report_terrain");
    const std::string model = dir.file("t.ulod"), out = dir.file("report");
    auto r = runCli("build -q " + q(kDem) + " -o " + q(model) + " --stride 4");
    ASSERT_EQ(r.code, 0) << r.err;
    r = runCli("report -q " + q(model) + " -o " + q(out) +
               " --distance 30km --budget 10 --image-size 64 --bench-frames 0");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(readCsv(out + "/rivers.csv").size(), 1u);  // the header alone
    EXPECT_NE(slurp(out + "/rivers.md").find("(no river with points to simplify)"),
              std::string::npos);
}
