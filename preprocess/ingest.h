// Ingestion: DEM raster + river lines -> the checked, cleaned inputs of the unified model, and the
// block point sets made from them. The ONE path from files to points: `unilod build`, `unilod
// order` and `unilod report` all call it, so that they rank the same points (issue 17, item 6).
//
// ingest(): load the DEM (GDAL; band, geographic -> UTM of its centre or the target CRS); refuse
// a raster below 2 x 2 cells or with absurd elevations; fill small nodata holes (nodata.h rule
// 1); load the rivers (OGR, reprojected to the DEM's CRS); refuse rivers with no vertex on the
// DEM; clean the rivers (rivercleaning.h). splitIntoBlocks(): check stride and block size against
// the DEM (a block size larger than the DEM is clamped: one block in that direction), cut the
// block grid with the river clearance (blocks.h), fill the nodata cells a block's hull would
// bridge (nodata.h rule 2).
#pragma once

#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "atomicfile.h"
#include "blocks.h"
#include "dem.h"
#include "nodata.h"
#include "rivercleaning.h"
#include "rivers.h"

namespace unilod {

// Elevations outside this range are refused as absurd (a broken nodata value, wrong units...):
// the lowest and highest points on Earth with a wide margin.
inline constexpr double kMinPlausibleZ = -12000.0, kMaxPlausibleZ = 10000.0;
// Nodata values people use that lie inside that range; a cell holding one that is more than
// kNodataJump from a neighbour is refused as an undeclared nodata value (the steepest real
// terrain, a kilometre cell of a mountain face or an ocean trench, stays well under it).
inline constexpr float kUndeclaredNodata[2] = {-9999.0f, 9999.0f};
inline constexpr double kNodataJump = 3000.0;

struct IngestOptions {
    std::string demPath, riversPath;
    int band = 0;           // 1-based; 0: the only band
    std::string targetSrs;  // --t-srs; empty: a projected DEM's own CRS, else UTM of its centre
    // River layer, OGR SQL filter; --s-srs: the CRS of an input (DEM, river layer) without one.
    std::string layer, where, assumeSrs;
    int stride = 1;                       // DEM points: every stride-th row and column
    double minRiverLength = 0;            // river cleaning: drop shorter rivers (metres)
    double riverClearance = kDefaultRiverClearance;  // DEM points this close to a river go
    // The memory the DEM's copies may take and what bound that is (DemLoadOptions::memoryBytes;
    // 0: no check): build and order pass their memory check's bound (build.h memoryBound).
    // `demMemorySkippable`: the command has --no-memory-check.
    double demMemoryBytes = 0;
    std::string demMemoryWhat;
    bool demMemorySkippable = true;
    int demThreads = 0;          // threads reprojecting the DEM (GDAL's warp); 0: all cores
    double demBytesPerCell = 4;  // the memory check's bytes per cell (DemLoadOptions::bytesPerCell)
    double demBaseBytes = 0;     // and the caller's fixed bytes (DemLoadOptions::baseBytes)
    // Where a raster the memory cannot hold is kept while it is read at --stride > 1
    // (DemLoadOptions::spillDir; empty: nowhere, such a raster is refused).
    std::string demSpillDir;
    // Warnings for accepted-but-odd input (empty river layer, NaN cells...).
    std::function<void(const std::string&)> warn;
    // Progress: the name of a long step as it starts ("cleaning the rivers").
    std::function<void(const std::string&)> onStage;
};

struct Ingested {
    DemGrid dem;        // working CRS, small holes filled (nodata.h)
    RiverLines rivers;  // cleaned, in the DEM's CRS
    RiverCleaningStats cleaning;
    NodataStats nodata;
};

// Returns false with `error` (naming the file and the problem) on bad input.
bool ingest(const IngestOptions& options, Ingested& data, std::string& error);

// The block grid of `data` (blocks.h) with the options' stride and river clearance; `blockSize`
// in DEM cells, clamped to the DEM per direction (a block size >= the DEM's extent in a direction
// gives one block there). A DEM without any domain (blocks.h "Domain": no lattice square with 3
// valid corners) is refused. `source` keeps a pointer to data.dem: keep
// `data` in place while `source` is used. Returns false with `error` naming the option
// (--stride, --block-size) or the DEM.
bool splitIntoBlocks(Ingested& data, const IngestOptions& options, int blockSize,
                     bool lockOuterEdge, BlockSource& source, std::string& error);

// A block size that makes the whole DEM one block (splitIntoBlocks clamps it).
inline constexpr int kWholeDem = 1 << 30;

// Cells so large that a block of two sampled cells exceeds the exact grid (cells beyond about
// 268 km): false with `error` ("its cells are ... km wide: ..."), which no --block-size fixes.
bool checkCellsFitExactGrid(const DemGrid& dem, int stride, std::string& error);

// The default block size of `build`: kDefaultBlockSize cells (twice the stride where that is
// more), or fewer where blocks that large would not fit the exact 1 mm grid of the constrained
// triangulation (about 537 km a side: cells of more than 2 km).
int automaticBlockSize(const DemGrid& dem, int stride);
// False with `error` naming --block-size when blocks of `blockSize` cells (clamped to the DEM)
// would not fit that grid.
bool checkBlockFitsExactGrid(const DemGrid& dem, int stride, int blockSize, std::string& error);

// The files a GDAL input consists of besides its name, for the output checks (an output is
// never one of them, also with --overwrite): where GDAL opens `name` (`raster`: as a raster,
// else as a vector source), every other file its driver lists (GDALGetFileList): a Shapefile's
// .shx, .dbf and .prj, a VRT's source rasters, a GeoTIFF's .aux.xml, .ovr or world file, the
// container of a subdataset. (`build dem.vrt -o src.tif --overwrite`, src.tif a source of the
// VRT, replaced the source raster; `-o rivers.dbf` the Shapefile's table.) Nothing for a name
// that is no regular file or folder (a FIFO: opening it would block) or that GDAL cannot open:
// its reader reports it.
std::vector<std::string> datasetFiles(const std::string& name, bool raster);
// Adds a DEM (raster) and rivers (vector; "": none) to `output`: each name to inputs, its
// datasetFiles to inputParts.
void addInputFiles(format::OutputOptions& output, const std::string& demPath,
                   const std::string& riversPath);

// The build info keys of these options: `unilod build` records them in the .ulod file,
// `unilod report` reads them back (absent keys keep the defaults).
void recordIngestOptions(const IngestOptions& options, nlohmann::json& info);
IngestOptions ingestOptionsFromInfo(const nlohmann::json& info);

}  // namespace unilod
