#include "ingestopts.h"

#include "numbers.h"

namespace unilod::cli {

void addSrsOptions(CLI::App& sub, IngestOptions& o) {
    sub.add_option("--t-srs", o.targetSrs,
                   "target (working) CRS, projected in metres, any GDAL SRS text (default: a "
                   "projected DEM's own when in metres, else the UTM zone of the DEM's centre)");
    sub.add_option("--s-srs", o.assumeSrs,
                   "source CRS assumed for an input that declares none (the DEM, the river "
                   "layer), as gdalwarp -s_srs");
    // The old spellings, hidden: scripts keep working.
    sub.add_option("--target-srs", o.targetSrs, "old spelling of --t-srs")->group("");
    sub.add_option("--assume-crs,--rivers-srs", o.assumeSrs, "old spelling of --s-srs")
        ->group("");
}

void addIngestOptions(CLI::App& sub, IngestOptions& o) {
    sub.add_option("DEM", o.demPath, "DEM raster (any single-band raster GDAL reads)")->required();
    sub.add_option("RIVERS", o.riversPath,
                   "river lines (any OGR line layer); leave out for a terrain-only model");
    sub.add_option("--band", o.band, "raster band (1-based) for multi-band rasters")
        ->transform(integerIn(1, 1 << 20));
    addSrsOptions(sub, o);
    sub.add_option("--layer", o.layer, "river layer name (default: the first line layer)");
    sub.add_option("--where", o.where, "OGR SQL attribute filter for the rivers");
    sub.add_option("--stride", o.stride, "take every k-th DEM row and column (default 1)")
        ->transform(integerIn(1, 1 << 20));
    sub.add_option("--min-river-length", o.minRiverLength,
                   "drop rivers shorter than this (metres; default 0)")
        ->check(nonNegative());
}

void addMemoryOptions(CLI::App& sub, MemoryFlags& flags, const std::string& what) {
    sub.add_option("--memory-limit", flags.limitMb,
                   "refuse, before the long work, a " + what +
                       " whose memory estimate (README \"Large DEMs\") exceeds this many MB "
                       "(default: the memory this process can get: available memory and swap, a "
                       "cgroup's or ulimit's limit)")
        ->check(numberIn(1.0, 1e12));
    sub.add_flag("--memory-check,!--no-memory-check", flags.check,
                 "refuse a " + what +
                     " whose memory estimate exceeds what is available (default); "
                     "--no-memory-check: try anyway");
}

}  // namespace unilod::cli
