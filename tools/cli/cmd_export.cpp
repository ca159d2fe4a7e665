// `unilod export FILE [--camera X,Y,Z[,YAW,PITCH] | --h-lim METRES] -o OUT.glb`: the LOD selected
// for one view (without either, capture's default overview) as glTF 2.0 binary (issue 6, item 2;
// layout in tools/export/gltfexport.h). With
// --camera the levels are the ones the streaming engine draws for that view (same S, h_lim and
// level choice: tools/export/selection.h); with yaw and pitch the blocks outside the view
// frustum are left out as the engine culls them (unless --no-cull), with X,Y,Z only every block
// is written. With --h-lim every block uses that h_lim.
// `unilod export FILE --3dtiles DIR`: the whole model as a 3D Tiles 1.1 tileset on the WGS84
// globe (tools/export/tiles3d.h; CesiumJS picks the levels itself). Usage errors exit 2, data
// errors 1; no partial .glb or tileset folder is ever left.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "campath.h"
#include "commands.h"
#include "engineopts.h"
#include "gltfexport.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"
#include "tiles3d.h"
#include "ulod.h"
#include "workers.h"

namespace unilod::cli {

namespace {

struct ExportCli {
    exporter::ExportOptions o;
    std::string camera;  // --camera X,Y,Z[,YAW,PITCH] (checked while parsing)
    double hLim = -1;
    std::string size = "1920x1080";
    std::string metric;
    std::string distance = "nearest";
    bool noCull = false;
    bool noRefine = false;
    bool quiet = false;
    OutputFlags output;     // -o/--output, --overwrite
    std::string tilesDir;   // --3dtiles
    std::string sourceSrs;  // --s-srs
    std::string verticalSrs;                         // --vertical-crs
    double tileRatio = exporter::kDefaultTileRatio;  // --tile-ratio
    std::size_t threads = 0;                         // --threads (--3dtiles)
    std::optional<engine::Camera> overview;  // neither --camera nor --h-lim: capture's default
};

int runTileset(ExportCli& c) {
    exporter::TilesetOptions t;
    t.path = c.o.path;
    t.outDir = c.tilesDir;
    t.sourceSrs = c.sourceSrs;
    t.verticalSrs = c.verticalSrs;
    t.tileRatio = c.tileRatio;
    t.compress = c.o.encoding.compress;
    t.threads = c.threads;
    t.metric = metricOf(c.metric);
    // The folder rule of outputopts.h: an existing non-empty folder only with --overwrite, and
    // then the old one stays until the new one is in place.
    const OutputFlags folder{c.tilesDir, c.output.overwrite};
    std::string error;
    ReplacedFolder old;
    if (!checkOutput(folder, OutputKind::Folder, error) ||
        (folder.overwrite &&
         !old.moveAside(folder.path, {.replace = false, .inputs = {c.o.path}, .inputParts = {}},
                        exporter::tilesetForeignPart, "a 3D Tiles tileset", error))) {
        std::fprintf(stderr, "unilod export: error: %s\n", error.c_str());
        return 1;
    }
    Progress progress("export", !c.quiet, "tiles", 0);
    t.progress = [&progress](std::size_t done, std::size_t total) {
        progress.update(done, total);
    };
    exporter::TilesetSummary summary;
    const bool ok = exporter::exportTileset(t, summary, error);
    progress.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod export: error: %s\n", error.c_str());
        return 1;  // `old` goes back in place
    }
    old.keep();
    std::printf("%s: 3D Tiles 1.1 tileset, %zu tiles from %zu entries (depth %zu), %llu "
                "triangles, %llu river edges in all tiles, %llu bytes; root geometricError %.2f m; "
                "origin %.6f, %.6f (longitude, latitude)\n",
                t.outDir.c_str(), summary.tiles, summary.entries, summary.depth,
                static_cast<unsigned long long>(summary.triangles),
                static_cast<unsigned long long>(summary.riverEdges),
                static_cast<unsigned long long>(summary.bytes), summary.rootError,
                summary.longitude, summary.latitude);
    if (t.compress)
        std::printf(
            "  compressed: positions within %.4f m of the model's (one grid; %zu of the "
            "tiles too large for 16-bit positions keep floats)\n",
            summary.maxQuantizationError, summary.floatTiles);
    return 0;
}

int run(ExportCli& c) {
    exporter::SelectionOptions& s = c.o.selection;
    std::uint32_t width = 0, height = 0;
    if (parseSize(c.size, width, height)) {
        s.widthPixels = width;
        s.heightPixels = height;
    } else {
        std::fprintf(stderr, "unilod export: error: --size '%s' is not WxH (1..16384)\n",
                     c.size.c_str());
        return 2;
    }
    s.useCamera = !c.camera.empty() || c.overview;
    s.refine = !c.noRefine;
    if (s.useCamera) {
        engine::Camera camera;
        bool direction = true;
        std::string error;
        if (c.overview)
            camera = *c.overview;
        else
            parseCamera(c.camera, true, camera, direction, error);  // checked while parsing
        for (int i = 0; i < 3; ++i)
            s.eye[i] = camera.eye[i];
        if (direction) {
            s.hasDirection = true;
            s.cull = !c.noCull;
            s.yawDegrees = camera.yawDegrees;
            s.pitchDegrees = camera.pitchDegrees;
        }
        s.distance = c.distance == "centre" ? engine::DistanceMode::Centre
                                            : engine::DistanceMode::Nearest;
    } else {
        s.hLim = c.hLim;
    }
    s.metric = metricOf(c.metric);
    c.o.outPath = c.output.path;
    c.o.overwrite = c.output.overwrite;
    Progress progress("export", !c.quiet, "blocks", 0);
    c.o.progress = [&progress](std::size_t done, std::size_t total) {
        progress.update(done, total);
    };
    exporter::ExportSummary summary;
    std::string error;
    const bool ok = exporter::exportGltf(c.o, summary, error);
    progress.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod export: error: %s\n", error.c_str());
        return 1;
    }
    std::printf("%s: %zu blocks, %llu vertices, %llu triangles, %llu river edges (%llu bytes)\n",
                c.o.outPath.c_str(), summary.blocks.size(),
                static_cast<unsigned long long>(summary.vertices),
                static_cast<unsigned long long>(summary.triangles),
                static_cast<unsigned long long>(summary.riverEdges),
                static_cast<unsigned long long>(summary.bytes));
    if (c.o.encoding.compress)
        std::printf("  compressed: positions within %.4f m of the model's (one grid)\n",
                    summary.maxQuantizationError);
    return 0;
}

}  // namespace

