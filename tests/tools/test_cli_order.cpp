// End-to-end runs of the `unilod` command (STYLE.md "The CLI runs end-to-end on a fixture"):
// `order` on the bundled data (CSV in deletion order, JSON summary), error exits that name the file
// and leave no output, usage errors, --help everywhere, and `synth` writing readable files.
#include <gtest/gtest.h>

#include "testutil.h"

#include "tools/cliutil.h"
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include <ogr_spatialref.h>

#include "dem.h"
#include "ingest.h"
#include "pointset.h"
#include "rivers.h"

using namespace unilod;
namespace fs = std::filesystem;

namespace {

using unilod::test::q;
using unilod::test::slurp;
using Result = unilod::test::CliResult;
Result run(const std::string& args) { return unilod::test::runCli(args); }

const std::string kAssets = UNILOD_ASSETS_DIR;
const std::string kDem = kAssets + "/jacksboro_dem.tif";
const std::string kRivers = kAssets + "/jacksboro_rivers_grass.geojson";

using unilod::test::TempDir;

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> fields;
    std::stringstream s(line);
    std::string f;
    while (std::getline(s, f, ','))
        fields.push_back(f);
    return fields;
}

}  // namespace

TEST(CliOrder, WritesTheDeletionOrder) {
    TempDir dir("order");
    const std::string csv = dir.file("order.csv");
    const Result r = run("order " + q(kDem) + " " + q(kRivers) + " --out " + q(csv) + " --json");
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json s = nlohmann::json::parse(r.out);
    const std::size_t demPoints = s["points"]["dem"], riverPoints = s["points"]["river"];
    const std::size_t locked = s["points"]["locked"];
    EXPECT_EQ(s["points"]["polylines"].get<std::size_t>(), 142u);
    EXPECT_GT(s["chainLength"].get<std::size_t>(), 0u);
    EXPECT_FALSE(s["basePlane"]["O"].is_null());
    EXPECT_GT(s["bends"]["count"].get<std::size_t>(), 0u);
    EXPECT_EQ(s["bends"]["top"].size(), 5u);
    for (const char* k : {"min", "median", "p90", "max"}) {
        EXPECT_TRUE(s["importance"]["dem"].contains(k));
        EXPECT_TRUE(s["importance"]["river"].contains(k));
    }

    // The same counts from the library: the point set `build --order 3ddp` makes of one block
    // covering the DEM (ingest.h).
    IngestOptions opts;
    opts.demPath = kDem;
    opts.riversPath = kRivers;
    Ingested data;
    BlockSource source;
    std::string error;
    ASSERT_TRUE(ingest(opts, data, error)) << error;
    ASSERT_TRUE(splitIntoBlocks(data, opts, kWholeDem, true, source, error)) << error;
    const PointSet set = source.points(0);
    std::size_t libRiver = 0, libLocked = 0, libDem = 0, libLockedRiver = 0;
    for (const Point& p : set.points) {
        (p.kind == PointKind::River ? libRiver : libDem) += 1;
        libLocked += p.locked;
        libLockedRiver += p.locked && p.kind == PointKind::River;
    }
    EXPECT_EQ(riverPoints, libRiver);
    EXPECT_EQ(locked, libLocked);
    EXPECT_EQ(demPoints, libDem);
    EXPECT_EQ(s["points"]["demDroppedNearRivers"].get<std::size_t>(),
              source.stats().droppedDemPoints);

    // CSV: one row per unlocked point, ranks 0.., importance ascending.
    std::ifstream in(csv);
    std::string line;
    ASSERT_TRUE(std::getline(in, line));
    EXPECT_EQ(line, "rank,id,x,y,z,kind,locked,importance,own_importance,bai_factor");
    std::size_t rows = 0, riverRows = 0;
    double previous = -1;
    std::set<unsigned long> ids;
    while (std::getline(in, line)) {
        const auto f = split(line);
        ASSERT_EQ(f.size(), 10u) << line;
        EXPECT_EQ(std::stoul(f[0]), rows);
        ids.insert(std::stoul(f[1]));
        EXPECT_EQ(f[6], "0");
        riverRows += f[5] == "river";
        const double importance = std::strtod(f[7].c_str(), nullptr);
        EXPECT_GE(importance, previous) << "rank " << rows;
        EXPECT_LE(importance, std::strtod(f[8].c_str(), nullptr) + 1e-9) << "rank " << rows;
        previous = importance;
        ++rows;
    }
    EXPECT_EQ(rows, demPoints + riverPoints - locked);
    EXPECT_EQ(ids.size(), rows);
    EXPECT_EQ(riverRows, riverPoints - libLockedRiver);  // the DEM's outer edge is locked too
    EXPECT_TRUE(std::isinf(previous));  // O, A, B last
    EXPECT_EQ(dir.entries(), 1u);       // no temporary file left
}

