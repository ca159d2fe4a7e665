// PNG output for captures (libpng, fast zlib level: captures are written per frame).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "atomicfile.h"

namespace unilod::format {

// Writes RGBA8 rows (top to bottom) as an RGBA PNG with writeFileAtomically (`output`:
// replace an existing file or not, the inputs `path` must not be). Returns false with a message
// naming the file; nothing is left behind on failure.
// The same PNG in memory (for a file written with others: AtomicFileSet). False when libpng
// fails.
bool encodePng(std::uint32_t width, std::uint32_t height, const std::vector<std::uint8_t>& rgba,
               std::string& png);

bool writePng(const std::string& path, std::uint32_t width, std::uint32_t height,
              const std::vector<std::uint8_t>& rgba, const OutputOptions& output,
              std::string& error);

}  // namespace unilod::format
