// Streaming of .ulod blocks under a GPU memory budget (scene.h). One device-local buffer is the
// arena; a first-fit free list sub-allocates it by offset (the "few large buffers" of the
// issue, here one). A loader thread reads blocks with pread; the frame records the uploads.
#include "scene.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <set>
#include <thread>

#include "vkcheck.h"
#include "workers.h"

namespace unilod::engine {

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;
constexpr std::uint64_t kAlignment = 16;  // vertex stride, and a multiple of the index size
constexpr std::uint32_t kNoParent = 0xFFFFFFFFu;

std::uint64_t alignUp(std::uint64_t n) { return (n + kAlignment - 1) / kAlignment * kAlignment; }

// Makes the geometry copied into the arena visible to the vertex input of later draws.
void recordUploadBarrier(VkCommandBuffer cmd) {
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_INDEX_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_VERTEX_INPUT_BIT, 0,
                         1, &barrier, 0, nullptr, 0, nullptr);
}

// First fit over [0, size) with coalescing on release.
class RangeAllocator {
public:
    void reset(std::uint64_t size) {
        free_.clear();
        if (size > 0) free_[0] = size;
        used_ = 0;
    }
    bool allocate(std::uint64_t size, std::uint64_t& offset) {
        size = alignUp(size);
        for (auto it = free_.begin(); it != free_.end(); ++it) {
            if (it->second < size) continue;
            offset = it->first;
            const std::uint64_t rest = it->second - size;
            free_.erase(it);
            if (rest > 0) free_[offset + size] = rest;
            used_ += size;
            return true;
        }
        return false;
    }
    void release(std::uint64_t offset, std::uint64_t size) {
        size = alignUp(size);
        assert(used_ >= size);
        used_ -= size;
        auto next = free_.lower_bound(offset);
        if (next != free_.end() && offset + size == next->first) {
            size += next->second;
            next = free_.erase(next);
        }
        if (next != free_.begin()) {
            auto prev = std::prev(next);
            if (prev->first + prev->second == offset) {
                prev->second += size;
                return;
            }
        }
        free_[offset] = size;
    }
    std::uint64_t used() const { return used_; }

private:
    std::map<std::uint64_t, std::uint64_t> free_;
    std::uint64_t used_ = 0;
};

// Where a block's geometry lies in the arena: [vertices | terrain indices | river indices].
struct Allocation {
    std::uint64_t offset = 0, size = 0;
    std::uint64_t vertexBytes = 0, terrainBytes = 0;
    bool valid = false;
};

// Packed bytes of a block's geometry, ready for the staging buffer.
struct Packed {
    std::vector<unsigned char> bytes;
    std::uint64_t vertexBytes = 0, terrainBytes = 0;
};

// `g`: a format::BlockGeometry or a whole format::Block (the same three arrays).
template <typename G>
void pack(const G& g, std::uint64_t terrainTriangles, std::uint64_t riverEdges, Packed& out) {
    out.vertexBytes = g.vertices.size() * sizeof(format::Vertex);
    out.terrainBytes = terrainTriangles * sizeof(format::Triangle);
    const std::uint64_t riverBytes = riverEdges * sizeof(format::Edge);
    out.bytes.resize(out.vertexBytes + out.terrainBytes + riverBytes);
    unsigned char* p = out.bytes.data();
    if (out.vertexBytes) std::memcpy(p, g.vertices.data(), out.vertexBytes);
    if (out.terrainBytes) std::memcpy(p + out.vertexBytes, g.terrainIndices.data(), out.terrainBytes);
    if (riverBytes)
        std::memcpy(p + out.vertexBytes + out.terrainBytes, g.riverIndices.data(), riverBytes);
}

struct BlockState {
    format::BlockInfo info;
    double originX = 0, originY = 0;
    double boxMin[3] = {}, boxMax[3] = {};
    std::uint64_t terrainTriangles = 0, riverEdges = 0;  // index data the levels use
    std::uint64_t fullBytes = 0;
    // coarse: the last level only, always resident, for a root (an entry with no tree parent:
    // every block of a file without a tree); full: every level, streamed.
    Allocation coarse, full;
    // With `full`: the entry's deletion records for refinement (SceneOptions::refine; null for
    // an entry refine.h does not refine).
    std::shared_ptr<const Refinement> refinement;
    std::uint64_t refinementBytes = 0;   // its memoryBytes(), counted in Impl::refineBytes
    std::uint64_t lastRefinedFrame = 0;  // the last frame that drew it refined
    std::uint32_t parent = kNoParent;
    std::uint32_t treeLevel = 0;
    std::uint64_t lastUsedFrame = 0;
    std::uint64_t deniedEpoch = ~0ull;  // space epoch in which an upload did not fit
};

struct Loaded {
    std::uint32_t block = 0;
    Packed packed;
    std::shared_ptr<const Refinement> refinement;
    std::string error;
};

