// The streamed scene (DESIGN.md "Engine", issue 5): the blocks of a .ulod file in one device
// buffer under a memory budget, and the per-frame choice of what to draw.
//
// - At open, every entry's levels come from the file's directory and level table (format
//   version 5), and the coarsest level of every root (an entry with no tree parent: the tree's
//   root, or every block of a file without a tree) is read, uploaded and stays resident, so no
//   area ever disappears; the budget must hold this coarse set. Entries below the root are read
//   when first streamed, whole (every level).
// - Every frame, prepare() culls the blocks against the view, computes S and h_lim per visible
//   block and picks the coarsest level with h_s <= h_lim (lod/cut.h selectCut). A block whose chosen level is
//   finer than its resident coarse level needs its full LOD geometry (all levels' index data):
//   it is requested from a loader thread, coarsest tree level first, nearest first within one.
//   Loaded blocks are uploaded by the frame's command buffer through a staging buffer (at most
//   `uploadBytesPerFrame` per frame). Until a block is resident ("fallback") a root is drawn at
//   its coarse level, an entry below the root through the nearest resident tree node above it
//   (drawn once in place of every cut entry below that node, at its finest level): a frame
//   never waits on disk and never shows a hole.
// - Memory: one device-local buffer of `gpuBudget` bytes, sub-allocated by offset (first fit).
//   When an upload does not fit, the least recently used full blocks not drawn in this frame
//   are evicted; their memory returns to the allocator only once the frames that drew them have
//   completed (per-frame destroy lists).
//
// Frame numbers are the caller's: frame f uses staging slot f % kFramesInFlight, so the caller
// must have waited for frame f - kFramesInFlight to complete before prepare(f).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "cut.h"
#include "device.h"
#include "lod.h"
#include "refine.h"
#include "renderer.h"
#include "ulod.h"

namespace unilod::engine {

inline constexpr std::uint32_t kFramesInFlight = 2;
inline constexpr std::uint64_t kDefaultGpuBudget = 512ull << 20;  // 512 MiB
// The largest budget: indices are addressed in uint32 units from the start of one buffer.
inline constexpr std::uint64_t kMaxGpuBudget = 16ull << 30;  // 16 GiB

enum class LodPolicy {
    Adaptive,  // the coarsest level with h_s <= h_lim (the product)
    Finest,    // every visible block at full resolution (the benchmark's baseline)
};

struct SceneOptions {
    std::uint64_t gpuBudget = kDefaultGpuBudget;  // bytes of device memory for geometry
    std::uint64_t uploadBytesPerFrame = 32ull << 20;  // staging size per frame in flight
    double pixels = 1.0;                              // P
    std::string metric;                               // "max", "paper"; empty: the file's
    DistanceMode distance = DistanceMode::Nearest;
    LodPolicy policy = LodPolicy::Adaptive;
    bool cull = true;  // frustum culling (off: every block is drawn)
    // Selective refinement (lod/refine.h): an entry (leaf or tree node) drawn from its full
    // geometry is drawn as its deletion records refined for the view (every step whose error
    // fits the tolerance of its own box) instead of its stored level; each frame's refined index
    // data is uploaded with the frame. Off: stored levels only (the paper's per-entry levels).
    // An entry that cannot be refined (refine.h) keeps its stored level.
    bool refine = true;
    // Host memory the resident entries' refinement tables may hold (about 240 bytes per vertex:
    // 0.9 MiB for a 64-cell leaf, 8-16 MiB for a 256-cell one); beyond it the entries drawn
    // refined longest ago lose theirs (lod/refine.h Refinement::memoryBytes).
    std::uint64_t refineMemory = 256ull << 20;
    // Threads that read the entries at open (and preload) and refine a frame's entries, the
    // calling thread included (engine/workers.h); 0: every core, at most 16. The frame is the
    // same for any count.
    std::size_t threads = 0;
    // Everything resident: open() also uploads every block's full LOD geometry (the budget
    // is raised to what that needs) and nothing is streamed: the benchmark's baseline.
    bool preloadAll = false;
    // open() reads and validates every root of the file (every block of a file without a tree:
    // seconds for a large one): called from the calling thread with (0, roots) first, then after
    // each batch of roots.
    std::function<void(std::size_t done, std::size_t total)> openProgress;
};

// One visible block's choice in the last prepared frame: the cut's choice (lod/cut.h) and what
// was drawn.
struct BlockSelection : NodeChoice {
    // The entry drawn for it: itself, or (a fallback below the root) the nearest resident tree
    // node above it, drawn once in place of every cut entry below it (its triangles and river
    // edges are then counted in FrameStats, 0 here).
    std::uint32_t drawnBlock = 0;
    std::size_t drawnLevel = 0;     // the level drawn of drawnBlock
    bool fallback = false;          // drawn coarser than wanted: not resident yet
    // Drawn as its deletion records refined for the view (SceneOptions::refine) instead of
    // drawnLevel; stepsDone: the steps of its records the refinement took.
    bool refined = false;
    std::uint32_t stepsDone = 0;
    std::uint32_t triangles = 0, riverEdges = 0;
};

struct FrameStats {
    std::uint64_t frame = 0;
    std::uint32_t blocks = 0;          // in the file
    std::uint32_t visibleBlocks = 0;   // after culling
    std::uint32_t residentBlocks = 0;  // full LOD geometry on the GPU
    std::uint32_t fallbackBlocks = 0;  // visible, drawn coarser than wanted
    std::uint32_t refinedBlocks = 0;   // drawn refined (SceneOptions::refine)
    double refineMs = 0;               // wall time of this frame's refinements (in parallel)
    std::uint64_t refineBytes = 0;     // host memory of the resident refinements
    std::uint64_t triangles = 0, riverEdges = 0;
    std::uint64_t bytesUploaded = 0;   // this frame
    std::uint64_t gpuBytesUsed = 0;    // allocated in the budget (incl. memory awaiting release)
    std::uint64_t gpuBudget = 0;
    std::uint64_t coarseBytes = 0;     // the always-resident coarse levels
    std::uint32_t loadsPending = 0;    // requested or loaded, not yet uploaded
    std::uint32_t evictions = 0;       // this frame
    // Since open, on the loader thread (the render thread never reads or decodes a block): the
    // file bytes of the blocks read and the seconds spent reading, checking and decoding them.
    std::uint64_t loaderBytesRead = 0;
    double loaderSeconds = 0;
};

class StreamingScene {
public:
    StreamingScene();
    ~StreamingScene();  // close() must have been called (needs the device)
    StreamingScene(const StreamingScene&) = delete;
    StreamingScene& operator=(const StreamingScene&) = delete;

