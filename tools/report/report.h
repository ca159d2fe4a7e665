// `unilod report FILE -o DIR` (issue 6, item 3): the paper's evaluation for one .ulod file.
//
//   DIR/report.md        index: what each file is, with the main numbers inline
//   DIR/tables.md, .csv  Tables 2 / 3 (preprocess/stats.h; the CSV is `unilod stats --csv`)
//   DIR/curves.svg, .csv model error vs retention for both metrics, aggregated over blocks
//   DIR/rivers.md, .csv  BAI vs plain 3D_DP: 2D Hausdorff distance of simplified rivers to the
//                        originals at equal point budgets, by landform (Table 1 altitude) class
//   DIR/grid_<D>.png     top-down wireframe of the levels drawn at view distance D (Figs. 7-12),
//                        titled with D, P and what it drew; with `annotate` a scale bar and a
//                        north arrow (engine/annotate.h)
//   DIR/grid.csv         what each diagram drew (nodes, points, triangles, river edges)
//   DIR/frametime.png, .csv  frame time (ms) per frame along a camera path: `unilod bench`'s
//                        lod, resident, bare and full runs (engine/bench.h), Vulkan
//   DIR/report.json      the numbers above, machine-readable
//
// Definitions (also in the README):
// - Curves: for retention r (1 %, 2 %, ..., 100 %) every block is taken at step
//   k_b = min(steps_b, floor((1 - r) · vertexCount_b)) (a block cannot drop its locked points: it
//   stays at its coarsest state), error_b = errors[k_b]; the curve shows the maximum and the mean
//   of error_b over blocks, per metric.
// - Rivers: the file's deletion order is computed twice on the model's inputs (DEM + rivers from
//   the file's build info or --dem / --rivers, cleaned like `unilod build` and cut into the
//   build's blocks at its block size and stride, as the build's leaves are): with BAI and
//   without (--no-bai). For a greedy build that is each block's greedy deletion order, with
//   and without the BAI weights on river keys; for a 3ddp build (or a file without an `order`
//   in its build info) improved 3D_DP with BAI and plain 3D_DP. A file without a `block_size`
//   in its build info gets the build's default block size. The unit compared is a river piece of a
//   block (a river crossing a block border is cut there at a locked crossing vertex, as in the
//   model). For a budget f, each piece keeps its locked points (ends, crossings, junctions) and the
//   round(f · n) highest-ranked of its n unlocked points (rank = position in the deletion order:
//   deleted later = more important); the simplified polyline joins the kept points in their
//   original order. Its symmetric 2D Hausdorff distance to the original polyline is measured
//   (hausdorff2D). Pieces without unlocked points are not counted. Landform class: the mean
//   altitude of the piece's vertices (z sampled from the DEM), classes by Table 1's lower bounds 0
//   / 500 / 1000 m.
// - Grid diagrams: the stats viewpoint (stats.h statsView: above the centre of the data, D above
//   its maximum z, S = distance to the block centre, h_lim = 2·P·S·tan(α/2)/H, P the first
//   pixel tolerance); the cut of that view through the block hierarchy (engine/lod/cut.h
//   selectCut, the nodes `stats` counts), each drawn node at the stored level the cut chooses
//   for it: the level the engine would draw. So the diagrams count the same nodes as the tables
//   but at their stored levels, while tables.md counts each node's exact deletion step k*
//   (stats.h): the stored levels are a subset of the steps and the engine draws the one with
//   the largest step <= k*, so the diagrams' points and triangles are >= the tables' for the
//   same D. Two distances whose cuts draw the
//   same nodes at the same levels (e.g. everything at its coarsest stored level) give the same
//   wireframe; only the title differs, and report.md says so.
// - Frame times: `benchFrames` cameras along `benchPath` (default: a fly-over generated from the
//   data's extent: from south of the data, 0.4 x its span above its top, to above its centre
//   at 0.15 x the span, looking north 30 degrees down), `benchWidth` x `benchHeight`, P and the
//   metric of the tables; the four runs of engine/bench.h with per-frame numbers. The lod run
//   streams without waiting: until the loader delivers a block's levels it draws the coarse
//   fallback, so on a short path its line can stay at the coarse cost; resident is the same
//   level choice with everything preloaded.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "atomicfile.h"
#include "camera.h"
#include "device.h"
#include "rivers.h"
#include "stats.h"

