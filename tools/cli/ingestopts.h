// Options every command that reads a DEM + river files shares (build, order; report the CRS ones): the inputs, band,
// CRS, river layer and filter, stride, river cleaning. One definition, so that names, defaults
// and ranges cannot drift between the commands that ingest (preprocess/ingest.h); `report` reads
// the same options back from a file's build info (ingestOptionsFromInfo).
#pragma once

#include <CLI/CLI.hpp>

#include "ingest.h"

namespace unilod::cli {

void addIngestOptions(CLI::App& sub, IngestOptions& options);

// --t-srs (target / working CRS) and --s-srs (the CRS of an input without one), with the old
// spellings --target-srs, --assume-crs and --rivers-srs as hidden aliases. Part of
// addIngestOptions; `report` adds them alone (for its --dem / --rivers).
void addSrsOptions(CLI::App& sub, IngestOptions& options);

// --memory-limit MB and --memory-check / --no-memory-check of the commands that check their
// memory estimate before the long work (build, order; preprocess/build.h checkMemory).
// `what`: the work refused ("build", "ranking").
struct MemoryFlags {
    double limitMb = 0;  // 0: what the process can get
    bool check = true;
    double limitBytes() const { return limitMb * 1e6; }
};
void addMemoryOptions(CLI::App& sub, MemoryFlags& flags, const std::string& what);

}  // namespace unilod::cli
