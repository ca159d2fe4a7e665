// Hostile input that is not a damaged file (issue 16): text that is not UTF-8 where JSON is
// written (a DEM path with the byte 0xFF, a CRS WKT with it), option values that are not finite
// numbers or outside their range, a --gpu-budget larger than the device can allocate, and a
// camera path whose number overflows. Every case: no abort, a message naming the option or the
// file, exit code != 0 where the input is refused, no output file; valid JSON where it is accepted.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include <gdal_priv.h>

#include "synthetic.h"
#include "tools/cliutil.h"
#include "ulod.h"

namespace fs = std::filesystem;
using namespace unilod;

namespace {

using unilod::test::q;
using unilod::test::runCli;
using unilod::test::slurp;

const std::string kAssets = UNILOD_ASSETS_DIR;
const std::string kBad = "\xff";  // never valid in UTF-8

// A JSON document parsed with exceptions on: a parse error or invalid UTF-8 fails the test.
nlohmann::json parseStrict(const std::string& text) {
    try {
        return nlohmann::json::parse(text);
    } catch (const std::exception& e) {
        ADD_FAILURE() << "not valid JSON: " << e.what() << "\n" << text.substr(0, 400);
        return {};
    }
}

// The JSON chunk of a GLB (glTF 2.0 binary: 12-byte header, then chunk length + type "JSON").
std::string glbJson(const std::string& glb) {
    if (glb.size() < 20 || glb.compare(0, 4, "glTF") != 0) return {};
    std::uint32_t length = 0;
    std::memcpy(&length, glb.data() + 12, 4);
    if (glb.compare(16, 4, "JSON") != 0 || 20 + std::size_t(length) > glb.size()) return {};
    return glb.substr(20, length);
}

bool aborted(const test::CliResult& r) { return r.code < 0 || r.code >= 128; }

class Inputs : public ::testing::Test {
protected:
    static inline fs::path dir;
    static inline std::string dem, rivers, model;
    static void SetUpTestSuite() {
        dir = fs::temp_directory_path() / ("unilod_test_inputs_" + std::to_string(getpid()));
        fs::remove_all(dir);
        fs::create_directories(dir);
        SyntheticOptions so;
        so.targetPoints = 6000;
        so.seed = 5;
        const SyntheticData data = generateSyntheticData(so);
        std::string error;
        ASSERT_TRUE(writeSyntheticData(data, (dir / "synth").string(), error)) << error;
        // Input paths that are not UTF-8 (valid on Linux).
        dem = (dir / ("dem_" + kBad + ".tif")).string();
        rivers = (dir / ("rivers_" + kBad + ".geojson")).string();
        fs::copy_file(dir / "synth" / "dem.tif", dem);
        fs::copy_file(dir / "synth" / "rivers.geojson", rivers);
        model = (dir / ("model_" + kBad + ".ulod")).string();
        const auto r = runCli("build " + q(dem) + " " + q(rivers) + " -o " + q(model) +
                                " --block-size 32 -q");
        ASSERT_EQ(r.code, 0) << r.err;
    }
    static void TearDownTestSuite() {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
};

TEST_F(Inputs, PathsThatAreNotUtf8BuildAndReportValidJson) {
    // The build info records the paths; it must be valid JSON (U+FFFD for the bad byte).
    format::Reader reader;
    std::string error;
    ASSERT_TRUE(reader.open(model, error)) << error;
    const nlohmann::json info = parseStrict(reader.header().buildInfo);
    ASSERT_TRUE(info.is_object());
    EXPECT_NE(info.value("dem", std::string()).find("\xEF\xBF\xBD"), std::string::npos)
        << "the 0xFF byte is shown as U+FFFD";

    const auto r = runCli("info --json " + q(model));
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json j = parseStrict(r.out);
    EXPECT_EQ(j.value("vertices", 0u) > 0, true);

    const std::string glb = (dir / ("out_" + kBad + ".glb")).string();
    const auto e = runCli("export " + q(model) + " --h-lim 5 -o " + q(glb));
    ASSERT_EQ(e.code, 0) << e.err;
    const nlohmann::json g = parseStrict(glbJson(slurp(glb)));
    EXPECT_TRUE(g.contains("asset"));
}

TEST_F(Inputs, CrsTextThatIsNotUtf8IsSanitisedInEveryJsonOutput) {
    // A file written by another tool (or edited) may carry any bytes in its CRS WKT and build
    // info; the format does not forbid them, the JSON writers must cope.
    test::Model m;
    std::string error;
    ASSERT_TRUE(test::readModel(model, m, error)) << error;
    m.header.crsWkt = "LOCAL_CS[\"caf" + kBad + "\"]";
    m.header.buildInfo = "{\"dem\": \"" + kBad + "\"";  // neither UTF-8 nor complete JSON
    const std::string odd = (dir / "odd.ulod").string();
    ASSERT_TRUE(format::writeUlod(odd, m.header, m.blocks, error)) << error;

    const auto r = runCli("info --json " + q(odd));
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json j = parseStrict(r.out);
    EXPECT_EQ(j.value("crs_wkt", std::string()), "LOCAL_CS[\"caf\xEF\xBF\xBD\"]");
    EXPECT_TRUE(j["build"].is_string()) << "unparsable build info is shown as text";

    const std::string glb = (dir / "odd.glb").string();
    const auto e = runCli("export " + q(odd) + " --h-lim 5 -o " + q(glb));
    ASSERT_EQ(e.code, 0) << e.err;
    const nlohmann::json g = parseStrict(glbJson(slurp(glb)));
    EXPECT_EQ(g["asset"]["extras"].value("crs_wkt", std::string()),
              "LOCAL_CS[\"caf\xEF\xBF\xBD\"]");
}

TEST_F(Inputs, OptionValuesOutsideTheirRangeAreUsageErrorsWithShortMessages) {
    const std::string out = (dir / "refused").string();
    struct Case {
        std::string command, option, value;
    };
    const std::string path = kAssets + "/jacksboro_path.json";
    const std::string buildArgs = "build " + q(dem) + " " + q(rivers) + " -o " + q(out);
    const std::string captureArgs = "capture " + q(model) + " --path " + q(path) + " --out " + q(out);
    const std::vector<Case> cases = {
        {buildArgs, "--min-river-length", "nan"},
        {buildArgs, "--min-river-length", "-1"},
        {buildArgs, "--bai-row", "inf"},
        {buildArgs, "--bai-row", "-1"},  // a table's thresholds are >= 0 (exit 1 before)
        {buildArgs, "--band", "-1"},
        {buildArgs, "--memory-limit", "nan"},
        {buildArgs, "--memory-limit", "inf"},
        {buildArgs, "--memory-limit", "1e999"},
        {buildArgs, "--memory-limit", " 5"},
        {buildArgs, "--memory-limit", "0x10"},
        {buildArgs, "--handoff-pixels", "nan"},
        {buildArgs, "--handoff-pixels", "inf"},
        {buildArgs, "--handoff-pixels", "1e999"},
        {captureArgs, "--pixels", "-1"},
        {captureArgs, "--pixels", "nan"},
        {captureArgs, "--pixels", "1e999"},
        {captureArgs, "--fov", "nan"},
        {captureArgs, "--fov", "180"},
        {captureArgs, "--gpu-budget", "nan"},
        {captureArgs, "--gpu-budget", "-5"},
        {captureArgs, "--gpu-budget", "99999999"},
        {"export " + q(model) + " -o " + q(out) + ".glb", "--h-lim", "nan"},
        {"stats " + q(model), "--pixels", "0"},
        {"stats " + q(model), "--fov", "inf"},
        {"stats " + q(model), "--height", "nan"},
        {"bench " + q(model) + " -o " + q(out), "--pace-ms", "nan"},
        {"bench " + q(model) + " -o " + q(out), "--pace-ms", "-1"},
        {"bench " + q(model) + " -o " + q(out), "--warmup-ms", "nan"},
        {"bench " + q(model) + " -o " + q(out), "--warmup-ms", "-1"},
        {"bench " + q(model) + " -o " + q(out), "--warmup", "100001"},
        {"bench " + q(model) + " -o " + q(out), "--rounds", "0"},
        {"bench " + q(model) + " -o " + q(out), "--rounds", "101"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.option + " " + c.value);
        const auto r = runCli(c.command + " " + c.option + " " + q(c.value));
        EXPECT_FALSE(aborted(r)) << r.err;
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find(c.option + ": "), std::string::npos) << r.err;
        EXPECT_LT(r.err.size(), 300u) << "no 309-digit bounds: " << r.err;
        EXPECT_FALSE(fs::exists(out)) << "no output on a refused option";
        EXPECT_FALSE(fs::exists(out + ".glb"));
    }
}

// Values the shared number parsing (engine/format/numtext.h, tools/cli/numbers.h) used to let
// through or to leave to a later check: hexadecimal numbers, lengths that overflow once in
// metres (1e308km: exit 1 without the option's name), empty items of a list (silently dropped),
// a view distance so large that h_lim was printed as inf. Each is a usage error naming the option.
TEST_F(Inputs, HexOverflowAndEmptyListItemsAreUsageErrors) {
    const std::string out = (dir / "refused_lists").string();
    struct Case {
        std::string command, option, value, shown = "";  // shown: the value the message quotes
    };
    const std::string stats = "stats " + q(model);
    const std::string report = "report " + q(model) + " --no-rivers --bench-frames 0 -o " + q(out);
    const std::vector<Case> cases = {
        {stats, "--distance", "1e308km"},
        {stats, "--distance", "1e300"},
        {stats, "--distance", "1,,2"},
        {stats, "--distance", "1.5km,"},
        {stats, "--distance", ",1km"},
        {stats, "--distance", "0x10"},
        {stats, "--pixels", "1,2,"},
        {stats, "--pixels", "0x10"},
        {stats, "--error", "1e308km"},
        {stats, "--error", "0x1p3"},
        {stats, "--error", "5,,10"},
        {report, "--distance", "1,,2"},
        {report, "--pixels", "1,"},
        {report, "--budget", "5,,10"},
        {"export " + q(model) + " -o " + q(out + ".glb"), "--h-lim", "0x10"},
        {"export " + q(model) + " -o " + q(out + ".glb"), "--camera", "0x10,0,0", "0x10"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.command + " " + c.option + " " + c.value);
        const auto r = runCli(c.command + " " + c.option + " " + q(c.value));
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find(c.option + ": "), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("'" + (c.shown.empty() ? c.value : c.shown) + "'"), std::string::npos)
            << r.err;
        EXPECT_TRUE(r.out.empty()) << r.out;
        EXPECT_FALSE(fs::exists(out));
        EXPECT_FALSE(fs::exists(out + ".glb"));
    }
    // The largest view distance is accepted and its h_lim is finite.
    const auto r = runCli(stats + " --distance 1e9 --csv");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out.find("inf"), std::string::npos) << r.out;
}

