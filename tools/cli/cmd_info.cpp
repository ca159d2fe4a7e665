// `unilod info FILE [--json]`: the header and a per-block summary of a .ulod file.
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.h"
#include "jsontext.h"
#include "outputopts.h"
#include "ulod.h"

namespace unilod::cli {

namespace {

int run(const std::string& path, bool asJson) {
    format::Reader reader;
    std::string error;
    if (!reader.open(path, error)) {
        std::fprintf(stderr, "unilod info: error: %s\n", error.c_str());
        return 1;
    }
    const format::Header& h = reader.header();
    nlohmann::json blocks = nlohmann::json::array();
    std::uint64_t vertices = 0, triangles = 0;  // totals over the blocks (tree level 0)
    std::uint64_t blockBytes = 0, compactBlocks = 0;
    std::size_t leafCount = 0, treeLevels = 0;
    for (const format::BlockInfo& b : reader.blocks()) {
        if (b.level == 0) {
            vertices += b.vertexCount;
            triangles += b.fullTriangles;
            ++leafCount;
        }
        treeLevels = std::max<std::size_t>(treeLevels, b.level);
        blockBytes += b.size;
        compactBlocks += b.encoding == 1;
        nlohmann::json children = nlohmann::json::array();
        for (std::uint32_t c = 0; c < b.childCount; ++c)
            children.push_back(b.firstChild + c);
        blocks.push_back({{"col", b.col},
                          {"row", b.row},
                          {"level", b.level},
                          {"children", children},
                          {"bbox", {b.minX, b.minY, b.minZ, b.maxX, b.maxY, b.maxZ}},
                          {"offset", b.offset},
                          {"bytes", b.size},
                          {"vertices", b.vertexCount},
                          {"steps", b.stepCount},
                          {"levels", b.levelCount},
                          {"full_triangles", b.fullTriangles},
                          {"encoding", b.encoding == 1 ? "compact" : "raw"}});
    }
    std::string metrics;
    if (h.metrics & format::kMetricMax) metrics += "max";
    if (h.metrics & format::kMetricPaper) metrics += metrics.empty() ? "paper" : ", paper";
    const char* def = h.defaultMetric == format::kMetricPaper ? "paper" : "max";
    nlohmann::json info = nlohmann::json::parse(h.buildInfo, nullptr, false);
    if (asJson) {
        const nlohmann::json out = {
            {"file", path},
            {"version", format::kVersion},
            {"crs_wkt", h.crsWkt},
            {"origin", {h.originX, h.originY}},
            {"extent", {h.minX, h.minY, h.maxX, h.maxY}},
            {"z_range", {h.minZ, h.maxZ}},
            {"block_grid", {h.blocksX, h.blocksY}},
            {"block_size_m", {h.blockWidth, h.blockHeight}},
            {"leaf_blocks", leafCount},
            {"tree_nodes", reader.blocks().size() - leafCount},
            {"tree_levels", treeLevels},
            {"metrics", metrics},
            {"default_metric", def},
            {"z_quantum_m", h.zQuantum},
            {"compact_blocks", compactBlocks},
            {"block_bytes", blockBytes},
            {"build", info.is_discarded() ? nlohmann::json(h.buildInfo) : info},
            {"vertices", vertices},
            {"full_triangles", triangles},
            {"blocks", blocks},
        };
        std::printf("%s\n", jsonText(out, 2).c_str());
        return 0;
    }
    std::printf("%s: unilod .ulod version %u\n", path.c_str(), format::kVersion);
    std::printf("  extent        x %.3f .. %.3f, y %.3f .. %.3f\n", h.minX, h.maxX, h.minY, h.maxY);
    std::printf("  z range       %.3f .. %.3f m\n", h.minZ, h.maxZ);
    std::printf("  origin        %.3f, %.3f\n", h.originX, h.originY);
    std::printf("  block grid    %u x %u blocks of %.1f x %.1f m\n", h.blocksX, h.blocksY,
                h.blockWidth, h.blockHeight);
    std::printf("  tree          %zu blocks, %zu nodes above them in %zu levels\n", leafCount,
                reader.blocks().size() - leafCount, treeLevels);
    std::printf("  metrics       %s (default %s)\n", metrics.c_str(), def);
    std::printf("  storage       %llu of %zu entries compact, %llu bytes of blocks, z quantum %g m\n",
                static_cast<unsigned long long>(compactBlocks), reader.blocks().size(),
                static_cast<unsigned long long>(blockBytes), h.zQuantum);
    std::printf("  totals        %llu vertices, %llu triangles at full resolution\n",
                static_cast<unsigned long long>(vertices),
                static_cast<unsigned long long>(triangles));
    std::printf("  crs           %.70s%s\n", h.crsWkt.empty() ? "none" : h.crsWkt.c_str(),
                h.crsWkt.size() > 70 ? "..." : "");
    std::printf("  %-13s %9s %9s %7s %10s %12s\n", "block", "vertices", "steps", "levels",
                "triangles", "bytes");
    for (const format::BlockInfo& b : reader.blocks()) {
        const std::string name = "(" + std::to_string(b.col) + "," + std::to_string(b.row) + ")" +
                                 (b.level > 0 ? " L" + std::to_string(b.level) : "");
        std::printf("  %-13s %9u %9u %7u %10u %12llu\n", name.c_str(), b.vertexCount, b.stepCount,
                    b.levelCount, b.fullTriangles, static_cast<unsigned long long>(b.size));
    }
    return 0;
}

}  // namespace

void addInfoCommand(CLI::App& app, int& exitCode) {
    auto path = std::make_shared<std::string>();
    auto json = std::make_shared<JsonFlags>();
    auto quiet = std::make_shared<bool>(false);
    CLI::App* sub =
        app.add_subcommand("info", "Print the header and a per-block summary of a .ulod file");
    sub->add_option("FILE", *path, ".ulod file")->required();
    addJsonOption(sub, *json, "print JSON on stdout ('-', the default)");
    addQuietFlag(sub, *quiet);  // info prints nothing on stderr but errors: accepted for scripts
    // Every bound variable is captured, so that it lives as long as the parser writes to it
    // (an uncaptured `quiet` was freed on return: `info -q` wrote to freed memory).
    sub->callback([path, json, quiet, &exitCode] { exitCode = run(*path, json->requested()); });
}

}  // namespace unilod::cli