namespace unilod::report {

struct ReportOptions {
    std::string path;    // the .ulod file
    std::string outDir;  // created; must not exist or be empty
    StatsOptions stats;  // distances, pixels, fov, height, metric: tables and grid diagrams
    std::string demPath, riversPath;  // override the build info's inputs
    bool rivers = true;               // false: no BAI comparison (no DEM / rivers needed)
    std::vector<double> budgets = {0.05, 0.10, 0.20, 0.40};  // river point budgets (fractions)
    std::uint32_t imageSize = 1024;                           // grid diagrams: square, pixels
    bool annotate = true;  // grid diagrams: scale bar and north arrow (the title is always there)
    std::uint32_t benchFrames = 60;  // frame-time plot: frames along the path; 0: no plot
    std::uint32_t benchWidth = 640, benchHeight = 360;
    std::string benchPath;  // camera path JSON (engine/capture.h); empty: a generated fly-over
    engine::DeviceOptions device;  // the benchmark's Vulkan device and validation
    std::string spirvDir;
    std::size_t threads =
        0;  // tables: blocks read, river comparison: ranked at once (0: every core, <= 16)
    std::function<void(const std::string&)> progress;         // one line per stage
    // Within a counted stage (the river comparison's blocks): done of total; called from one
    // thread at a time.
    std::function<void(std::size_t, std::size_t)> progressCount;
};

struct GridDiagram {
    double distance = 0, pixels = 0;
    std::string file;  // name inside outDir
    // Summed over the drawn nodes at their stored levels (points: the levels' vertexCount).
    std::uint64_t nodes = 0, points = 0, triangles = 0, triangleEdges = 0, riverEdges = 0;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> drawn;  // (node, level), file order
};

// The frame-time measurement (definitions above).
struct FrameTimes {
    std::string device, cameras;  // the Vulkan device; the path file or "generated fly-over"
    std::uint32_t width = 0, height = 0;
    std::vector<std::string> runs;          // "lod", "resident", "bare", "full"
    std::vector<std::vector<double>> ms;    // per run: frame time (ms) of each frame
    std::vector<double> medianMs;           // per run
    std::vector<std::uint64_t> triangles;   // per run: triangles of the last frame
};

struct RiverRow {
    int landformClass = 0;
    double classLow = 0, classHigh = 0;  // altitude range (m); classHigh = +inf for the last
    double budget = 0;                   // fraction of unlocked points kept
    std::uint64_t rivers = 0, originalPoints = 0, keptPoints = 0;
    double meanBai = 0, meanPlain = 0, maxBai = 0, maxPlain = 0;  // Hausdorff (m)
    std::uint64_t baiBetter = 0, plainBetter = 0;  // rivers where one is strictly smaller
};

struct CurvePoint {
    double retention = 0;                            // percent
    double maxOfMax = 0, meanOfMax = 0;              // metric "max" over blocks
    double maxOfPaper = 0, meanOfPaper = 0;          // metric "paper" over blocks
};

struct ReportSummary {
    StatsTable table;
    std::vector<CurvePoint> curve;
    bool hasMax = false, hasPaper = false;
    std::vector<RiverRow> rivers;
    std::vector<GridDiagram> grids;
    FrameTimes frameTimes;           // runs empty: not measured (benchFrames 0)
    std::vector<std::string> files;  // written, relative to outDir
};

// Whether a report writes a file of this name (runReport writes no other): report.json,
// report.md, tables.csv / .md, curves.csv / .svg, rivers.csv / .md, grid.csv,
// frametime.png / .csv, grid_<km>km.png.
bool isReportFileName(const std::string& name);

// What `report --overwrite` may replace in `folder` (cli/outputopts.h ReplacedFolder): for an
// entry of the folder, "" when an earlier report wrote it, else its name. An earlier report is
// a readable report.json of runReport's (its "source" and "files"); its entries are report.json,
// report.md and the files it lists, each a regular file (not a link, not a folder) whose name
// is one a report writes (isReportFileName): a report.json placed by hand that lists other
// files does not make them the report's. Without such a report.json every entry is foreign.
std::function<std::string(const std::filesystem::directory_entry&)> reportForeignPart(
    const std::string& folder);

// Every file the report of `options` reads, for the output checks (format::OutputOptions, never
// replaced; a replaced folder may not hold one): the .ulod file, the camera path, and the DEM and
// rivers with every file GDAL reads for them (ingest.h addInputFiles): --dem / --rivers, else,
// when the river comparison runs, those the file's build info names, and its BAI table. A file
// that cannot be opened contributes its path alone (runReport then reports the error).
format::OutputOptions reportInputs(const ReportOptions& options);

// Writes everything into a temporary folder beside outDir and renames it into place at the end:
// on failure nothing is left (outDir untouched). False with a message naming the file.
bool runReport(const ReportOptions& options, ReportSummary& summary, std::string& error);

// --- Building blocks (tested on their own) ---------------------------------------------------

// Distance from p to the segment ab (a == b: to the point).
double pointSegmentDistance(const XY& p, const XY& a, const XY& b);

// Directed 2D Hausdorff distance sup_{p in A} d(p, B) of polylines (a single point is a
// polyline too). d(p, B) is exact (point-to-segment); the supremum over A is taken over A's
// vertices and `samples` - 1 evenly spaced interior points of each of its segments, so the result
// is at most (longest segment of A) / (2 · samples) below the true value (d(·, B) is 1-Lipschitz).
double directedHausdorff(const std::vector<XY>& a, const std::vector<XY>& b, int samples = 64);

// Symmetric: max of both directions.
double hausdorff2D(const std::vector<XY>& a, const std::vector<XY>& b, int samples = 64);

// Error-vs-retention curve of one file (definitions above), 100 points. The blocks are read on
// `reading.threads` threads (the curve is the same for any number), `reading.progress` counting
// them (stats.h StatsReading).
bool computeCurve(const std::string& path, std::vector<CurvePoint>& curve, bool& hasMax,
                  bool& hasPaper, std::string& error, const StatsReading& reading = {});

// Renders one grid diagram (RGBA8, size x size, title band on top) and counts what it drew.
bool renderGrid(const std::string& path, const StatsOptions& stats, double distance,
                std::uint32_t size, bool annotate, std::vector<std::uint8_t>& rgba,
                GridDiagram& counts, std::string& error);

// The title of a grid diagram: D, P, then the drawn nodes, points, triangles and river edges.
std::vector<std::string> gridTitle(const GridDiagram& g);

// The cameras of the frame-time measurement (definitions above) for a file's header.
std::vector<engine::Camera> flyOverCameras(const format::Header& header, std::uint32_t frames);

// Runs the benchmark for the frame-time plot. False with a message (no Vulkan device, a
// validation message, an unreadable camera path).
bool measureFrameTimes(const ReportOptions& options, FrameTimes& out, std::string& error);

// The plot (RGBA8, width x height, white): frame time (ms) over the frame index, one line per
// run, legend with each run's median.
void plotFrameTimes(const FrameTimes& t, std::uint32_t width, std::uint32_t height,
                    std::vector<std::uint8_t>& rgba);


}  // namespace unilod::report

namespace unilod::report {

// The BAI vs plain 3D_DP comparison (definitions above) on the inputs named by the file's build
// info `buildInfo` (JSON) or the options' overrides (no rows for a terrain-only build).
// `progress` may be empty.
bool compareRivers(const ReportOptions& options, const std::string& buildInfo,
                   std::vector<RiverRow>& rows, std::string& error);

}  // namespace unilod::report