// Integer options (tools/cli/numbers.h integerIn) take decimal digits only: CLI11's conversion
// read "010" as octal (--block-size 010 built 8-cell blocks) and "0x40" as hexadecimal, and its
// range check said "Value abc not in range". A leading zero now reads as decimal.
TEST_F(Inputs, IntegerOptionsTakeDecimalDigitsOnly) {
    const std::string out = (dir / "refused_integers").string();
    struct Case {
        std::string command, option, value, expect;
    };
    const std::string build = "build " + q(dem) + " " + q(rivers) + " -o " + q(out);
    const std::string capture = "capture " + q(model) + " -o " + q(out);
    const std::string synth = "synth -o " + q(out);
    const std::string notWhole = "is not a whole number", range = "must be in [";
    const std::vector<Case> cases = {
        {build, "--block-size", "0x40", notWhole},
        {build, "--block-size", "1e2", notWhole},
        {build, "--block-size", "abc", notWhole},
        {build, "--block-size", " 64", notWhole},
        {build, "--block-size", "", notWhole},
        {build, "--block-size", "-", notWhole},
        {build, "--block-size", "99999999999999999999999", range},
        {build, "--stride", "0", range},
        {build, "--band", "1.5", notWhole},
        {build, "--threads", "0x2", notWhole},
        {capture, "--frames", "0x10", notWhole},
        {capture, "--threads", "17", range},
        {capture, "--device", "-1", range},
        {"bench " + q(model) + " -o " + q(out), "--rounds", "1.0", notWhole},
        {"check " + q(model), "--threads", "1e1", notWhole},
        {"report " + q(model) + " -o " + q(out), "--image-size", "0x400", notWhole},
        {synth, "--seed", "-1", range},
        {synth, "--points", "1e6", notWhole},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.command + " " + c.option + " '" + c.value + "'");
        const auto r = runCli(c.command + " " + c.option + " " + q(c.value));
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find(c.option + ": '" + c.value + "' " + c.expect), std::string::npos)
            << r.err;
        EXPECT_FALSE(fs::exists(out));
    }
    // --size (one parser for capture, bench, view and export): digits on both sides of the x.
    for (const std::string size : {" 64x48", "+64x48", "64x-48", "64x48x"}) {
        SCOPED_TRACE("--size '" + size + "'");
        const auto r = runCli(capture + " --size " + q(size));
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find("--size '" + size + "' is not WxH"), std::string::npos) << r.err;
        const auto e = runCli("export " + q(model) + " --camera 746000,4050000,5000,0,-45 -o " +
                              q(out + ".glb") + " --size " + q(size));
        EXPECT_EQ(e.code, 2) << e.err;
        EXPECT_FALSE(fs::exists(out + ".glb"));
    }
    // A leading zero or sign is decimal: the same files as the plain number, not those of 8.
    const auto synthesise = [&](const std::string& seed, const std::string& name) {
        const std::string folder = (dir / name).string();
        const auto r = runCli("synth --points 0400 --seed " + seed + " -q -o " + q(folder));
        EXPECT_EQ(r.code, 0) << r.err;
        return slurp(folder + "/dem.tif");
    };
    const std::string padded = synthesise("010", "seed_010"), ten = synthesise("+10", "seed_10"),
                      eight = synthesise("8", "seed_8");
    ASSERT_FALSE(padded.empty());
    EXPECT_EQ(padded, ten);
    EXPECT_NE(padded, eight);
}