void addExportCommand(CLI::App& app, int& exitCode) {
    auto c = std::make_shared<ExportCli>();
    CLI::App* sub = app.add_subcommand(
        "export",
        "The LOD selected for a camera or an h_lim as glTF 2.0 binary (.glb): terrain mesh, "
        "rivers as lines, georeference in asset.extras; or (--3dtiles DIR) the whole model as a "
        "3D Tiles 1.1 tileset on the WGS84 globe (CesiumJS)");
    sub->add_option("FILE", c->o.path, ".ulod file")->required();
    CLI::Option* camera =
        addCameraOption(*sub, c->camera,
                        "eye X,Y,Z (file CRS, metres), optionally yaw,pitch in degrees (as in "
                        "`unilod capture`): then only the blocks in the view frustum (default, "
                        "without --h-lim: capture's view of the whole model from the south)",
                        true);
    CLI::Option* hLim = sub->add_option("--h-lim", c->hLim,
                                        "model-space error tolerance in metres for every block")
                            ->check(nonNegative());
    camera->excludes(hLim);
    hLim->excludes(camera);
    sub->add_option("--pixels", c->o.selection.pixels,
                    "screen-space error tolerance P in pixels (--camera; default 1)")
        ->check(positive());
    sub->add_option("--fov", c->o.selection.fovDegrees,
                    "vertical field of view in degrees (--camera; default 60)")
        ->check(fovRange());
    sub->add_option("--size", c->size,
                    "viewport WxH: H enters h_lim, W/H the frustum (--camera; default 1920x1080)");
    sub->add_option("--distance", c->distance,
                    "S: nearest point of a block's box (default) or its centre (the paper's)")
        ->check(CLI::IsMember({"nearest", "centre"}));
    sub->add_flag("--no-cull", c->noCull, "with yaw,pitch: keep the blocks outside the view");
    sub->add_flag("--no-refine", c->noRefine,
                  "with --camera: every block at a stored level instead of the leaves refined "
                  "for the view from their deletion records (as the engine draws them)");
    addMetricOption(*sub, c->metric);
    CLI::Option* out = addOutputOptions(sub, c->output, "output .glb", false);
    CLI::Option* tiles = sub->add_option("--3dtiles", c->tilesDir,
                                         "write the whole model as a 3D Tiles 1.1 tileset "
                                         "(tileset.json + tiles/*.glb; the stored levels as "
                                         "chains of tiles, refine REPLACE, on the WGS84 globe) "
                                         "into this folder: a missing or empty one, or an "
                                         "earlier tileset with --overwrite")
                             ->check(notStdout("export"));
    out->excludes(tiles);
    tiles->excludes(out)->excludes(camera)->excludes(hLim);
    sub->add_option("--s-srs", c->sourceSrs,
                    "--3dtiles: CRS of the file's coordinates (any GDAL form, e.g. EPSG:32616); "
                    "default the file's own");
    sub->add_option("--vertical-crs", c->verticalSrs,
                    "--3dtiles: the vertical CRS of the file's heights (e.g. EPSG:5773, EGM96 "
                    "height, as SRTM-based DEMs): converted to WGS84 ellipsoidal heights through "
                    "PROJ's geoid grid (an error where PROJ lacks it); default: heights are "
                    "ellipsoidal already")
        ->needs(tiles);
    sub->add_option("--threads", c->threads,
                    "--3dtiles: entries exported at once (default 0: every core, at most " +
                        std::to_string(engine::WorkerPool::kMaxThreads) +
                        "); the tileset is the same for any number")
        ->transform(integerIn(0, engine::WorkerPool::kMaxThreads))
        ->needs(tiles);
    CLI::Option* ratio = sub->add_option(
        "--tile-ratio", c->tileRatio,
        "--3dtiles: a stored level becomes a tile where it has at most this share of the "
        "triangles of the tile below it (default 0.5; 1: every level a client draws at rest)");
    ratio->check(numberIn(0.01, 1.0));
    ratio->needs(tiles);
    sub->add_flag(
        "--compress", c->o.encoding.compress,
        "smaller files for the web: positions on one grid for the whole export (16-bit "
        "where a mesh fits: KHR_mesh_quantization), 8-bit octahedral normals, meshopt-compressed "
        "buffers (EXT_meshopt_compression; CesiumJS reads both, three.js with its "
        "meshopt decoder); a coordinate moves by at most half the grid step (printed)");
    addQuietFlag(sub, c->quiet);
    sub->callback([c, sub, &exitCode] {
        if (!c->tilesDir.empty()) {
            exitCode = runTileset(*c);
            return;
        }
        if (c->output.path.empty()) {
            std::fprintf(stderr, "unilod export: error: one of -o/--output or --3dtiles is "
                                 "required\n%s",
                         sub->help().c_str());
            exitCode = 2;
            return;
        }
        if (c->camera.empty() && c->hLim < 0) {
            // Neither: the view `unilod capture` renders without a camera, the whole model seen
            // from the south (engine::defaultOverview), culled like any view with a direction.
            engine::Camera overview;
            std::string error;
            if (!defaultCamera(c->o.path, overview, error)) {
                std::fprintf(stderr, "unilod export: error: %s\n", error.c_str());
                exitCode = 1;
                return;
            }
            c->overview = overview;
        }
        exitCode = run(*c);
    });
}

}  // namespace unilod::cli
