// Options every command that reads a DEM + river files shares (build, order): the inputs, band,
// CRS, river layer and filter, stride, river cleaning. One definition, so that names, defaults
// and ranges cannot drift between the commands that ingest (preprocess/ingest.h); `report` reads
// the same options back from a file's build info (ingestOptionsFromInfo).
#pragma once

#include <CLI/CLI.hpp>

#include "ingest.h"

namespace unilod::cli {

void addIngestOptions(CLI::App& sub, IngestOptions& options);

}  // namespace unilod::cli