// bench --runs "" ran nothing and exited 0; an empty item of the list is refused too.
TEST_F(Inputs, EmptyBenchRunsAreUsageErrors) {
    const std::string out = (dir / "bench_runs.json").string();
    for (const std::string& runs : {std::string(), std::string("lod,"), std::string(",")}) {
        SCOPED_TRACE("--runs '" + runs + "'");
        const auto r = runCli("bench " + q(model) + " --frames 1 --size 16x16 -o " + q(out) +
                              " --runs " + q(runs));
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find("--runs: "), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(runs.empty() ? "the list is empty" : "has an empty item"),
                  std::string::npos)
            << r.err;
        EXPECT_FALSE(fs::exists(out));
    }
    const auto r = runCli("bench " + q(model) + " -o " + q(out) + " --runs lod,fast");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("--runs: unknown run 'fast'"), std::string::npos) << r.err;
}

// bench --runs tin: the best known method's frames (the view-dependent greedy TIN of each frame,
// preprocess/viewtin.h) drawn and timed like the other runs; its ratios are in the JSON.
TEST_F(Inputs, BenchTinRunDrawsAViewDependentTinPerFrame) {
    const std::string out = (dir / "bench_tin.json").string();
    const auto r = runCli("bench -q " + q(model) +
                          " --runs full,tin,lod --frames 3 --size 160x90 --warmup 0 "
                          "--warmup-ms 0 --validation -o " +
                          q(out));
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("full_over_tin = "), std::string::npos) << r.out;
    const nlohmann::json j = nlohmann::json::parse(slurp(out));
    const nlohmann::json& tin = j["runs"]["tin"];
    EXPECT_EQ(tin["frames"].get<int>(), 3);
    EXPECT_NE(tin["baseline"].get<std::string>().find("greedy TIN"), std::string::npos);
    // More than the hull's two triangles where the terrain is in view, fewer than full resolution.
    EXPECT_GT(tin["triangles"]["max"].get<double>(), 2.0);
    EXPECT_LT(tin["triangles"]["max"].get<double>(),
              j["runs"]["full"]["triangles"]["max"].get<double>());
    EXPECT_TRUE(j["ratios_of_median_frame_ms"].contains("full_over_tin"));
    EXPECT_TRUE(j["ratios_of_median_frame_ms"].contains("lod_over_tin"));
}