TEST(CliOrder, TextSummaryAndPlain3dDp) {
    TempDir dir("plain");
    const std::string csv = dir.file("plain.csv");
    const Result r =
        run("order " + q(kDem) + " " + q(kRivers) + " --no-bai --stride 2 --out " + q(csv));
    ASSERT_EQ(r.code, 0) << r.err;
    for (const char* text : {"DEM points", "river points", "locked points", "chain length",
                             "importance dem", "importance river", "bends", "total"}) {
        EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
    }
    for (const char* stage : {"ingest", "point set", "importance"}) {
        EXPECT_NE(r.err.find(stage), std::string::npos) << stage << "\n" << r.err;
    }
    std::ifstream in(csv);
    std::string line;
    std::getline(in, line);
    std::size_t rows = 0;
    while (std::getline(in, line)) {
        EXPECT_EQ(split(line)[9], "1") << line;  // no BAI: factor 1 everywhere
        ++rows;
    }
    EXPECT_GT(rows, 30000u);  // stride 2: about a quarter of the ~140k DEM points
    EXPECT_LT(rows, 45000u);
}

TEST(CliOrder, DataErrorsNameTheFileAndLeaveNoOutput) {
    TempDir dir("errors");
    const std::string csv = dir.file("order.csv");
    const std::string missing = dir.file("no_such_dem.tif");
    Result r = run("order " + q(missing) + " " + q(kRivers) + " --out " + q(csv));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(csv));
    EXPECT_EQ(dir.entries(), 0u);

    const std::string missingRivers = dir.file("no_such_rivers.geojson");
    r = run("order " + q(kDem) + " " + q(missingRivers) + " --out " + q(csv));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(missingRivers), std::string::npos) << r.err;
    EXPECT_EQ(dir.entries(), 0u);

    // Rivers given as the DEM and the other way round.
    r = run("order " + q(kRivers) + " " + q(kDem) + " --out " + q(csv));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(kRivers), std::string::npos) << r.err;
    EXPECT_EQ(dir.entries(), 0u);

    const std::string badDir = dir.file("no_dir") + "/order.csv";
    r = run("order " + q(kDem) + " " + q(kRivers) + " --out " + q(badDir));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(badDir), std::string::npos) << r.err;

    const std::string table = dir.file("no_table.txt");
    r = run("order " + q(kDem) + " " + q(kRivers) + " --bai-table " + q(table) + " --out " +
            q(csv));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(table), std::string::npos) << r.err;
    EXPECT_EQ(dir.entries(), 0u);
}

TEST(CliOrder, UsageErrorsExitWith2) {
    for (const std::string& args : std::vector<std::string>{
             "", "order", "order " + q(kDem) + " " + q(kRivers) + " --stride 0",
             "order " + q(kDem) + " " + q(kRivers) + " --band 0",
             "order " + q(kDem) + " " + q(kRivers) + " --bai-row 123",
             "order " + q(kDem) + " " + q(kRivers) + " --no-such-option", "synth",
             "synth --points 10 -o /tmp/x", "frobnicate"}) {
        const Result r = run(args);
        EXPECT_EQ(r.code, 2) << args << "\n" << r.err;
        EXPECT_FALSE(r.err.empty()) << args;
    }
}

// `-o -` is stdout where a command's output is text (order's CSV; bench's JSON): the CSV the same
// bytes as a file's, the summary then on stderr. Elsewhere it is refused as a usage error rather
// than written as a file named "-".
TEST(CliOrder, DashOutputIsStdoutForOrderAndRefusedElsewhere) {
    TempDir dir("dash");
    const std::string csv = dir.file("order.csv");
    const std::string args = "order " + q(kDem) + " " + q(kRivers) + " --stride 2";
    const std::string inDir = "cd " + q(dir.path.string()) + " &&";
    ASSERT_EQ(run(args + " -q -o " + q(csv)).code, 0);
    Result r = unilod::test::runCli(args + " -q -o -", inDir);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out, slurp(csv));
    EXPECT_EQ(r.err.find("summary"), std::string::npos) << r.err;  // -q: none
    r = unilod::test::runCli(args + " -o -", inDir);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out, slurp(csv));
    EXPECT_NE(r.err.find("unilod order summary"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("stdout ("), std::string::npos) << r.err;
    r = unilod::test::runCli(args + " -o - --json", inDir);
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("both write to stdout"), std::string::npos) << r.err;
    for (const std::string& refused :
         std::vector<std::string>{"build " + q(kDem) + " -o -", "build " + q(kDem) + " --out -",
                                  "synth --points 1000 -o -", "export " + q(csv) + " -o -",
                                  "export " + q(csv) + " --3dtiles -",
                                  "view " + q(csv) + " --frames 1 --screenshot -"}) {
        r = unilod::test::runCli(refused, inDir);
        EXPECT_EQ(r.code, 2) << refused << "\n" << r.err;
        EXPECT_NE(r.err.find("'-' is not stdout here"), std::string::npos) << refused << r.err;
    }
    EXPECT_EQ(dir.entries(), 1u);  // order.csv alone: no file named "-"
}