struct Release {
    std::int64_t afterFrame = 0;  // the memory is free once this frame has completed
    std::uint64_t offset = 0, size = 0;
};

struct Staging {
    Buffer buffer;
    DynamicIndices refined;  // the frame's refined index data (SceneOptions::refine)
};

}  // namespace

struct StreamingScene::Impl {
    const Device* device = nullptr;
    SceneOptions options;
    format::Reader reader;
    std::uint32_t metric = format::kMetricMax;
    std::vector<BlockState> blocks;
    std::vector<LodNode> nodes;  // per block: what the cut needs (lod/cut.h)
    std::vector<NodeChoice> cut;
    Buffer arena;
    RangeAllocator allocator;
    std::uint64_t budget = 0, coarseBytes = 0;
    std::uint64_t refineBytes = 0;  // held by the resident leaves' refinements
    Staging staging[kFramesInFlight];
    std::uint64_t stagingSize = 0;
    std::deque<Release> releases;
    std::uint64_t spaceEpoch = 0;
    std::vector<BlockSelection> selection;
    std::vector<DrawBlock> draws;
    std::vector<std::uint32_t> refinedWords;  // the last prepare()'s refined index data
    std::uint32_t slot = 0;                   // the last prepare()'s frame slot
    // Open, preload and each frame's refinements run on these (SceneOptions::threads).
    std::unique_ptr<WorkerPool> workers;
    // A frame's refinements: one task per entry drawn refined, in draw order.
    struct RefineTask {
        std::uint32_t selection = 0;  // index in `selection`
        std::uint32_t draw = 0;       // index in `draws`
        RefinedMesh mesh;
    };
    std::vector<RefineTask> refineTasks;  // [0, refineCount) this frame's; capacity kept
    std::size_t refineCount = 0;
    FrameStats stats;

    // Loader thread state, under `mutex`.
    std::mutex mutex;
    std::condition_variable wake;      // the loader waits for requests / room
    std::deque<std::uint32_t> queue;   // requested, nearest first
    std::int64_t loading = -1;         // the block being read
    std::uint64_t loaderBytesRead = 0;  // file bytes the loader has read (and decoded)
    double loaderSeconds = 0;           // its time reading, checking and decoding them
    std::vector<Loaded> ready;         // read, waiting for an upload
    bool stop = false;
    std::thread loader;
    static constexpr std::size_t kMaxReady = 2;

