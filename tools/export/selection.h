// Per-block level selection of a whole .ulod file for a camera or a fixed h_lim: what `unilod
// export` writes, and what the engine draws for that view — both call the one cut of
// engine/lod/cut.h (paper §3.4, Eq. 11; DESIGN.md "Screen-space error"). This file only turns
// the export's options into its ViewSpec and checks them against the file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cut.h"
#include "lod.h"
#include "ulod.h"

namespace unilod::exporter {

struct SelectionOptions {
    // Either a camera (eye in world coordinates of the file's CRS, metres) ...
    bool useCamera = false;
    double eye[3] = {0, 0, 0};
    double fovDegrees = 60.0;  // vertical field of view
    double widthPixels = 1920.0, heightPixels = 1080.0;
    engine::DistanceMode distance = engine::DistanceMode::Nearest;
    // With a view direction: the engine's depth-based tolerance (engine/lod/lod.h) and, unless
    // `cull` is off, its frustum culling. Without one: distance only, every block.
    bool hasDirection = false, cull = true;
    double yawDegrees = 0, pitchDegrees = 0;
    double pixels = 1.0;  // P
    // ... or one h_lim (metres) for every block.
    double hLim = 0;
    std::uint32_t metric = 0;  // format::kMetricMax / kMetricPaper; 0 = the file's default
    // With a camera: leaves refined for the view from their records, as the engine draws them
    // (engine/scene.h SceneOptions::refine, engine/lod/refine.h).
    bool refine = true;
};

// The view of the options (engine/lod/cut.h): a camera (with or without a direction) or one
// h_lim for every block.
engine::ViewSpec viewSpec(const SelectionOptions& options);

// One exported block: the cut's choice and the counts of the chosen level.
struct ExportedBlock : engine::NodeChoice {
    std::uint32_t vertexCount = 0, triangles = 0, riverEdges = 0;
    bool refined = false;  // written refined (SelectionOptions::refine): the counts are its
    std::uint32_t stepsDone = 0;
};

// Chooses the level of one block already read.
ExportedBlock selectLevel(const format::Block& block, std::size_t index,
                          const SelectionOptions& options, std::uint32_t metric);

// Checks the options against the file (metric present, numbers in range) and resolves the
// metric (0 -> the file's default). False with a message naming the file.
bool resolveMetric(const format::Reader& reader, const SelectionOptions& options,
                   std::uint32_t& metric, std::string& error);

}  // namespace unilod::exporter