TEST(CliOrder, HelpForEveryCommand) {
    for (const std::string args : {"--help", "order --help", "synth --help"}) {
        const Result r = run(args);
        EXPECT_EQ(r.code, 0) << args;
        EXPECT_NE(r.out.find("Usage"), std::string::npos) << args << "\n" << r.out;
        EXPECT_NE(r.out.find("--help"), std::string::npos) << args;
    }
    EXPECT_NE(run("order --help").out.find("--bai-row"), std::string::npos);
    EXPECT_NE(run("synth --help").out.find("--points"), std::string::npos);
    const Result v = run("--version");
    EXPECT_EQ(v.code, 0);
    EXPECT_NE(v.out.find("unilod"), std::string::npos) << v.out;
}

TEST(CliSynth, WritesReadableFiles) {
    TempDir dir("synth");
    const std::string out = dir.file("data");
    const Result r = run("synth --points 5000 --seed 4 -o " + q(out));
    ASSERT_EQ(r.code, 0) << r.err;
    DemGrid dem;
    RiverLines lines;
    std::string error;
    ASSERT_TRUE(loadDem(out + "/dem.tif", {}, dem, error)) << error;
    ASSERT_TRUE(loadRivers(out + "/rivers.geojson", {}, dem.wkt, lines, error)) << error;
    OGRSpatialReference srs;
    ASSERT_EQ(srs.importFromWkt(dem.wkt.c_str()), OGRERR_NONE);
    EXPECT_STREQ(srs.GetAuthorityCode(nullptr), "32616");
    EXPECT_EQ(dem.cellX, 30.0);
    EXPECT_GT(lines.size(), 2u);
    EXPECT_EQ(fs::path(out).filename(), "data");
    EXPECT_EQ(static_cast<std::size_t>(std::distance(fs::directory_iterator(out), {})), 2u);

    // Junctions survive the file round trip as exactly shared vertices.
    const PointSet set = buildPointSet(dem, lines, {});
    std::size_t riverPoints = 0, entries = 0;
    for (const Point& p : set.points)
        riverPoints += p.kind == PointKind::River;
    for (const Polyline& l : set.rivers)
        entries += l.size();
    EXPECT_EQ(set.rivers.size(), lines.size());
    EXPECT_LT(riverPoints, entries);  // tributary ends are main river vertices
    const std::size_t points = set.points.size();
    EXPECT_GT(points, 4500u);
    EXPECT_LT(points, 5500u);

    // Same seed, same files.
    const std::string again = dir.file("again");
    ASSERT_EQ(run("synth --points 5000 --seed 4 -o " + q(again)).code, 0);
    EXPECT_EQ(slurp(out + "/rivers.geojson"), slurp(again + "/rivers.geojson"));
    DemGrid dem2;
    ASSERT_TRUE(loadDem(again + "/dem.tif", {}, dem2, error)) << error;
    EXPECT_EQ(dem.z, dem2.z);

    // And `order` runs on them.
    const Result o =
        run("order " + q(out + "/dem.tif") + " " + q(out + "/rivers.geojson") + " --json");
    EXPECT_EQ(o.code, 0) << o.err;
}

TEST(CliOrder, BaiTableFromAFile) {
    TempDir dir("table");
    const std::string table = dir.file("table.txt");
    std::ofstream(table) << "# test table\naltitudes 0 500 1000\n250 3 3 3\n";
    const Result r = run("order " + q(kDem) + " " + q(kRivers) + " --stride 4 --bai-table " +
                         q(table) + " --bai-row 250 --json");
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json s = nlohmann::json::parse(r.out);
    ASSERT_FALSE(s["bends"]["top"].empty());
    for (const auto& b : s["bends"]["top"])
        EXPECT_EQ(b["c"].get<double>(), 3.0);
    EXPECT_EQ(s["bai"]["table"].get<std::string>(), table);

    // A row the file does not have: a data error naming the file (the default table's rows are
    // checked while parsing instead, see UsageErrorsExitWith2).
    const Result bad =
        run("order " + q(kDem) + " " + q(kRivers) + " --bai-table " + q(table) + " --bai-row 500");
    EXPECT_EQ(bad.code, 1);
    EXPECT_NE(bad.err.find(table), std::string::npos) << bad.err;
}

TEST(CliSynth, UnwritableOutputIsADataError) {
    TempDir dir("synth_bad");
    const std::string file = dir.file("a_file");
    std::ofstream(file) << "x";
    const std::string out = file + "/data";  // a directory below a regular file
    const Result r = run("synth --points 2000 -o " + q(out));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(out), std::string::npos) << r.err;
    EXPECT_EQ(dir.entries(), 1u);
}