    // The arena's size for `options` (preloadAll: raised to every block), checked against one
    // buffer's addressing, the coarse set and the device's largest allocation.
    bool checkBudget(const Device& dev, const SceneOptions& o, std::uint64_t& size,
                     std::string& error) const {
        const std::string& path = reader.path();
        std::uint64_t wanted = o.gpuBudget;
        if (o.preloadAll) {
            std::uint64_t all = coarseBytes;
            for (const BlockState& b : blocks) all += alignUp(b.fullBytes);
            wanted = std::max(wanted, all);
        }
        if (wanted > kMaxGpuBudget) {
            char text[160];
            std::snprintf(text, sizeof text,
                          ": %s %.10g MiB is more than one buffer can address (%llu MiB)",
                          o.preloadAll ? "every block resident needs" : "--gpu-budget",
                          double(wanted) / 1048576.0, (unsigned long long)(kMaxGpuBudget >> 20));
            error = path + text;
            return false;
        }
        size = wanted / kAlignment * kAlignment;
        if (coarseBytes > size) {
            char text[200];
            std::snprintf(text, sizeof text,
                          ": --gpu-budget %.6g MiB is below the always-resident coarse levels "
                          "(%.2f MiB)",
                          double(o.gpuBudget) / 1048576.0, double(coarseBytes) / 1048576.0);
            error = path + text;
            return false;
        }
        // The arena must fit the device: checked first, so that a large --gpu-budget (or a model
        // too large to preload) is an error naming the option and the device's limit, not a
        // driver abort.
        const std::uint64_t deviceLimit =
            largestAllocation(dev, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
        if (size > deviceLimit) {
            char text[160];
            if (o.preloadAll)
                std::snprintf(text, sizeof text, ": every block resident needs %.2f MiB, more than ",
                              double(size) / 1048576.0);
            else
                std::snprintf(text, sizeof text, ": --gpu-budget %.10g MiB is more than ",
                              double(o.gpuBudget) / 1048576.0);
            error = path + text + "the Vulkan device '" + dev.properties.deviceName +
                    "' can allocate at once (" + std::to_string(deviceLimit >> 20) + " MiB)";
            return false;
        }
        return true;
    }

    // Reads, validates and packs an entry's full geometry (every level); with
    // SceneOptions::refine an entry is read whole and its records prepared for refinement
    // (refine.h; left null where it does not apply). Thread-safe (pread).
    bool readEntry(std::uint32_t index, Packed& packed,
                   std::shared_ptr<const Refinement>& refinement, std::string& error) const {
        const BlockState& b = blocks[index];
        const auto fits = [&](const auto& g) {
            if (g.terrainIndices.size() >= b.terrainTriangles &&
                g.riverIndices.size() >= b.riverEdges)
                return true;
            error = reader.path() + ": block arrays shorter than its levels";
            return false;
        };
        if (options.refine) {
            format::Block block;
            if (!reader.readBlock(index, block, error) || !fits(block)) return false;
            pack(block, b.terrainTriangles, b.riverEdges, packed);
            auto r = std::make_shared<Refinement>();
            std::string why;
            if (r->init(block, why)) refinement = std::move(r);
            return true;
        }
        format::BlockGeometry g;
        if (!reader.readGeometry(index, format::kAllLevels, g, error) || !fits(g)) return false;
        pack(g, b.terrainTriangles, b.riverEdges, packed);
        return true;
    }

    void loaderMain() {
        for (;;) {
            std::uint32_t index;
            {
                std::unique_lock lock(mutex);
                wake.wait(lock, [&] { return stop || (!queue.empty() && ready.size() < kMaxReady); });
                if (stop) return;
                index = queue.front();
                queue.pop_front();
                loading = index;
            }
            Loaded item;
            item.block = index;
            const auto t0 = std::chrono::steady_clock::now();
            try {
                readEntry(index, item.packed, item.refinement, item.error);
            } catch (const std::bad_alloc&) {
                // A memory limit (the entry's sizes are bounded by its bytes at open): the frame
                // that needs it fails with this message, as for a damaged entry.
                const format::BlockInfo& info = reader.blocks()[index];
                item.packed = Packed{};
                item.refinement.reset();
                item.error = reader.path() + ": " +
                             format::blockName(info.col, info.row, info.level) +
                             ": out of memory reading it";
            }
            const double seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            {
                std::lock_guard lock(mutex);
                loading = -1;
                loaderBytesRead += reader.blocks()[index].size;
                loaderSeconds += seconds;
                ready.push_back(std::move(item));
            }
        }
    }

    // Frees what completed frames no longer use.
    void releaseCompleted(std::int64_t completedFrame) {
        while (!releases.empty() && releases.front().afterFrame <= completedFrame) {
            allocator.release(releases.front().offset, releases.front().size);
            releases.pop_front();
            ++spaceEpoch;
        }
    }

    // Evicts the least recently used full block not drawn in `frame`. False if none.
    bool evictOne(std::uint64_t frame, std::int64_t completedFrame) {
        BlockState* victim = nullptr;
        for (BlockState& b : blocks)
            if (b.full.valid && b.lastUsedFrame < frame &&
                (!victim || b.lastUsedFrame < victim->lastUsedFrame))
                victim = &b;
        if (!victim) return false;
        // Frames up to lastUsedFrame may still read it.
        Release r{std::int64_t(victim->lastUsedFrame), victim->full.offset, victim->full.size};
        victim->full = Allocation{};
        dropRefinement(*victim);
        if (r.afterFrame <= completedFrame) {
            allocator.release(r.offset, r.size);
            ++spaceEpoch;
        } else {
            // Keep the list ordered by frame: evicted blocks were last used at most `frame - 1`.
            auto at = std::upper_bound(
                releases.begin(), releases.end(), r.afterFrame,
                [](std::int64_t f, const Release& x) { return f < x.afterFrame; });
            releases.insert(at, r);
        }
        ++stats.evictions;
        return true;
    }

    // Keeps an entry's refinement within SceneOptions::refineMemory: room is made by dropping
    // the refinements of the leaves drawn refined longest ago (not in `frame`); without room the
    // leaf keeps its stored levels (until its geometry is evicted and streamed again).
    void adoptRefinement(BlockState& b, std::shared_ptr<const Refinement> r, std::uint64_t frame) {
        if (!r) return;
        const std::uint64_t bytes = r->memoryBytes();
        while (refineBytes + bytes > options.refineMemory) {
            BlockState* victim = nullptr;
            for (BlockState& o : blocks)
                if (o.refinement && &o != &b && o.lastRefinedFrame < frame &&
                    (!victim || o.lastRefinedFrame < victim->lastRefinedFrame))
                    victim = &o;
            if (!victim) return;
            dropRefinement(*victim);
        }
        b.refinement = std::move(r);
        b.refinementBytes = bytes;
        refineBytes += bytes;
    }
    void dropRefinement(BlockState& b) {
        refineBytes -= b.refinementBytes;
        b.refinementBytes = 0;
        b.refinement.reset();
    }

    // Whether drawing `level` of `b` needs its full geometry: any level of an entry below the
    // root, a level finer than the coarse one of a root.
    static bool needsFull(const BlockState& b, std::size_t level) {
        return b.parent != kNoParent || level + 1 < b.info.levels.size();
    }
    // Whether some level of `b` can be drawn now.
    static bool drawable(const BlockState& b) { return b.full.valid || b.coarse.valid; }
    // The nearest entry above `index` that can be drawn now (a root always can).
    std::uint32_t drawableAncestor(std::uint32_t index) const {
        std::uint32_t a = blocks[index].parent;
        while (a != kNoParent && !drawable(blocks[a])) a = blocks[a].parent;
        return a;
    }

    bool allocate(std::uint64_t size, std::uint64_t frame, std::int64_t completedFrame,
                  std::uint64_t& offset) {
        for (;;) {
            if (allocator.allocate(size, offset)) return true;
            if (!evictOne(frame, completedFrame)) return false;
        }
    }
};

StreamingScene::StreamingScene() : impl_(std::make_unique<Impl>()) {}

StreamingScene::~StreamingScene() { assert(!impl_->device && "StreamingScene::close() first"); }

bool StreamingScene::open(const Device& device, const std::string& path,
                          const SceneOptions& options, std::string& error) {
    assert(!impl_->device && "StreamingScene::close() first");
    impl_ = std::make_unique<Impl>();  // a scene closed before opens with fresh state
    Impl& s = *impl_;
    s.options = options;
    if (!s.reader.open(path, error)) return false;
    s.workers = std::make_unique<WorkerPool>(options.threads);
    const format::Header& header = s.reader.header();
    std::uint32_t requested = 0;
    if (!format::metricOfName(options.metric, requested)) {
        error = "unknown metric '" + options.metric + "' (max or paper)";
        return false;
    }
    if (!format::resolveMetric(header, path, requested, s.metric, error)) return false;

    // Every entry's box, levels and outline flag come from the directory (format version 5); the
    // roots' coarse geometry is read now (readGeometry validates the whole block: checksum,
    // structure, every level's geometry, its levels against the directory), every other entry
    // when it is first streamed (a damaged one then fails the frame that wanted it, naming the
    // file and the block).
    std::vector<std::uint32_t> parent(s.reader.blocks().size(), kNoParent);
    for (std::size_t i = 0; i < parent.size(); ++i) {
        const format::BlockInfo& info = s.reader.blocks()[i];
        for (std::uint32_t c = 0; c < info.childCount; ++c)
            parent[info.firstChild + c] = std::uint32_t(i);  // links checked by the reader
    }
    const std::size_t blockCount = s.reader.blocks().size();
    std::vector<std::uint32_t> roots;
    for (std::uint32_t i = 0; i < blockCount; ++i)
        if (parent[i] == kNoParent) roots.push_back(i);
    // Read and validated in parallel, in batches so that the progress is reported from this
    // thread; the first failing root in file order is reported.
    std::vector<Packed> coarse(blockCount);
    std::vector<std::string> errors(roots.size());
    std::vector<char> failed(roots.size(), 0);
    constexpr std::size_t kOpenBatch = 64;
    if (options.openProgress) options.openProgress(0, roots.size());
    for (std::size_t from = 0; from < roots.size(); from += kOpenBatch) {
        const std::size_t count = std::min(kOpenBatch, roots.size() - from);
        s.workers->run(count, [&](std::size_t k) {
            const std::uint32_t i = roots[from + k];
            const int last = int(s.reader.blocks()[i].levelCount) - 1;
            format::BlockGeometry g;
            failed[from + k] = !s.reader.readGeometry(i, last, g, errors[from + k]);
            if (!failed[from + k])
                pack(g, g.terrainIndices.size(), g.riverIndices.size(), coarse[i]);
        });
        if (options.openProgress) options.openProgress(from + count, roots.size());
    }
    for (std::size_t k = 0; k < roots.size(); ++k)
        if (failed[k]) {
            error = std::move(errors[k]);
            return false;
        }
    std::uint64_t largest = 0;
    for (std::size_t i = 0; i < blockCount; ++i) {
        BlockState b;
        b.info = s.reader.blocks()[i];
        b.parent = parent[i];
        b.treeLevel = b.info.level;
        b.originX = b.info.originX;
        b.originY = b.info.originY;
        b.boxMin[0] = b.info.minX, b.boxMin[1] = b.info.minY, b.boxMin[2] = b.info.minZ;
        b.boxMax[0] = b.info.maxX, b.boxMax[1] = b.info.maxY, b.boxMax[2] = b.info.maxZ;
        for (const format::Level& l : b.info.levels) {
            b.terrainTriangles =
                std::max<std::uint64_t>(b.terrainTriangles, std::uint64_t(l.triangleFirst) + l.triangleCount);
            b.riverEdges = std::max<std::uint64_t>(b.riverEdges, std::uint64_t(l.riverFirst) + l.riverCount);
        }
        b.fullBytes = std::uint64_t(b.info.vertexCount) * sizeof(format::Vertex) +
                      b.terrainTriangles * sizeof(format::Triangle) +
                      b.riverEdges * sizeof(format::Edge);
        largest = std::max(largest, b.fullBytes);
        if (b.parent == kNoParent) s.coarseBytes += alignUp(coarse[i].bytes.size());
        s.blocks.push_back(std::move(b));
    }
    if (s.blocks.empty()) {
        error = path + ": no blocks to draw";
        return false;
    }
    // What the cut needs, once s.blocks no longer moves.
    for (const BlockState& b : s.blocks)
        s.nodes.push_back(lodNode(b.info));
    if (!s.checkBudget(device, options, s.budget, error)) return false;
    s.device = &device;
    if (!tryCreateBuffer(device, s.budget,
                         VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_INDEX_BUFFER_BIT |
                             VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                         VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, s.arena, error)) {
        error = path + ": --gpu-budget: " + error;
        close();
        return false;
    }
    s.allocator.reset(s.budget);
    s.stagingSize = std::max({options.uploadBytesPerFrame, largest, s.coarseBytes});
    for (Staging& st : s.staging) {
        if (!tryCreateBuffer(device, s.stagingSize, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                             VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                 VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                             st.buffer, error)) {
            error = path + ": staging for the coarse levels and the largest block: " + error;
            close();
            return false;
        }
    }
    // The coarse set, in one transfer through the first staging buffer.
    std::vector<VkBufferCopy> copies;
    std::uint64_t at = 0;
    for (std::size_t i = 0; i < s.blocks.size(); ++i) {
        BlockState& b = s.blocks[i];
        if (b.parent != kNoParent) continue;  // streamed whole (Impl::resident)
        const Packed& p = coarse[i];
        std::uint64_t offset = 0;
        const bool ok = s.allocator.allocate(p.bytes.size(), offset);
        assert(ok);
        (void)ok;
        b.coarse = {offset, p.bytes.size(), p.vertexBytes, p.terrainBytes, true};
        if (p.bytes.empty()) continue;
        std::memcpy(static_cast<unsigned char*>(s.staging[0].buffer.mapped) + at, p.bytes.data(),
                    p.bytes.size());
        copies.push_back({at, offset, p.bytes.size()});
        at += alignUp(p.bytes.size());
    }
    submitAndWait(device, [&](VkCommandBuffer cmd) {
        vkCmdCopyBuffer(cmd, s.staging[0].buffer.buffer, s.arena.buffer,
                        std::uint32_t(copies.size()), copies.data());
        recordUploadBarrier(cmd);
    });
    if (options.preloadAll) {
        // Read, validated and packed in parallel, a batch of blocks at a time (bounded host
        // memory); uploaded block by block, in file order, through the first staging buffer (it
        // holds the largest block).
        std::vector<std::uint32_t> todo;
        for (std::uint32_t i = 0; i < s.blocks.size(); ++i)
            if (!(s.blocks[i].parent == kNoParent && s.blocks[i].info.levels.size() < 2))
                todo.push_back(i);  // not a root whose coarse level is all there is
        constexpr std::size_t kBatch = 32;
        std::vector<Packed> packed(kBatch);
        std::vector<std::shared_ptr<const Refinement>> refinements(kBatch);
        std::vector<std::string> batchErrors(kBatch);
        std::vector<char> batchFailed(kBatch);
        for (std::size_t from = 0; from < todo.size(); from += kBatch) {
            const std::size_t count = std::min(kBatch, todo.size() - from);
            s.workers->run(count, [&](std::size_t k) {
                refinements[k].reset();
                batchFailed[k] =
                    !s.readEntry(todo[from + k], packed[k], refinements[k], batchErrors[k]);
            });
            for (std::size_t k = 0; k < count; ++k) {
                if (batchFailed[k]) {
                    error = std::move(batchErrors[k]);
                    close();
                    return false;
                }
                BlockState& b = s.blocks[todo[from + k]];
                const Packed p = std::move(packed[k]);
                std::uint64_t offset = 0;
                const bool fits = s.allocator.allocate(p.bytes.size(), offset);
                assert(fits);
                (void)fits;
                b.full = {offset, p.bytes.size(), p.vertexBytes, p.terrainBytes, true};
                s.adoptRefinement(b, std::move(refinements[k]), 0);
                std::memcpy(s.staging[0].buffer.mapped, p.bytes.data(), p.bytes.size());
                submitAndWait(device, [&](VkCommandBuffer cmd) {
                    const VkBufferCopy copy{0, offset, p.bytes.size()};
                    vkCmdCopyBuffer(cmd, s.staging[0].buffer.buffer, s.arena.buffer, 1, &copy);
                    recordUploadBarrier(cmd);
                });
            }
        }
    }
    s.stats.blocks = std::uint32_t(s.blocks.size());
    s.stats.gpuBudget = s.budget;
    s.stats.coarseBytes = s.coarseBytes;
    s.stats.gpuBytesUsed = s.allocator.used();
    s.loader = std::thread([&s] { s.loaderMain(); });
    return true;
}

bool StreamingScene::preloadFits(std::string& why) const {
    const Impl& s = *impl_;
    assert(s.device);
    SceneOptions o = s.options;
    o.preloadAll = true;
    std::uint64_t size = 0;
    return s.checkBudget(*s.device, o, size, why);
}

void StreamingScene::close() {
    Impl& s = *impl_;
    if (s.loader.joinable()) {
        {
            std::lock_guard lock(s.mutex);
            s.stop = true;
        }
        s.wake.notify_all();
        s.loader.join();
    }
    s.workers.reset();
    if (!s.device) return;
    for (Staging& st : s.staging) {
        destroyBuffer(*s.device, st.buffer);
        st.refined.destroy(*s.device);
    }
    destroyBuffer(*s.device, s.arena);
    s.device = nullptr;
}

bool StreamingScene::prepare(VkCommandBuffer cmd, std::uint64_t frame, std::int64_t completedFrame,
                             const FrameView& view, std::string& error) {
    Impl& s = *impl_;
    assert(s.device);
    assert(std::int64_t(frame) - completedFrame <= std::int64_t(kFramesInFlight) &&
           "wait for frame - kFramesInFlight before prepare()");
    FrameStats& st = s.stats;
    st.frame = frame;
    st.bytesUploaded = 0;
    st.evictions = 0;
    s.releaseCompleted(completedFrame);

    // 1. The cut: culling and the level each visible block asks for, nearest first (uploads
    // and requests go in this order).
    ViewSpec spec;
    spec.kind = view.grid ? ViewSpec::Kind::Grid : ViewSpec::Kind::Camera;
    spec.camera = view.camera;
    spec.cull = s.options.cull;
    spec.widthPixels = double(view.width);
    spec.heightPixels = double(view.height);
    spec.pixels = s.options.pixels;
    spec.distance = s.options.distance;
    spec.gridHalfHeight = view.gridHalfHeight;
    spec.finest = s.options.policy == LodPolicy::Finest;
    selectCut(spec, s.nodes, s.metric, s.cut);
    s.selection.clear();
    for (const NodeChoice& c : s.cut) {
        BlockSelection sel;
        static_cast<NodeChoice&>(sel) = c;
        s.selection.push_back(sel);
    }
    for (const BlockSelection& sel : s.selection) {
        BlockState& b = s.blocks[sel.block];
        if (!s.needsFull(b, sel.wanted.level)) continue;
        b.lastUsedFrame = frame;
        // Not resident: the entry above it that may be drawn in its place is kept too.
        if (!b.full.valid && b.parent != kNoParent) {
            const std::uint32_t a = s.drawableAncestor(sel.block);
            if (a != kNoParent) s.blocks[a].lastUsedFrame = frame;
        }
    }

    // 2. Uploads of what the loader has read, as far as the staging buffer and budget allow.
    std::vector<Loaded> loaded;
    {
        std::lock_guard lock(s.mutex);
        loaded.swap(s.ready);
    }
    s.wake.notify_all();
    std::vector<VkBufferCopy> copies;
    std::uint64_t stagingAt = 0;
    unsigned char* stagingBytes =
        static_cast<unsigned char*>(s.staging[frame % kFramesInFlight].buffer.mapped);
    bool ok = true;
    for (Loaded& item : loaded) {
        BlockState& b = s.blocks[item.block];
        if (!item.error.empty()) {
            if (ok) error = item.error;
            ok = false;
            b.deniedEpoch = ~0ull - 1;  // never again in this session
            continue;
        }
        if (b.full.valid) continue;
        const std::uint64_t size = item.packed.bytes.size();
        if (stagingAt + alignUp(size) > s.stagingSize) {
            // No room in this frame's staging: keep it for the next frame.
            std::lock_guard lock(s.mutex);
            s.ready.push_back(std::move(item));
            continue;
        }
        std::uint64_t offset = 0;
        if (!s.allocate(size, frame, completedFrame, offset)) {
            b.deniedEpoch = s.spaceEpoch;  // retried once memory is released
            continue;
        }
        b.full = {offset, size, item.packed.vertexBytes, item.packed.terrainBytes, true};
        s.adoptRefinement(b, std::move(item.refinement), frame);
        std::memcpy(stagingBytes + stagingAt, item.packed.bytes.data(), size);
        copies.push_back({stagingAt, offset, size});
        stagingAt += alignUp(size);
        st.bytesUploaded += size;
    }
    if (!copies.empty()) {
        vkCmdCopyBuffer(cmd, s.staging[frame % kFramesInFlight].buffer.buffer, s.arena.buffer,
                        std::uint32_t(copies.size()), copies.data());
        recordUploadBarrier(cmd);
    }

    // 3. What is drawn: the wanted level where resident. Else, for a root, its coarse level;
    // below the root, the nearest entry above it that is resident (the root's coarse level at
    // worst) is drawn ONCE in place of every cut entry below it, at its finest resident level,
    // so the frame never shows a hole or draws an area twice. Requests: the entry and the
    // entries between it and what is drawn for it, coarsest first.
    s.draws.clear();
    s.refinedWords.clear();
    s.refineCount = 0;
    st.visibleBlocks = std::uint32_t(s.selection.size());
    st.fallbackBlocks = 0;
    st.refinedBlocks = 0;
    st.refineMs = 0;
    st.triangles = st.riverEdges = 0;
    std::vector<std::uint32_t> requests;
    auto requestable = [&](const BlockState& b) {
        return b.deniedEpoch != s.spaceEpoch && b.deniedEpoch != ~0ull - 1;
    };
    std::vector<char> inPlace(s.blocks.size(), 0);  // drawn in place of entries below it
    for (BlockSelection& sel : s.selection) {
        const BlockState& b = s.blocks[sel.block];
        sel.drawnBlock = sel.block;
        if (!s.needsFull(b, sel.wanted.level) || b.full.valid) continue;
        sel.fallback = true;
        ++st.fallbackBlocks;
        if (requestable(b)) requests.push_back(sel.block);
        if (b.parent == kNoParent) continue;  // its own coarse level
        const std::uint32_t a = s.drawableAncestor(sel.block);
        assert(a != kNoParent && "a root's coarse level is always resident");
        for (std::uint32_t up = b.parent; up != a; up = s.blocks[up].parent)
            if (requestable(s.blocks[up])) requests.push_back(up);
        inPlace[a] = 1;
    }
    // The topmost entry drawn in place covers every cut entry below it.
    auto coveringEntry = [&](std::uint32_t index) {
        std::uint32_t cover = kNoParent;
        for (std::uint32_t up = s.blocks[index].parent; up != kNoParent; up = s.blocks[up].parent)
            if (inPlace[up]) cover = up;
        return cover;
    };
    auto addDraw = [&](const BlockState& b, bool full, std::size_t level) {
        const Allocation* alloc = full ? &b.full : &b.coarse;
        const format::Level& l = b.info.levels[level];
        // The coarse allocation holds only its level, rebased to 0.
        const std::uint64_t triangleFirst = full ? l.triangleFirst : 0;
        const std::uint64_t riverFirst = full ? l.riverFirst : 0;
        DrawBlock d;
        d.originX = b.originX;
        d.originY = b.originY;
        d.vertexOffset = alloc->offset;
        d.terrainFirst = std::uint32_t((alloc->offset + alloc->vertexBytes) / 4 + triangleFirst * 3);
        d.terrainCount = l.triangleCount * 3;
        d.riverFirst = std::uint32_t(
            (alloc->offset + alloc->vertexBytes + alloc->terrainBytes) / 4 + riverFirst * 2);
        d.riverCount = l.riverCount * 2;
        st.triangles += l.triangleCount;
        st.riverEdges += l.riverCount;
        s.draws.push_back(d);
    };
    std::vector<char> drawnInPlace(s.blocks.size(), 0);
    for (BlockSelection& sel : s.selection) {
        const std::uint32_t cover = coveringEntry(sel.block);
        if (cover != kNoParent) {
            // Drawn through the entry above it: its finest resident level.
            const BlockState& c = s.blocks[cover];
            const std::size_t level = c.full.valid ? 0 : c.info.levels.size() - 1;
            if (!sel.fallback) {
                sel.fallback = true;
                ++st.fallbackBlocks;
            }
            sel.drawnBlock = cover;
            sel.drawnLevel = level;
            sel.triangles = sel.riverEdges = 0;  // counted once, with the entry drawn
            if (!drawnInPlace[cover]) {
                drawnInPlace[cover] = 1;
                addDraw(c, c.full.valid, level);
            }
            continue;
        }
        BlockState& b = s.blocks[sel.block];
        // Resident as wanted, or a root at its coarse level (wanted, or a fallback).
        const bool full = s.needsFull(b, sel.wanted.level) && b.full.valid;
        sel.drawnLevel = full ? sel.wanted.level : b.info.levels.size() - 1;
        if (full && b.refinement && s.options.refine && !spec.finest &&
            sel.wanted.step < b.info.stepCount) {
            // Refined for the view: the records' steps whose own error fits their own box's
            // tolerance, instead of the stored level (refine.h), from that level's step on (a
            // level at the last step is drawn as it is: nothing is left to take). The draw's
            // index data is filled in below, once the frame's refinements have run in parallel.
            if (s.refineTasks.size() <= s.refineCount) s.refineTasks.emplace_back();
            Impl::RefineTask& task = s.refineTasks[s.refineCount++];
            task.selection = std::uint32_t(&sel - s.selection.data());
            task.draw = std::uint32_t(s.draws.size());
            b.lastRefinedFrame = frame;
            DrawBlock d;
            d.originX = b.originX;
            d.originY = b.originY;
            d.vertexOffset = b.full.offset;
            d.dynamic = true;
            s.draws.push_back(d);
            continue;
        }
        const format::Level& l = b.info.levels[sel.drawnLevel];
        sel.triangles = l.triangleCount;
        sel.riverEdges = l.riverCount;
        addDraw(b, full, sel.drawnLevel);
    }
    // The refinements: each entry's on its own (Refinement::refine is const and its scratch is
    // the task's), in parallel; their index data then goes out in draw order, so the frame is the
    // same for any number of threads.
    if (s.refineCount > 0) {
        const auto t0 = std::chrono::steady_clock::now();
        s.workers->run(s.refineCount, [&](std::size_t k) {
            Impl::RefineTask& task = s.refineTasks[k];
            const BlockSelection& sel = s.selection[task.selection];
            s.blocks[sel.block].refinement->refine(spec, task.mesh, sel.wanted.step);
        });
        st.refineMs =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        for (std::size_t k = 0; k < s.refineCount; ++k) {
            const Impl::RefineTask& task = s.refineTasks[k];
            BlockSelection& sel = s.selection[task.selection];
            DrawBlock& d = s.draws[task.draw];
            d.terrainFirst = std::uint32_t(s.refinedWords.size());
            d.terrainCount = std::uint32_t(task.mesh.triangles.size() * 3);
            for (const format::Triangle& t : task.mesh.triangles)
                s.refinedWords.insert(s.refinedWords.end(), {t.a, t.b, t.c});
            d.riverFirst = std::uint32_t(s.refinedWords.size());
            d.riverCount = std::uint32_t(task.mesh.riverEdges.size() * 2);
            for (const format::Edge& e : task.mesh.riverEdges)
                s.refinedWords.insert(s.refinedWords.end(), {e.a, e.b});
            sel.refined = true;
            sel.stepsDone = task.mesh.stepsDone;
            sel.triangles = std::uint32_t(task.mesh.triangles.size());
            sel.riverEdges = std::uint32_t(task.mesh.riverEdges.size());
            st.triangles += sel.triangles;
            st.riverEdges += sel.riverEdges;
            ++st.refinedBlocks;
        }
    }
    // The refined index data goes to this frame's slot (its previous frame has completed).
    s.slot = std::uint32_t(frame % kFramesInFlight);
    s.staging[s.slot].refined.write(*s.device, s.refinedWords);
    // Coarsest first (nearest first within a tree level), each once.
    std::stable_sort(requests.begin(), requests.end(), [&](std::uint32_t x, std::uint32_t y) {
        return s.blocks[x].treeLevel > s.blocks[y].treeLevel;
    });
    {
        std::vector<char> seen(s.blocks.size(), 0);
        std::size_t kept = 0;
        for (std::uint32_t i : requests)
            if (!seen[i]) seen[i] = 1, requests[kept++] = i;
        requests.resize(kept);
    }

    // 4. Requests, nearest first, replacing those of the previous frame.
    {
        std::lock_guard lock(s.mutex);
        s.queue.clear();
        for (std::uint32_t i : requests) {
            if (std::int64_t(i) == s.loading) continue;
            if (std::any_of(s.ready.begin(), s.ready.end(),
                            [i](const Loaded& l) { return l.block == i; }))
                continue;
            s.queue.push_back(i);
        }
        st.loadsPending = std::uint32_t(s.queue.size() + s.ready.size() + (s.loading >= 0));
        st.loaderBytesRead = s.loaderBytesRead;
        st.loaderSeconds = s.loaderSeconds;
    }
    s.wake.notify_all();
    st.residentBlocks = 0;
    for (const BlockState& b : s.blocks) st.residentBlocks += b.full.valid;
    st.refineBytes = s.refineBytes;
    st.gpuBytesUsed = s.allocator.used();
    return ok;
}

void StreamingScene::draw(VkCommandBuffer cmd, const Pipelines& pipelines,
                          const FrameView& view) const {
    recordDraws(cmd, pipelines, impl_->arena.buffer, view, impl_->draws,
                impl_->staging[impl_->slot].refined.buffer.buffer);
}

const std::vector<DrawBlock>& StreamingScene::drawList() const { return impl_->draws; }
const std::vector<std::uint32_t>& StreamingScene::refinedIndices() const {
    return impl_->refinedWords;
}
VkBuffer StreamingScene::geometryBuffer() const { return impl_->arena.buffer; }

bool StreamingScene::settled() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->queue.empty() && impl_->loading < 0 && impl_->ready.empty();
}

void StreamingScene::setPixels(double pixels) {
    assert(pixels > 0);
    impl_->options.pixels = pixels;
}

const FrameStats& StreamingScene::stats() const { return impl_->stats; }
const std::vector<BlockSelection>& StreamingScene::selection() const { return impl_->selection; }
const format::Header& StreamingScene::header() const { return impl_->reader.header(); }
std::uint32_t StreamingScene::metric() const { return impl_->metric; }
const std::vector<format::Level>& StreamingScene::levels(std::size_t index) const {
    return impl_->blocks[index].info.levels;
}
const format::BlockInfo& StreamingScene::blockInfo(std::size_t index) const {
    return impl_->blocks[index].info;
}

}  // namespace unilod::engine
