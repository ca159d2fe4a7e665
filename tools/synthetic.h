// Synthetic terrain + river networks with a fixed seed, for benchmarks and tests at any size
// (STYLE.md "Tests": procedural inputs with fixed seeds). Bit-identical on every platform and
// compiler: own PRNG (splitmix64 / xoshiro256**), no std::*_distribution, no libm transcendental
// functions (own sine), and the library is compiled with -ffp-contract=off (no FMA contraction).
#pragma once

#include <ogr_spatialref.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "dem.h"
#include "points.h"
#include "rivers.h"

namespace unilod {

inline constexpr double kDefaultRoughness = 0.75;

struct SyntheticOptions {
    std::size_t targetPoints = 100000;  // DEM + river points, approximately (within a few %)
    std::uint64_t seed = 1;
    double cellSize = 30.0;  // metres
    // fBm persistence: each octave (half the wavelength) has this fraction of the previous one's
    // amplitude. 0.75 gives greedy-TIN statistics close to real DEMs and to the 4097^2 synthetic
    // of issue 15's table (README "Synthetic data"); 0.5 is the smooth terrain of earlier versions.
    double roughness = kDefaultRoughness;
    int rivers = 0;             // main rivers; 0 = scale with the grid size
    bool lockBorder = false;    // lock the grid border points (a block border)
    int width = 0, height = 0;  // explicit grid size in cells (both > 0): overrides the grid
                                // derived from targetPoints
};

// The synthetic world lies in UTM zone 16N (EPSG:32616) with its south-west grid corner here.
inline constexpr int kSyntheticEpsg = 32616;
inline constexpr double kSyntheticOriginX = 300000.0;
inline constexpr double kSyntheticOriginY = 3900000.0;

// The raster and the river lines before they become a point set; what `unilod synth` writes.
struct SyntheticData {
    // North-up grid, cell centres as in DemGrid; altitudes 0..~2000 m with an overall rise to the
    // east, large flat lowlands (< 500 m) in the west and rough mountains (> 1000 m) in the east.
    // dem.wkt is empty (the CRS is kSyntheticEpsg).
    DemGrid dem;
    // Main rivers first (roughly west to east, sine-generated meanders of varying wavelength and
    // amplitude, some tight), then tributaries. A tributary's last vertex is exactly equal to an
    // interior vertex of a main river (the junction). No two lines cross or touch elsewhere, no
    // line crosses itself; vertices are 0.5..1 cell apart and inside the hull of the cell centres.
    RiverLines rivers;
    int mainRivers = 0;
};

SyntheticData generateSyntheticData(const SyntheticOptions& options);

// generateSyntheticData + buildPointSet: DEM points closer than 1% of the cell size to a river
// segment are dropped, river z is the bilinear DEM altitude, junctions are shared ids, river
// endpoints and junctions are locked, and the grid border too with lockBorder.
PointSet generateSyntheticTerrain(const SyntheticOptions& options);

// Writes dir/dem.tif (GeoTIFF Float32, EPSG:32616) and dir/rivers.geojson (LineStrings, same CRS,
// full double precision so that junctions stay exactly shared), each through a temporary file and
// a rename. Creates `dir` when missing. `replace`: replace existing files (otherwise an existing
// file is an error, before anything is written). Returns false with `error` naming the file on
// failure and leaves no temporary file behind.
bool writeSyntheticData(const SyntheticData& data, const std::string& dir, std::string& error,
                        bool replace = true);

// Writes `dem` to `path` as a GeoTIFF (Float32, NaN = nodata) in `srs`. False with `error`.
bool writeDemFile(const DemGrid& dem, const OGRSpatialReference& srs, const std::string& path,
                  std::string& error);

}  // namespace unilod
