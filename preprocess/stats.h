// `unilod stats`: the paper's Tables 2 and 3 (§4.2.1, §4.2.2) for a .ulod file — per view
// distance D and pixel tolerance P, the model-space error tolerance h_lim of an edge, a corner
// and a middle block, and the size of the network the viewer would draw.
//
// Definitions (the paper leaves the viewpoint open; these are ours, also in the README):
// - Viewpoint: above the centre of the data's x/y extent (header minX..maxX, minY..maxY) at
//   height D above the data's maximum z (header maxZ): the paper's "sight distance" read as the
//   eye's height over the terrain, looking straight down.
// - Per block: S = 3D distance from the viewpoint to the block centre (bounding-box centre, z at
//   the box's mid height), the paper's choice of S; h_lim = 2·P·S·tan(α/2)/H (Eq. 11), α the
//   vertical field of view, H the viewport height in pixels (default 1080: the paper's
//   1920x1080 screen).
// - Selected state: the EXACT deletion step k* = the largest k with error[k] <= h_lim (error of
//   the chosen metric, non-decreasing, error[0] = full resolution). When even error[0] exceeds
//   h_lim the block stays at full resolution (k* = 0): nothing finer exists.
// - Counts of that state: points = vertexCount - k* (the alive prefix of the retention order),
//   river bound edges = steps[k*-1].riverEdgesAlive, triangles = steps[k*-1].trianglesAlive
//   (k* = 0: levels[0].riverCount / levels[0].triangleCount). Which blocks: the cut of the view
//   through the file's block hierarchy (issue 18; engine/lod/cut.h selectCut): a tree node is
//   counted instead of its children when its full-resolution error fits its h_lim. Totals are
//   sums over the drawn nodes;
//   locked border vertices shared by neighbouring blocks are counted once in EVERY block that
//   holds them (no deduplication), and so is a river edge lying on a block border. Retention % =
//   points / full-resolution points (the sum of vertexCount) · 100, counted the same way.
// - Named blocks: corner = block (0, 0); edge = ((blocksX - 1) / 2, 0), the middle of the first
//   row; middle = ((blocksX - 1) / 2, (blocksY - 1) / 2), the block nearest the grid centre
//   (integer division: ties go to the lower index). On grids smaller than 3x3 these coincide
//   (1x1: all three are block (0, 0); 2x2: all three are block (0, 0) too). A position with no
//   block in the file falls back to the nearest stored block (Manhattan distance in the grid,
//   first in file order on ties).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "cut.h"
#include "ulod.h"

namespace unilod {

struct StatsOptions {
    std::vector<double> distances = {100e3, 200e3, 500e3, 1000e3, 1500e3};  // metres
    std::vector<double> pixels = {1.0};
    double fovDegrees = 60.0;      // vertical field of view α
    double heightPixels = 1080.0;  // viewport height H
    std::uint32_t metric = 0;      // format::kMetricMax / kMetricPaper; 0 = the file's default
};

// How computeStats and computeErrorStats read the blocks their cuts draw: one block a task on
// `threads` threads (0: every core, at most engine::WorkerPool::kMaxThreads; the tables are the
// same for any number); `progress(done, total)` blocks read, from one thread at a time.
struct StatsReading {
    std::size_t threads = 0;
    std::function<void(std::size_t, std::size_t)> progress;
};

struct StatsRow {
    double distance = 0, pixels = 0;             // D (metres), P
    double hEdge = 0, hCorner = 0, hMiddle = 0;  // h_lim of the named blocks (metres)
    std::uint64_t points = 0, riverEdges = 0, triangles = 0;
    std::uint64_t nodes = 0;  // drawn nodes of the cut (blocks and tree nodes)
    double retention = 0;  // percent
};

struct StatsTable {
    std::uint32_t metric = 0;  // the metric used
    std::uint32_t blocksX = 0, blocksY = 0;
    std::uint32_t edgeCol = 0, edgeRow = 0, cornerCol = 0, cornerRow = 0;
    std::uint32_t middleCol = 0, middleRow = 0;  // named blocks actually used
    std::uint64_t fullPoints = 0;                // sum of vertexCount over blocks
    std::vector<StatsRow> rows;  // for each distance (given order), for each pixel tolerance
};

// The view of one table row (distance D, pixel tolerance P): the camera above the data's centre
// at D over its maximum z, S to each block's centre, h_lim of Eq. 11 (engine/lod/cut.h; the grid
// diagram of `report` uses the same view).
engine::ViewSpec statsView(const format::Header& header, const StatsOptions& options,
                           double distance, double pixels);

// The table as CSV (`unilod stats --csv`, `report`'s tables.csv): a header line, then one line
// per row; doubles with %.17g (they round-trip), '.' decimals.
std::string statsCsv(const StatsTable& table);

// Parses "100km", "1500 m", "2.5km" or a bare number (metres); the number as format/numtext.h
// reads it (no hexadecimal, finite), the metres finite too. False on anything else.
bool parseDistance(const std::string& text, double& metres);

// Reads `path` (format::Reader: checksums and structure are validated) and fills `table`.
// Returns false with `error` naming the file and the problem: unreadable or invalid file, a
// metric the file does not store, options out of range.
bool computeStats(const std::string& path, const StatsOptions& options, StatsTable& table,
                  std::string& error, const StatsReading& reading = {});

// --- Uniform model-error thresholds (`unilod stats --error`): the same tolerance e (metres) for
// every block, no viewpoint. Per e, summed over the nodes of the cut for h_lim = e (border vertices counted in every block
// holding them, as above):
// - exact: the exact step k* = the largest k with error[k] <= e (k* = 0 when even error[0] > e);
//   points = vertexCount - k*, triangles = steps[k*-1].trianglesAlive (k* = 0: levels[0]).
// - level: the stored level the engine draws for h_lim = e (format::storedLevelFor: the level
//   with the largest step whose stored error is <= e, level 0 when none is); points = its
//   vertexCount, triangles = its triangleCount. Finer than exact or equal to it (never coarser):
//   stored levels are a subset of the steps, so the level's step is <= k*.
struct ErrorStatsRow {
    double error = 0;  // e (metres)
    std::uint64_t exactPoints = 0, exactTriangles = 0;
    std::uint64_t levelPoints = 0, levelTriangles = 0;
    std::uint64_t nodes = 0;  // drawn nodes of the cut
};

struct ErrorStatsTable {
    std::uint32_t metric = 0;  // the metric used
    std::size_t blocks = 0, nodes = 0;  // leaves (blocks) and tree nodes in the file
    std::uint64_t fullPoints = 0, fullTriangles = 0;  // sums over the blocks at full resolution
    std::vector<ErrorStatsRow> rows;                  // one per threshold, in the given order
};

// Reads `path` and fills `table` for the thresholds `errors` (metres, >= 0) with `metric`
// (format::kMetricMax / kMetricPaper; 0 = the file's default). Returns false with `error`
// naming the file and the problem, like computeStats.
bool computeErrorStats(const std::string& path, const std::vector<double>& errors,
                       std::uint32_t metric, ErrorStatsTable& table, std::string& error,
                       const StatsReading& reading = {});

}  // namespace unilod
