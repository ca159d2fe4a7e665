// Per-block level selection of a whole .ulod file for a camera or a fixed h_lim, without Vulkan:
// what `unilod export` writes (and what the engine would draw for that view). Same conventions
// as the streaming engine (engine/scene.cpp; paper §3.4, Eq. 11; DESIGN.md "Screen-space
// error"): S = engine::blockDistance (nearest point of the block's bounding box, or its centre),
// h_lim = engine::blockTolerance (Eq. 11, with the frustum-edge factor in nearest mode), level =
// the coarsest stored level with h_s <= h_lim. With a view direction (yaw, pitch) the blocks
// outside the view frustum are left out, exactly as the engine culls them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

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
    // With a view direction: the engine's depth-based tolerance (engine/lod.h) and, unless
    // `cull` is off, its frustum culling. Without one: distance only, every block.
    bool hasDirection = false, cull = true;
    double yawDegrees = 0, pitchDegrees = 0;
    double pixels = 1.0;  // P
    // ... or one h_lim (metres) for every block.
    double hLim = 0;
    std::uint32_t metric = 0;  // format::kMetricMax / kMetricPaper; 0 = the file's default
};

struct BlockSelection {
    std::size_t index = 0;  // block index in the file (Reader::blocks())
    std::uint32_t col = 0, row = 0;
    double distance = 0;  // S (camera mode; 0 otherwise)
    engine::BoxView box;  // how the box lies in the view (camera with a direction; else BoxView{})
    double hLim = 0;
    engine::LevelChoice choice;
    std::uint32_t vertexCount = 0, triangles = 0, riverEdges = 0;  // of the chosen level
};

// The h_lim of a block for the options (camera: the engine's S and Eq. 11; else options.hLim).
// `rivers`: the block has river edges (engine/camera.h BoxView::horizontal).
double blockTolerance(const format::BlockInfo& info, const SelectionOptions& options, bool rivers,
                      double* distance = nullptr, engine::BoxView* box = nullptr);

// Camera mode with culling: false when the block's box is outside the view frustum.
bool blockVisible(const format::BlockInfo& info, const SelectionOptions& options);

// Chooses the level of one block already read.
BlockSelection selectLevel(const format::Block& block, std::size_t index,
                           const SelectionOptions& options, std::uint32_t metric);

// Checks the options against the file (metric present, numbers in range) and resolves the
// metric (0 -> the file's default). False with a message naming the file.
bool resolveMetric(const format::Reader& reader, const SelectionOptions& options,
                   std::uint32_t& metric, std::string& error);

}  // namespace unilod::exporter