// --fov: one range, (0, 180) degrees, for capture, export, stats and report (capture took [1,
// 179]); capture refuses it without --camera (it was ignored: the frame said 60), since a --path
// has its own "fov" and the default view its 60 degrees.
TEST_F(Inputs, FovHasOneRangeAndCaptureTakesItOnlyWithACamera) {
    const std::string out = (dir / "fov").string();
    const std::string camera = " --camera 746000,4050000,5000,0,-45";
    const auto r = runCli("capture " + q(model) + " --fov 179 -o " + q(out));
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("--fov requires --camera"), std::string::npos) << r.err;
    const auto p = runCli("capture " + q(model) + " --path " + q(kAssets + "/jacksboro_path.json") +
                          " --fov 30 -o " + q(out));
    EXPECT_EQ(p.code, 2) << p.err;
    EXPECT_FALSE(fs::exists(out));
    for (const std::string& command :
         {"capture " + q(model) + camera + " -o " + q(out),
          "export " + q(model) + camera + " -o " + q(out), "stats " + q(model),
          "report " + q(model) + " -o " + q(out)}) {
        for (const char* fov : {"0", "180"}) {
            SCOPED_TRACE(command + " --fov " + fov);
            const auto f = runCli(command + " --fov " + fov);
            EXPECT_EQ(f.code, 2) << f.err;
            EXPECT_NE(f.err.find("--fov: '" + std::string(fov) + "' must be in (0, 180)"),
                      std::string::npos)
                << f.err;
            EXPECT_FALSE(fs::exists(out));
        }
    }
    // Inside the range but outside capture's old [1, 179]: a frame with that field of view.
    const auto c =
        runCli("capture -q " + q(model) + camera + " --fov 0.5 --size 16x16 -o " + q(out));
    ASSERT_EQ(c.code, 0) << c.err;
    const nlohmann::json frame = parseStrict(slurp(out + "/frame_0000.json"));
    EXPECT_DOUBLE_EQ(frame["camera"].value("fov", 0.0), 0.5) << frame["camera"].dump();
}

