// The README's main-job command (tools/demo.sh) run headless with a small frame count, as CI
// runs it (issue 6, item 4): it must complete and leave every output it announces, each one
// readable by its consumer (the .ulod by the reader, the captures as PNG + JSON, the bench JSON
// with its runs, the .glb through tinygltf, the report's Markdown).
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "testutil.h"
#include "tools/cliutil.h"
#include "ulod.h"

using namespace unilod;
namespace fs = std::filesystem;
using unilod::test::q;
using unilod::test::slurp;

namespace {

struct DemoRun {
    int code = -1;
    std::string out;
};

DemoRun runDemo(const std::string& args, const std::string& logPath) {
    // No display: the viewer must not open; the built binary, no rebuild.
    const std::string command = "env -u DISPLAY -u WAYLAND_DISPLAY UNILOD_BIN=" +
                                q(UNILOD_CLI) + " bash " + q(UNILOD_SOURCE_DIR "/tools/demo.sh") +
                                " " + args + " >" + q(logPath) + " 2>&1";
    const int status = std::system(command.c_str());
    DemoRun r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(logPath);
    return r;
}

bool isPng(const std::string& path) {
    const std::string s = slurp(path);
    return s.size() > 8 && s.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0;
}

}  // namespace

TEST(Demo, MainJobCompletesHeadless) {
    test::TempDir dir("demo");
    const std::string out = dir.file("out");
    const DemoRun r = runDemo("--no-build --frames 3 --size 320x180 --out " + q(out),
                          dir.file("demo.log"));
    ASSERT_EQ(r.code, 0) << r.out;
    for (const char* step : {"unilod build", "unilod check", "unilod capture", "unilod bench",
                             "unilod export", "unilod report", "unilod order", "== outputs =="})
        EXPECT_NE(r.out.find(step), std::string::npos) << step << "\n" << r.out;
    EXPECT_EQ(r.out.find("== viewer"), std::string::npos) << "no display: no viewer";

    // The model: readable, 64-cell blocks.
    format::Reader reader;
    std::string error;
    ASSERT_TRUE(reader.open(out + "/jacksboro.ulod", error)) << error;
    EXPECT_GT(reader.blocks().size(), 4u);

    // Captures: PNG + JSON per frame; the path capture has its 5 frames.
    for (const char* view : {"oblique", "topdown", "grid"}) {
        SCOPED_TRACE(view);
        const std::string base = out + "/capture/" + view + "/frame_0000";
        EXPECT_TRUE(isPng(base + ".png"));
        const nlohmann::json j = nlohmann::json::parse(slurp(base + ".json"));
        EXPECT_GT(j.at("totals").at("triangles").get<std::uint64_t>(), 0u);
    }
    for (int f = 0; f < 5; ++f) {
        char name[64];
        std::snprintf(name, sizeof name, "/capture/path/frame_%04d.png", f);
        EXPECT_TRUE(isPng(out + name)) << name;
    }

    // The benches (fly-over, orbit, orbit in the paper's configuration): the requested frames,
    // four runs each.
    for (const char* name : {"/bench.json", "/bench_orbit.json", "/bench_orbit_paper.json"}) {
        const nlohmann::json bench = nlohmann::json::parse(slurp(out + name));
        EXPECT_EQ(bench.at("frames").get<int>(), 3) << name;
        const bool paper = std::string(name) == "/bench_orbit_paper.json";
        EXPECT_EQ(bench.at("metric"), paper ? "paper" : "file default") << name;
        EXPECT_EQ(bench.at("distance"), paper ? "centre" : "nearest") << name;
        for (const char* run : {"lod", "resident", "bare", "full"})
            EXPECT_EQ(bench.at("runs").at(run).at("frames").get<int>(), 3) << name << " " << run;
    }

    // The export opens in tinygltf and has terrain and river primitives.
    tinygltf::Model m;
    tinygltf::TinyGLTF loader;
    std::string err, warn;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, out + "/jacksboro_oblique.glb")) << err;
    EXPECT_GT(m.nodes.size(), 0u);
    bool lines = false;
    for (const tinygltf::Mesh& mesh : m.meshes)
        for (const tinygltf::Primitive& p : mesh.primitives) lines |= p.mode == TINYGLTF_MODE_LINE;
    EXPECT_TRUE(lines);

    // The report and the importance order.
    const std::string report = slurp(out + "/report/report.md");
    EXPECT_NE(report.find("Table"), std::string::npos);
    EXPECT_TRUE(isPng(out + "/report/grid_100km.png"));
    EXPECT_GT(fs::file_size(out + "/jacksboro_order.csv"), 1000u);

    // Every path the summary announces exists.
    const std::size_t summary = r.out.find("== outputs ==");
    ASSERT_NE(summary, std::string::npos);
    const std::regex line(R"(:\s+(\S+))");
    std::string rest = r.out.substr(summary);
    int checked = 0;
    for (std::sregex_iterator it(rest.begin(), rest.end(), line), end; it != end; ++it) {
        std::string p = (*it)[1];
        if (!p.empty() && p.back() == ',') p.pop_back();
        if (p.find('{') != std::string::npos) p = p.substr(0, p.find('{'));
        EXPECT_TRUE(fs::exists(p)) << p;
        ++checked;
    }
    EXPECT_GE(checked, 6);

    // A second run into the same folder works (the report folder is replaced).
    EXPECT_EQ(runDemo("--no-build --frames 2 --size 160x90 --out " + q(out),
                      dir.file("demo2.log"))
                  .code,
              0)
        << slurp(dir.file("demo2.log"));

    // Usage errors exit 2.
    EXPECT_EQ(runDemo("--frobnicate", dir.file("demo3.log")).code, 2);
}
