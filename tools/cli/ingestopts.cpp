#include "ingestopts.h"

#include "numbers.h"

namespace unilod::cli {

void addIngestOptions(CLI::App& sub, IngestOptions& o) {
    sub.add_option("DEM", o.demPath, "DEM raster (any single-band raster GDAL reads)")->required();
    sub.add_option("RIVERS", o.riversPath, "river lines (any OGR line layer)")->required();
    sub.add_option("--band", o.band, "raster band (1-based) for multi-band rasters")
        ->check(positive());
    sub.add_option("--t-srs,--target-srs", o.targetSrs,
                   "working CRS (default: a projected DEM's own, a geographic DEM's UTM zone)");
    sub.add_option("--layer", o.layer, "river layer name (default: the first line layer)");
    sub.add_option("--where", o.where, "OGR SQL attribute filter for the rivers");
    sub.add_option("--assume-crs,--rivers-srs", o.assumeSrs,
                   "CRS of a river layer that declares none");
    sub.add_option("--stride", o.stride, "take every k-th DEM row and column (default 1)")
        ->check(CLI::Range(1, 1 << 20));
    sub.add_option("--min-river-length", o.minRiverLength,
                   "drop rivers shorter than this (metres; default 0)")
        ->check(nonNegative());
}

}  // namespace unilod::cli