TEST_F(Inputs, GpuBudgetBeyondTheDeviceIsAnErrorNamingTheOption) {
    // 16 GiB is accepted by the option; lavapipe (2 GiB heap) cannot allocate it and a large GPU
    // can: either a clean error naming the option and the device, or frames.
    const std::string out = (dir / "budget").string();
    const auto r = runCli("capture " + q(model) + " --path " + q(kAssets + "/jacksboro_path.json") +
                          " --frames 1 --size 64x48 --gpu-budget 16384 --out " + q(out));
    EXPECT_FALSE(aborted(r)) << r.err;
    if (r.code != 0) {
        EXPECT_EQ(r.code, 1) << r.err;
        EXPECT_NE(r.err.find("--gpu-budget 16384 MiB"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("can allocate"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(out));
    } else {
        EXPECT_TRUE(fs::exists(fs::path(out) / "frame_0000.png"));
    }
}

TEST_F(Inputs, MissingCameraPathSaysWhy) {
    const std::string missing = (dir / "no_such_path.json").string();
    const std::string out = (dir / "missing_path.json").string();
    const auto r = runCli("bench " + q(model) + " --path " + q(missing) + " -o " + q(out));
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(missing + ": cannot read the camera path: No such file or directory"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(out));
}

TEST_F(Inputs, CameraPathWithAnOverflowingNumberNamesTheProblem) {
    const std::string path = (dir / "overflow.json").string();
    std::ofstream(path) << "{\"fov\": 60, \"keyframes\": [{\"eye\": [0, 0, 1e999], "
                           "\"yaw\": 0, \"pitch\": -30}]}";
    const std::string out = (dir / "overflow_frames").string();
    const auto r = runCli("capture " + q(model) + " --path " + q(path) + " --out " + q(out));
    EXPECT_FALSE(aborted(r)) << r.err;
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("overflow"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

}  // namespace

// A DEM whose band stores scaled values in feet (scale 2, unit "ft"): the model's heights are
// metres (x 2 x 0.3048) and the build summary says which conversion it made.
TEST_F(Inputs, ScaledElevationsInFeetBecomeMetresInTheModel) {
    const std::string scaled = (dir / "scaled_feet.tif").string();
    fs::copy_file(dir / "synth" / "dem.tif", scaled);
    {
        GDALAllRegister();
        GDALDatasetUniquePtr ds(
            GDALDataset::Open(scaled.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
        ASSERT_TRUE(ds);
        ASSERT_EQ(ds->GetRasterBand(1)->SetScale(2.0), CE_None);
        ASSERT_EQ(ds->GetRasterBand(1)->SetUnitType("ft"), CE_None);
    }
    const std::string out = (dir / "scaled_feet.ulod").string();
    const auto r = runCli("build " + q(scaled) + " " + q(rivers) + " -o " + q(out) +
                          " --block-size 32");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("DEM conversion   elevations = stored value x 2 (the band's scale"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("DEM conversion   elevations in ft, converted to metres (x 0.3048)"),
              std::string::npos)
        << r.out;
    const nlohmann::json plain = parseStrict(runCli("info --json " + q(model)).out);
    const nlohmann::json feet = parseStrict(runCli("info --json " + q(out)).out);
    ASSERT_TRUE(plain.contains("z_range") && feet.contains("z_range")) << feet.dump();
    for (int i = 0; i < 2; ++i)
        EXPECT_NEAR(feet["z_range"][i].get<double>(),
                    plain["z_range"][i].get<double>() * 2 * 0.3048, 0.02)
            << i;
}