    // Opens the file (header, directory, level table), reads and validates every root
    // (format::Reader::readGeometry: checksum, structure, level geometry; with preloadAll every
    // entry), uploads the coarse set (blocking: startup). False with a message naming the file
    // (unreadable, a root that fails validation, named, no geometry, budget below the coarse
    // set, unknown metric). An entry below the roots that fails validation when it is streamed
    // fails that frame's prepare() (below).
    bool open(const Device& device, const std::string& path, const SceneOptions& options,
              std::string& error);
    // Stops the loader and frees the GPU memory. The device must be idle. A closed scene can be
    // opened again: open() starts from fresh state.
    void close();
    // After open(): whether this file opened with preloadAll on the same device would pass
    // open()'s budget checks (one buffer holding every block); false with open()'s message. The
    // benchmark asks before its first run.
    bool preloadFits(std::string& why) const;

    // Outside a render pass, once per frame: releases the memory of frames <= completedFrame
    // (-1: none yet), chooses the levels for `view`, queues loads, and records into `cmd` the
    // uploads of blocks the loader has finished. A data error on the loader thread (a block
    // that changed on disk since open) is reported here once: false with a message; the block
    // then stays coarse, it is never drawn from unvalidated data.
    bool prepare(VkCommandBuffer cmd, std::uint64_t frame, std::int64_t completedFrame,
                 const FrameView& view, std::string& error);
    // Inside the render pass: draws the selection of the last prepare().
    void draw(VkCommandBuffer cmd, const Pipelines& pipelines, const FrameView& view) const;
    // The draw list of the last prepare() and the buffer it refers to (the benchmark replays
    // it in a bare pipeline).
    const std::vector<DrawBlock>& drawList() const;
    VkBuffer geometryBuffer() const;
    // The index data of the list's `dynamic` draws (refined blocks), from its start.
    const std::vector<std::uint32_t>& refinedIndices() const;

    // True when no load is queued, in flight or waiting for upload: the selection of the last
    // prepare() is then final for its view (captures wait for this, frames do not).
    bool settled() const;

    // Changes P for the following prepare() calls (the viewer's +/- keys).
    void setPixels(double pixels);

    const FrameStats& stats() const;
    const std::vector<BlockSelection>& selection() const;
    const format::Header& header() const;
    std::uint32_t metric() const;  // format::kMetricMax or kMetricPaper
    // Level table of block `index` (as in the file).
    const std::vector<format::Level>& levels(std::size_t index) const;
    const format::BlockInfo& blockInfo(std::size_t index) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace unilod::engine
