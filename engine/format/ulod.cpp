// .ulod reader and writer. The byte layout (every field, offset, alignment and checksum) is
// described in README.md beside this file; the on-disk structs below are its source of truth and
// each has a static_assert on its size so that the two cannot drift apart silently.
//
// The reader treats the file as hostile: every count is checked against the byte range it must fit
// in before anything is allocated, all size arithmetic is done in 64 bits on values bounded by the
// (real) file size, and nothing is read outside the ranges the directory declares.
#include "ulod.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <set>
#include <tuple>
#include <utility>

#include "blockarrays.h"
#include "blockcodec.h"
#include "predicates.h"

namespace unilod::format {

// v1 is defined as little-endian and written by copying the in-memory structs; a big-endian port
// would need byte swapping on every field (and a test on such a host).
static_assert(std::endian::native == std::endian::little, ".ulod v1 needs a little-endian host");

namespace {

constexpr std::uint64_t kAlign = 8;  // every array and every block starts 8-byte aligned

// The fixed part of the file header, at offset 0.
struct FileHeader {
    char magic[8];
    std::uint32_t version;
    std::uint32_t headerSize;  // sizeof(FileHeader)
    std::uint64_t fileSize;    // total file size in bytes
    double originX, originY;
    double minX, minY, minZ, maxX, maxY, maxZ;
    double blockWidth, blockHeight;
    std::uint32_t blocksX, blocksY;
    std::uint32_t metrics, defaultMetric;
    std::uint32_t blockCount;
    std::uint32_t crsWktSize;
    std::uint32_t buildInfoSize;
    std::uint32_t levelTableCrc;  // CRC-32 of the level table's bytes (padding included)
    double zQuantum;              // vertex heights are multiples of it
    std::uint64_t levelTableOffset;  // the level table: after the last block, to fileSize
};
static_assert(sizeof(FileHeader) == 152);
static_assert(offsetof(FileHeader, fileSize) == 16);
static_assert(offsetof(FileHeader, blocksX) == 104);
static_assert(offsetof(FileHeader, levelTableCrc) == 132);
static_assert(offsetof(FileHeader, levelTableOffset) == 144);

// One block directory entry (BlockInfo on disk).
struct DirEntry {
    std::uint32_t col, row;
    double minX, minY, minZ, maxX, maxY, maxZ;
    std::uint64_t offset, size;
    std::uint32_t checksum;
    std::uint32_t vertexCount, stepCount, levelCount;
    std::uint32_t fullTriangles;
    std::uint16_t level, childCount;  // tree links (Block)
    std::uint32_t firstChild;
    std::uint32_t encoding;  // BlockEncoding, as in the block header
    double originX, originY;  // as in the block header
    std::uint32_t flags;      // kEntryOutlineMoves
    std::uint32_t reserved;   // 0
};
static_assert(sizeof(DirEntry) == 128);
static_assert(offsetof(DirEntry, originX) == 104);
static_assert(offsetof(DirEntry, offset) == 56);
static_assert(offsetof(DirEntry, checksum) == 72);

// DirEntry::flags: the block's outline may move between its levels (ulod.h outlineMoves).
constexpr std::uint32_t kEntryOutlineMoves = 1;

// Written after the directory: the CRC-32 of every byte before it.
struct HeaderTrailer {
    std::uint32_t crc;
    std::uint32_t reserved;  // 0
};
static_assert(sizeof(HeaderTrailer) == 8);

// The fixed header at the start of every block: position, bounds and the count of every array.
struct BlockHeader {
    std::uint32_t col, row;
    double originX, originY;
    double minX, minY, minZ, maxX, maxY, maxZ;
    std::uint32_t vertexCount;
    std::uint32_t stepCount;
    std::uint32_t removedTriangleOffsetCount, addedTriangleOffsetCount;
    std::uint32_t removedEdgeOffsetCount, addedEdgeOffsetCount;
    std::uint32_t removedTriangleCount, addedTriangleCount;
    std::uint32_t removedEdgeCount, addedEdgeCount;
    std::uint32_t errorMaxCount, errorPaperCount;
    std::uint32_t errorRiverCount;
    std::uint32_t levelCount;
    std::uint32_t terrainTriangleCount;
    std::uint32_t riverEdgeCount;
    std::uint32_t gridCount;
    std::uint32_t encoding;     // BlockEncoding
    std::uint32_t payloadSize;  // compact: the encoded bytes after this header; raw: 0
    std::uint32_t reserved;     // 0
};
static_assert(sizeof(BlockHeader) == kBlockHeaderBytes);
static_assert(offsetof(BlockHeader, payloadSize) == kBlockPayloadSizeOffset);
static_assert(offsetof(BlockHeader, vertexCount) == 72);
static_assert(offsetof(BlockHeader, gridCount) == 136);

constexpr std::uint64_t alignUp(std::uint64_t n) {
    return (n + kAlign - 1) / kAlign * kAlign;
}

// The grid of tree level L: the block grid halved L times, rounding up.
std::uint32_t levelGridSize(std::uint32_t blocks, std::uint32_t level) {
    return std::uint32_t((std::uint64_t(blocks) + (std::uint64_t(1) << level) - 1) >> level);
}

// The tree links of a whole directory (issue 18): a leaf (level 0) has no children; a node of
// level L > 0 has 1 to 4 children, the entries [firstChild, firstChild + childCount) before it,
// each of level L - 1, at its position halved and inside its box; every entry is the child of at
// most one node. Positions inside their level's grid and unique per level.
bool treeValid(const Header& h, const std::vector<DirEntry>& dir, std::string& error) {
    std::set<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>> seen;
    std::vector<std::uint8_t> hasParent(dir.size(), 0);
    for (std::size_t i = 0; i < dir.size(); ++i) {
        const DirEntry& e = dir[i];
        const std::string name =
            "directory entry " + std::to_string(i) + " (" + blockName(e.col, e.row, e.level) + ")";
        if (e.level > kMaxTreeLevel) {
            error = name + ": tree level above " + std::to_string(kMaxTreeLevel);
            return false;
        }
        const std::uint32_t gx = levelGridSize(h.blocksX, e.level),
                            gy = levelGridSize(h.blocksY, e.level);
        if (e.col >= gx || e.row >= gy) {
            error = name + ": outside the " + std::to_string(gx) + "x" + std::to_string(gy) +
                    " grid of its tree level";
            return false;
        }
        if (!seen.insert({e.level, e.col, e.row}).second) {
            error = name + ": duplicate block position";
            return false;
        }
        if (e.level == 0) {
            if (e.childCount != 0 || e.firstChild != kNoChild) {
                error = name + ": a leaf with children";
                return false;
            }
            continue;
        }
        if (e.childCount < 1 || e.childCount > 4 || e.firstChild >= i ||
            e.childCount > i - e.firstChild) {
            error = name + ": children [" + std::to_string(e.firstChild) + ", +" +
                    std::to_string(e.childCount) + ") are not 1 to 4 entries before it";
            return false;
        }
        for (std::uint32_t c = e.firstChild; c < e.firstChild + e.childCount; ++c) {
            const DirEntry& k = dir[c];
            const bool inside = k.minX >= e.minX && k.maxX <= e.maxX && k.minY >= e.minY &&
                                k.maxY <= e.maxY && k.minZ >= e.minZ && k.maxZ <= e.maxZ;
            if (k.level + 1u != e.level || k.col / 2 != e.col || k.row / 2 != e.row ||
                hasParent[c] || !inside) {
                error = name + ": entry " + std::to_string(c) +
                        " is not one of its children (level, position, box or a second parent)";
                return false;
            }
            hasParent[c] = 1;
        }
    }
    return true;
}

std::string errnoText() {
    return std::strerror(errno);
}

// The block header's count of array i of the table (blockarrays.h): the counts are contiguous, in
// the table's order.
static_assert(offsetof(BlockHeader, gridCount) ==
              offsetof(BlockHeader, vertexCount) + (kArrayCount - 1) * sizeof(std::uint32_t));
std::uint32_t& countOf(BlockHeader& h, int i) {
    return (&h.vertexCount)[i];
}
std::uint32_t countOf(const BlockHeader& h, int i) {
    return (&h.vertexCount)[i];
}

// Byte size of a raw block from its header's counts; 64-bit, cannot overflow (17 arrays of at
// most 2^32 - 1 elements of at most 32 bytes each).
std::uint64_t blockByteSize(const BlockHeader& h) {
    static const Block kShape;  // only the element types are used
    std::uint64_t size = sizeof(BlockHeader);
    forEachArray(kShape, [&](const auto& v, int i) {
        size += alignUp(std::uint64_t(countOf(h, i)) * sizeof(v[0]));
    });
    return size;
}

// The counts a compact block's decoder is held to.
BlockCounts compactCounts(const BlockHeader& h) {
    BlockCounts c;
    c.vertices = h.vertexCount;
    c.steps = h.stepCount;
    c.levels = h.levelCount;
    c.removedTriangles = h.removedTriangleCount;
    c.addedTriangles = h.addedTriangleCount;
    c.removedEdges = h.removedEdgeCount;
    c.addedEdges = h.addedEdgeCount;
    c.terrainTriangles = h.terrainTriangleCount;
    c.riverEdges = h.riverEdgeCount;
    c.errorMax = h.errorMaxCount > 0;
    c.errorPaper = h.errorPaperCount > 0;
    c.errorRiver = h.errorRiverCount > 0;
    return c;
}

// A compact block decodes to at most this many times its stored bytes (plus 1 MiB): the reader
// refuses larger counts before it decodes, so a hostile block cannot ask for a huge allocation.
// Built blocks expand about 10-40 times.
constexpr std::uint64_t kMaxExpansion = 1024;

}  // namespace

const char* metricName(std::uint32_t metric) {
    return metric == kMetricPaper ? "paper" : "max";
}

bool metricOfName(const std::string& name, std::uint32_t& metric) {
    metric = 0;
    if (name == "max") metric = kMetricMax;
    if (name == "paper") metric = kMetricPaper;
    return metric != 0 || name.empty();
}

bool resolveMetric(const Header& header, const std::string& path, std::uint32_t requested,
                   std::uint32_t& metric, std::string& error) {
    metric = requested == 0 ? header.defaultMetric : requested;
    if (metric != kMetricMax && metric != kMetricPaper) {
        error = path + ": unknown error metric " + std::to_string(metric);
        return false;
    }
    if ((header.metrics & metric) == 0) {
        error = path + ": the file has no '" + metricName(metric) + "' error metric";
        return false;
    }
    return true;
}

namespace {

bool metricsValid(std::uint32_t metrics, std::uint32_t defaultMetric, std::string& error) {
    const std::uint32_t all = kMetricMax | kMetricPaper;
    if (metrics == 0 || (metrics & ~all) != 0) {
        error = "invalid metrics mask " + std::to_string(metrics);
        return false;
    }
    if ((defaultMetric != kMetricMax && defaultMetric != kMetricPaper) ||
        (metrics & defaultMetric) == 0) {
        error = "default metric " + std::to_string(defaultMetric) + " is not in metrics mask " +
                std::to_string(metrics);
        return false;
    }
    return true;
}

// The header's values (Reader::open, and Writer::finish before it writes them): every float
// finite, extents ordered, block size positive. A grid may have cells without a block, but not
// more cells than the file has bytes: whatever a reader keeps per grid cell then costs at most as
// much as the file itself (a hostile 2^32 - 1 x 2^32 - 1 grid is rejected).
bool headerValid(const Header& h, std::uint64_t fileSize, std::string& error) {
    const std::pair<const char*, double> values[] = {{"originX", h.originX},
                                                     {"originY", h.originY},
                                                     {"minX", h.minX},
                                                     {"minY", h.minY},
                                                     {"minZ", h.minZ},
                                                     {"maxX", h.maxX},
                                                     {"maxY", h.maxY},
                                                     {"maxZ", h.maxZ},
                                                     {"blockWidth", h.blockWidth},
                                                     {"blockHeight", h.blockHeight}};
    for (const auto& [name, value] : values) {
        if (!std::isfinite(value)) {
            error = std::string("header ") + name + " is not finite";
            return false;
        }
    }
    if (h.minX > h.maxX || h.minY > h.maxY || h.minZ > h.maxZ) {
        error = "header extents are inverted (a min above its max)";
        return false;
    }
    if (!(h.zQuantum > 0 && h.zQuantum <= 1)) {
        error = "z quantum " + std::to_string(h.zQuantum) + " is not in (0, 1] m";
        return false;
    }
    if (h.blockWidth <= 0 || h.blockHeight <= 0) {
        error = "block size " + std::to_string(h.blockWidth) + " x " +
                std::to_string(h.blockHeight) + " m is not positive";
        return false;
    }
    if (std::uint64_t(h.blocksX) * h.blocksY > fileSize) {
        error = "block grid " + std::to_string(h.blocksX) + "x" + std::to_string(h.blocksY) +
                " has more cells than the file has bytes (" + std::to_string(fileSize) + ")";
        return false;
    }
    return true;
}

// A directory entry's bounding box: finite, ordered and inside the header's extents. Exact: the
// writer's caller sets the extents to the min / max of the same doubles (preprocess/build.cpp),
// so no rounding lies between them. Comparisons are written so that NaN fails them.
bool directoryBoxValid(const Header& h, const double box[6], std::string& error) {
    const double lo[3] = {h.minX, h.minY, h.minZ}, hi[3] = {h.maxX, h.maxY, h.maxZ};
    for (int a = 0; a < 3; ++a) {
        if (!(box[a] >= lo[a] && box[a] <= box[a + 3] && box[a + 3] <= hi[a])) {
            error = "bounding box is not finite, inverted or outside the header's extents";
            return false;
        }
    }
    return true;
}

// ---- I/O helpers ------------------------------------------------------------------------------

bool preadAll(int fd, void* data, std::uint64_t size, std::uint64_t offset) {
    auto* p = static_cast<unsigned char*>(data);
    while (size > 0) {
        const ssize_t got = ::pread(fd, p, size, static_cast<off_t>(offset));
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) {
            if (got == 0) errno = EIO;  // the file shrank under us
            return false;
        }
        p += got;
        size -= static_cast<std::uint64_t>(got);
        offset += static_cast<std::uint64_t>(got);
    }
    return true;
}

std::uint32_t crc32Of(const void* data, std::uint64_t size, std::uint32_t crc = 0) {
    // zlib's crc32 takes a uInt length: feed it in chunks.
    const auto* p = static_cast<const Bytef*>(data);
    uLong c = crc;
    while (size > 0) {
        const uInt chunk = static_cast<uInt>(std::min<std::uint64_t>(size, 1u << 30));
        c = ::crc32(c, p, chunk);
        p += chunk;
        size -= chunk;
    }
    return static_cast<std::uint32_t>(c);
}

// Appends bytes to a buffer, then zero padding up to the next 8-byte boundary.
void appendPadded(std::vector<unsigned char>& out, const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    out.insert(out.end(), p, p + size);
    out.resize(alignUp(out.size()), 0);
}

void fillBlockHeader(const Block& b, BlockHeader& h) {
    h = BlockHeader{};
    h.col = b.col;
    h.row = b.row;
    h.originX = b.originX;
    h.originY = b.originY;
    h.minX = b.minX;
    h.minY = b.minY;
    h.minZ = b.minZ;
    h.maxX = b.maxX;
    h.maxY = b.maxY;
    h.maxZ = b.maxZ;
    forEachArray(b, [&](const auto& v, int i) { countOf(h, i) = static_cast<std::uint32_t>(v.size()); });
}

// The block's bytes: compact (blockcodec.h) when asked for, the block is in canonical form (the
// encoder replays it and proves that everything the decoder derives equals what it stores) and
// compact is smaller; raw otherwise.
void serializeBlock(const Block& b, bool compact, double zQuantum,
                    std::vector<unsigned char>& out) {
    BlockHeader h;
    fillBlockHeader(b, h);
    out.clear();
    std::vector<unsigned char> payload;
    std::string why;
    // Compact only when it is smaller (a tiny block's stream headers can cost more than raw).
    if (compact && encodeCompact(b, zQuantum, payload, why) &&
        alignUp(sizeof(h) + payload.size()) < blockByteSize(h) &&
        payload.size() <= std::numeric_limits<std::uint32_t>::max()) {
        h.encoding = std::uint32_t(BlockEncoding::kCompact);
        h.payloadSize = static_cast<std::uint32_t>(payload.size());
        appendPadded(out, &h, sizeof(h));
        appendPadded(out, payload.data(), payload.size());
        return;
    }
    h.encoding = std::uint32_t(BlockEncoding::kRaw);
    out.reserve(blockByteSize(h));
    appendPadded(out, &h, sizeof(h));
    forEachArray(b, [&](const auto& v, int) { appendPadded(out, v.data(), v.size() * sizeof(v[0])); });
    assert(out.size() == blockByteSize(h));
}

}  // namespace

// ---- writer -----------------------------------------------------------------------------------

struct Writer::Impl {
    std::string path;
    Header header;
    AtomicFile file;
    std::size_t blockCount = 0;
    std::vector<DirEntry> dir;
    std::vector<Level> levelTable;  // every entry's levels, in directory order
    std::uint64_t dataStart = 0, offset = 0;
    std::vector<unsigned char> bytes;
    bool open = false;
    bool raw = false;
};

Writer::Writer() : impl_(std::make_unique<Impl>()) {}
Writer::~Writer() = default;  // an unfinished temporary file is removed (AtomicFile)

Header& Writer::header() { return impl_->header; }

void Writer::storeRaw(bool raw) { impl_->raw = raw; }

bool Writer::open(const std::string& path, const Header& header, std::size_t blockCount,
                  const OutputOptions& output, std::string& error) {
    impl_ = std::make_unique<Impl>();
    Impl& w = *impl_;
    w.path = path;
    w.header = header;
    w.blockCount = blockCount;
    auto fail = [&](const std::string& what) {
        error = path + ": " + what;
        return false;
    };
    constexpr std::uint64_t kMax32 = std::numeric_limits<std::uint32_t>::max();
    // Header checks that need no I/O come first.
    std::string why;
    if (!metricsValid(header.metrics, header.defaultMetric, why)) return fail(why);
    if (header.crsWkt.size() > kMax32 || header.buildInfo.size() > kMax32) {
        return fail("CRS WKT or build info longer than 2^32 - 1 bytes");
    }
    if (blockCount > kMax32) return fail("more than 2^32 - 1 blocks");

    // Layout: fixed header, WKT, build info, directory, trailer, then the blocks in order. The
    // header part has a known size, so blocks are written first and the header last.
    w.dataStart = sizeof(FileHeader) + alignUp(header.crsWkt.size()) +
                  alignUp(header.buildInfo.size()) + blockCount * sizeof(DirEntry) +
                  sizeof(HeaderTrailer);
    w.offset = w.dataStart;
    if (!w.file.open(path, output, error)) return false;
    w.open = true;
    return true;
}

bool Writer::writeBlock(const Block& b, std::string& error) {
    Impl& w = *impl_;
    assert(w.open && "Writer::open() first");
    auto fail = [&](const std::string& what) {
        error = w.path + ": " + what;
        return false;
    };
    if (w.dir.size() >= w.blockCount) {
        return fail("more blocks than the " + std::to_string(w.blockCount) + " announced");
    }
    if (b.level > kMaxTreeLevel) return fail(blockName(b.col, b.row, b.level) + ": tree level too high");
    std::string why;
    if (!validateBlock(b, w.header.metrics, why)) return fail(why);
    serializeBlock(b, !w.raw, w.header.zQuantum, w.bytes);
    DirEntry e{};
    e.col = b.col;
    e.row = b.row;
    e.minX = b.minX;
    e.minY = b.minY;
    e.minZ = b.minZ;
    e.maxX = b.maxX;
    e.maxY = b.maxY;
    e.maxZ = b.maxZ;
    e.offset = w.offset;
    e.size = w.bytes.size();
    e.checksum = crc32Of(w.bytes.data(), w.bytes.size());
    e.vertexCount = static_cast<std::uint32_t>(b.vertices.size());
    e.stepCount = static_cast<std::uint32_t>(b.steps.size());
    e.levelCount = static_cast<std::uint32_t>(b.levels.size());
    e.fullTriangles = b.levels[0].triangleCount;  // validateBlock: levels[0] is step 0
    e.level = std::uint16_t(b.level);
    e.childCount = std::uint16_t(std::min<std::uint32_t>(b.childCount, 0xFFFF));
    e.firstChild = b.firstChild;
    std::memcpy(&e.encoding, w.bytes.data() + offsetof(BlockHeader, encoding), 4);
    e.originX = b.originX;
    e.originY = b.originY;
    e.flags = outlineMoves(b) ? kEntryOutlineMoves : 0;
    // Tree links are checked as a whole in finish() (treeValid); positions here, early.
    {
        std::vector<DirEntry> one = {e};
        one[0].childCount = 0;
        one[0].firstChild = kNoChild;
        one[0].level = std::uint16_t(b.level);
        if (b.level == 0 && !treeValid(w.header, one, why)) return fail(why);
    }
    if (!w.file.writeAt(w.bytes.data(), w.bytes.size(), w.offset, error)) return false;
    w.offset += w.bytes.size();
    w.dir.push_back(e);
    w.levelTable.insert(w.levelTable.end(), b.levels.begin(), b.levels.end());
    return true;
}

bool Writer::finish(std::string& error) {
    Impl& w = *impl_;
    assert(w.open && "Writer::open() first");
    auto fail = [&](const std::string& what) {
        error = w.path + ": " + what;
        return false;
    };
    if (w.dir.size() != w.blockCount) {
        return fail(std::to_string(w.dir.size()) + " blocks written, " +
                    std::to_string(w.blockCount) + " announced");
    }
    const Header& header = w.header;
    const std::uint64_t expectedStart =
        sizeof(FileHeader) + alignUp(header.crsWkt.size()) + alignUp(header.buildInfo.size()) +
        w.blockCount * sizeof(DirEntry) + sizeof(HeaderTrailer);
    if (expectedStart != w.dataStart) return fail("CRS WKT or build info changed size after open");
    std::string why;
    if (!metricsValid(header.metrics, header.defaultMetric, why)) return fail(why);
    // The level table after the last block.
    std::vector<unsigned char> table;
    appendPadded(table, w.levelTable.data(), w.levelTable.size() * sizeof(Level));
    const std::uint64_t fileSize = w.offset + table.size();
    // What Reader::open checks of the header and directory holds before anything is written.
    if (!headerValid(header, fileSize, why)) return fail(why);
    for (const DirEntry& e : w.dir) {
        const double box[6] = {e.minX, e.minY, e.minZ, e.maxX, e.maxY, e.maxZ};
        if (!directoryBoxValid(header, box, why))
            return fail(blockName(e.col, e.row, e.level) + ": " + why);
    }
    if (!treeValid(header, w.dir, why)) return fail(why);

    FileHeader fh{};
    std::memcpy(fh.magic, kMagic, sizeof(kMagic));
    fh.version = kVersion;
    fh.headerSize = sizeof(FileHeader);
    fh.originX = header.originX;
    fh.originY = header.originY;
    fh.minX = header.minX;
    fh.minY = header.minY;
    fh.minZ = header.minZ;
    fh.maxX = header.maxX;
    fh.maxY = header.maxY;
    fh.maxZ = header.maxZ;
    fh.blockWidth = header.blockWidth;
    fh.blockHeight = header.blockHeight;
    fh.blocksX = header.blocksX;
    fh.blocksY = header.blocksY;
    fh.metrics = header.metrics;
    fh.defaultMetric = header.defaultMetric;
    fh.blockCount = static_cast<std::uint32_t>(w.blockCount);
    fh.crsWktSize = static_cast<std::uint32_t>(header.crsWkt.size());
    fh.buildInfoSize = static_cast<std::uint32_t>(header.buildInfo.size());
    fh.fileSize = fileSize;
    fh.zQuantum = header.zQuantum;
    fh.levelTableOffset = w.offset;
    fh.levelTableCrc = crc32Of(table.data(), table.size());

    std::vector<unsigned char> bytes;
    appendPadded(bytes, &fh, sizeof(fh));
    appendPadded(bytes, header.crsWkt.data(), header.crsWkt.size());
    appendPadded(bytes, header.buildInfo.data(), header.buildInfo.size());
    appendPadded(bytes, w.dir.data(), w.dir.size() * sizeof(DirEntry));
    HeaderTrailer trailer{crc32Of(bytes.data(), bytes.size()), 0};
    appendPadded(bytes, &trailer, sizeof(trailer));
    assert(bytes.size() == w.dataStart);
    if (!table.empty() && !w.file.writeAt(table.data(), table.size(), w.offset, error))
        return false;
    if (!w.file.writeAt(bytes.data(), bytes.size(), 0, error)) return false;
    // fsync, close and the move into place: AtomicFile (no replacing unless asked to).
    if (!w.file.commit(error)) return false;
    w.open = false;
    return true;
}

bool writeUlod(const std::string& path, const Header& header, const std::vector<Block>& blocks,
               std::string& error) {
    Writer writer;
    if (!writer.open(path, header, blocks.size(),
                     OutputOptions{.replace = true, .inputs = {}, .inputParts = {}}, error)) {
        return false;
    }
    for (const Block& b : blocks) {
        if (!writer.writeBlock(b, error)) return false;
    }
    return writer.finish(error);
}

// ---- reader -----------------------------------------------------------------------------------

struct Reader::Impl {
    std::string path;
    int fd = -1;
    Header header;
    std::vector<BlockInfo> blocks;

    ~Impl() {
        if (fd >= 0) ::close(fd);
    }
};

Reader::Reader() : impl_(std::make_unique<Impl>()) {}
Reader::~Reader() = default;

const Header& Reader::header() const {
    assert(impl_->fd >= 0 && "Reader::open() first");
    return impl_->header;
}

const std::vector<BlockInfo>& Reader::blocks() const {
    assert(impl_->fd >= 0 && "Reader::open() first");
    return impl_->blocks;
}

const std::string& Reader::path() const {
    return impl_->path;
}

bool Reader::open(const std::string& path, std::string& error) {
    impl_ = std::make_unique<Impl>();  // a failed open leaves a closed reader
    auto fail = [&](const std::string& what) {
        error = path + ": " + what;
        impl_ = std::make_unique<Impl>();
        return false;
    };

    // Before open(): a FIFO would block it forever.
    if (std::string why; !checkInputFile(path, false, why)) return fail(why);
    Impl& r = *impl_;
    r.path = path;
    r.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (r.fd < 0) return fail("cannot open: " + errnoText());
    struct stat st {};
    if (::fstat(r.fd, &st) != 0) return fail("cannot stat: " + errnoText());
    if (!S_ISREG(st.st_mode)) return fail("not a regular file");
    const auto actualSize = static_cast<std::uint64_t>(st.st_size);

    FileHeader fh{};
    if (actualSize < sizeof(kMagic)) {
        return fail("not a .ulod file (" + std::to_string(actualSize) + " bytes)");
    }
    if (!preadAll(r.fd, &fh, std::min<std::uint64_t>(actualSize, sizeof(fh)), 0)) {
        return fail("read failed: " + errnoText());
    }
    if (std::memcmp(fh.magic, kMagic, sizeof(kMagic)) != 0) return fail("not a .ulod file");
    if (actualSize < offsetof(FileHeader, fileSize)) {
        return fail("truncated (" + std::to_string(actualSize) + " bytes, shorter than a header)");
    }
    if (fh.version != kVersion) {
        return fail("unsupported .ulod version " + std::to_string(fh.version) +
                    " (this build reads " + std::to_string(kVersion) + ")");
    }
    if (fh.headerSize != sizeof(FileHeader)) {
        return fail("header size " + std::to_string(fh.headerSize) + ", version " +
                    std::to_string(kVersion) + " has " + std::to_string(sizeof(FileHeader)));
    }
    if (actualSize < sizeof(FileHeader)) {
        return fail("truncated (" + std::to_string(actualSize) + " bytes, shorter than a header)");
    }
    if (actualSize < fh.fileSize) {
        return fail("truncated (" + std::to_string(actualSize) + " bytes, header records " +
                    std::to_string(fh.fileSize) + ")");
    }
    if (actualSize > fh.fileSize) {
        return fail("trailing bytes (" + std::to_string(actualSize) + " bytes, header records " +
                    std::to_string(fh.fileSize) + ")");
    }

    // Header region size from 32-bit counts: cannot overflow 64 bits; checked against the file
    // size before it is allocated.
    const std::uint64_t wktAt = sizeof(FileHeader);
    const std::uint64_t buildAt = wktAt + alignUp(fh.crsWktSize);
    const std::uint64_t dirAt = buildAt + alignUp(fh.buildInfoSize);
    const std::uint64_t trailerAt = dirAt + std::uint64_t(fh.blockCount) * sizeof(DirEntry);
    const std::uint64_t dataStart = trailerAt + sizeof(HeaderTrailer);
    if (dataStart > actualSize) {
        return fail("header region (" + std::to_string(dataStart) + " bytes) exceeds the file (" +
                    std::to_string(actualSize) + " bytes)");
    }
    std::vector<unsigned char> head(dataStart);
    if (!preadAll(r.fd, head.data(), head.size(), 0)) return fail("read failed: " + errnoText());
    HeaderTrailer trailer;
    std::memcpy(&trailer, head.data() + trailerAt, sizeof(trailer));
    const std::uint32_t crc = crc32Of(head.data(), trailerAt);
    if (crc != trailer.crc) return fail("header checksum mismatch");
    if (trailer.reserved != 0) return fail("reserved header field not 0");
    std::string why;
    if (!metricsValid(fh.metrics, fh.defaultMetric, why)) return fail(why);

    Header& h = r.header;
    h.crsWkt.assign(reinterpret_cast<const char*>(head.data() + wktAt), fh.crsWktSize);
    h.buildInfo.assign(reinterpret_cast<const char*>(head.data() + buildAt), fh.buildInfoSize);
    h.originX = fh.originX;
    h.originY = fh.originY;
    h.minX = fh.minX;
    h.minY = fh.minY;
    h.minZ = fh.minZ;
    h.maxX = fh.maxX;
    h.maxY = fh.maxY;
    h.maxZ = fh.maxZ;
    h.blocksX = fh.blocksX;
    h.blocksY = fh.blocksY;
    h.blockWidth = fh.blockWidth;
    h.blockHeight = fh.blockHeight;
    h.metrics = fh.metrics;
    h.defaultMetric = fh.defaultMetric;
    h.zQuantum = fh.zQuantum;
    if (!headerValid(h, actualSize, why)) return fail(why);

    r.blocks.resize(fh.blockCount);
    std::vector<DirEntry> dir(fh.blockCount);
    if (fh.blockCount > 0)
        std::memcpy(dir.data(), head.data() + dirAt, dir.size() * sizeof(DirEntry));
    if (!treeValid(h, dir, why)) return fail(why);
    // The level table: from levelTableOffset (after every block) to the end of the file, the
    // entries' levels in directory order; the count is checked against its bytes before any
    // allocation.
    std::uint64_t levelTotal = 0;
    for (const DirEntry& e : dir) levelTotal += e.levelCount;
    if (fh.levelTableOffset < dataStart || fh.levelTableOffset % kAlign != 0 ||
        fh.levelTableOffset > actualSize ||
        alignUp(levelTotal * sizeof(Level)) != actualSize - fh.levelTableOffset) {
        return fail("level table at " + std::to_string(fh.levelTableOffset) + " does not hold the " +
                    std::to_string(levelTotal) + " levels the directory counts up to the end of "
                    "the file");
    }
    std::vector<unsigned char> tableBytes(actualSize - fh.levelTableOffset);
    if (!preadAll(r.fd, tableBytes.data(), tableBytes.size(), fh.levelTableOffset))
        return fail("read failed: " + errnoText());
    if (crc32Of(tableBytes.data(), tableBytes.size()) != fh.levelTableCrc)
        return fail("level table checksum mismatch");
    for (std::uint64_t at = levelTotal * sizeof(Level); at < tableBytes.size(); ++at)
        if (tableBytes[at] != 0) return fail("level table padding not 0");
    std::uint64_t levelAt = 0;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> ranges;  // (offset, size) per block
    ranges.reserve(fh.blockCount);
    for (std::uint32_t i = 0; i < fh.blockCount; ++i) {
        const DirEntry& e = dir[i];
        const std::string name = "directory entry " + std::to_string(i) + " (" +
                                 blockName(e.col, e.row, e.level) + ")";
        if (e.encoding > std::uint32_t(BlockEncoding::kCompact))
            return fail(name + ": unknown block encoding " + std::to_string(e.encoding));
        // Overflow-safe: offset <= actualSize is checked before actualSize - offset.
        if (e.offset < dataStart || e.offset % kAlign != 0 || e.offset > fh.levelTableOffset ||
            e.size > fh.levelTableOffset - e.offset || e.size < sizeof(BlockHeader)) {
            return fail(name + ": byte range [" + std::to_string(e.offset) + ", +" +
                        std::to_string(e.size) + ") is out of bounds");
        }
        const double box[6] = {e.minX, e.minY, e.minZ, e.maxX, e.maxY, e.maxZ};
        if (!directoryBoxValid(h, box, why)) return fail(name + ": " + why);
        if (!std::isfinite(e.originX) || !std::isfinite(e.originY))
            return fail(name + ": origin not finite");
        if ((e.flags & ~kEntryOutlineMoves) != 0 || e.reserved != 0)
            return fail(name + ": unknown flags or reserved field not 0");
        ranges.emplace_back(e.offset, e.size);
        BlockInfo& info = r.blocks[i];
        info.col = e.col;
        info.row = e.row;
        info.minX = e.minX;
        info.minY = e.minY;
        info.minZ = e.minZ;
        info.maxX = e.maxX;
        info.maxY = e.maxY;
        info.maxZ = e.maxZ;
        info.offset = e.offset;
        info.size = e.size;
        info.checksum = e.checksum;
        info.vertexCount = e.vertexCount;
        info.stepCount = e.stepCount;
        info.levelCount = e.levelCount;
        info.fullTriangles = e.fullTriangles;
        info.encoding = e.encoding;
        info.level = e.level;
        info.firstChild = e.firstChild;
        info.childCount = e.childCount;
        info.originX = e.originX;
        info.originY = e.originY;
        info.outlineMoves = (e.flags & kEntryOutlineMoves) != 0;
        info.levels.resize(e.levelCount);
        if (e.levelCount > 0)
            std::memcpy(info.levels.data(), tableBytes.data() + levelAt,
                        e.levelCount * sizeof(Level));
        levelAt += std::uint64_t(e.levelCount) * sizeof(Level);
    }
    std::sort(ranges.begin(), ranges.end());
    for (std::size_t i = 1; i < ranges.size(); ++i) {
        if (ranges[i].first < ranges[i - 1].first + ranges[i - 1].second) {
            return fail("directory: blocks at offsets " + std::to_string(ranges[i - 1].first) +
                        " and " + std::to_string(ranges[i].first) + " overlap");
        }
    }
    // Each entry's levels (the table), once the byte ranges are known to be sound.
    for (std::uint32_t i = 0; i < fh.blockCount; ++i) {
        const DirEntry& e = dir[i];
        const BlockInfo& info = r.blocks[i];
        const std::string name = "directory entry " + std::to_string(i) + " (" +
                                 blockName(e.col, e.row, e.level) + ")";
        if (!validateLevelTable(info.levels, e.vertexCount, e.stepCount, e.fullTriangles,
                                h.metrics, why))
            return fail(name + ": level table: " + why);
        // What the engine sizes its buffers by before it reads the block (its vertices and the
        // index data its levels reach) must fit what the block's bytes can hold, as readBlock
        // requires of the block's own counts: so a lying table costs at most that, and the
        // block's read then names the lie.
        std::uint64_t terrainEnd = 0, riverEnd = 0;
        for (const Level& l : info.levels) {
            terrainEnd = std::max(terrainEnd, std::uint64_t(l.triangleFirst) + l.triangleCount);
            riverEnd = std::max(riverEnd, std::uint64_t(l.riverFirst) + l.riverCount);
        }
        const std::uint64_t needs = std::uint64_t(e.vertexCount) * sizeof(Vertex) +
                                    terrainEnd * sizeof(Triangle) + riverEnd * sizeof(Edge);
        const std::uint64_t holds = e.encoding == std::uint32_t(BlockEncoding::kRaw)
                                        ? e.size
                                        : kMaxExpansion * e.size + (1u << 20);
        if (needs > holds)
            return fail(name + ": level table: its vertices and levels need " +
                        std::to_string(needs) + " bytes, more than the block's " +
                        std::to_string(e.size) + " bytes can hold");
    }
    return true;
}

bool Reader::readBlock(std::size_t index, Block& block, std::string& error) const {
    assert(impl_->fd >= 0 && "Reader::open() first");
    assert(index < impl_->blocks.size());
    const Impl& r = *impl_;
    const BlockInfo& info = r.blocks[index];
    auto fail = [&](const std::string& what) {
        error = r.path + ": " + blockName(info.col, info.row, info.level) + ": " + what;
        return false;
    };

    // info.size was checked against the real file size at open: this allocation is bounded.
    std::vector<unsigned char> bytes(info.size);
    if (!preadAll(r.fd, bytes.data(), bytes.size(), info.offset)) {
        return fail("read failed: " + errnoText());
    }
    if (crc32Of(bytes.data(), bytes.size()) != info.checksum) return fail("checksum mismatch");

    if (info.size < sizeof(BlockHeader)) return fail("shorter than a block header");
    BlockHeader h;
    std::memcpy(&h, bytes.data(), sizeof(h));
    if (h.col != info.col || h.row != info.row) {
        return fail("block header says " + blockName(h.col, h.row, info.level));
    }
    if (h.encoding != info.encoding) return fail("encoding differs from the directory");
    if (h.reserved != 0) return fail("reserved block header field not 0");
    if (h.encoding == std::uint32_t(BlockEncoding::kRaw) ? h.payloadSize != 0
                                                          : alignUp(sizeof(BlockHeader) +
                                                                    std::uint64_t(h.payloadSize)) !=
                                                                info.size) {
        return fail("payload size " + std::to_string(h.payloadSize) + " does not fit the block's " +
                    std::to_string(info.size) + " bytes");
    }
    // Counts are checked against the byte size before any array is allocated.
    const std::uint64_t expected = blockByteSize(h);
    if (h.encoding == std::uint32_t(BlockEncoding::kRaw) && expected != info.size) {
        return fail("its counts need " + std::to_string(expected) + " bytes, the directory gives " +
                    std::to_string(info.size));
    }
    if (h.encoding == std::uint32_t(BlockEncoding::kCompact) &&
        expected > kMaxExpansion * info.size + (1u << 20)) {
        return fail("its counts need " + std::to_string(expected) +
                    " bytes, more than a compact block of " + std::to_string(info.size) +
                    " bytes can hold");
    }
    if (h.vertexCount != info.vertexCount || h.stepCount != info.stepCount ||
        h.levelCount != info.levelCount) {
        return fail("vertex, step or level count differs from the directory");
    }

    Block b;
    b.col = h.col;
    b.row = h.row;
    b.level = info.level;
    b.firstChild = info.firstChild;
    b.childCount = info.childCount;
    b.originX = h.originX;
    b.originY = h.originY;
    b.minX = h.minX;
    b.minY = h.minY;
    b.minZ = h.minZ;
    b.maxX = h.maxX;
    b.maxY = h.maxY;
    b.maxZ = h.maxZ;
    if (h.encoding == std::uint32_t(BlockEncoding::kRaw)) {
        std::uint64_t at = sizeof(BlockHeader);
        forEachArray(b, [&](auto& v, int i) {
            const std::uint32_t n = countOf(h, i);
            v.resize(n);
            const std::uint64_t size = n * sizeof(v[0]);
            if (size > 0) std::memcpy(v.data(), bytes.data() + at, size);  // data() may be null
            at += alignUp(size);
        });
        assert(at == info.size);
    } else {
        for (std::size_t at = sizeof(BlockHeader) + h.payloadSize; at < bytes.size(); ++at)
            if (bytes[at] != 0) return fail("padding not 0");
        std::string why;
        if (!decodeCompact(bytes.data() + sizeof(BlockHeader), h.payloadSize, compactCounts(h),
                           r.header.zQuantum, b, why))
            return fail(why);
        BlockHeader back;
        fillBlockHeader(b, back);
        if (std::memcmp(&h.vertexCount, &back.vertexCount, kArrayCount * 4) != 0)
            return fail("compact data: decoded array sizes differ from the block header's counts");
    }

    const double dirBox[6] = {info.minX, info.minY, info.minZ, info.maxX, info.maxY, info.maxZ};
    const double blockBox[6] = {b.minX, b.minY, b.minZ, b.maxX, b.maxY, b.maxZ};
    if (std::memcmp(dirBox, blockBox, sizeof(dirBox)) != 0) {
        return fail("bounding box differs from the directory");
    }

    std::string why;
    if (!validateBlock(b, r.header.metrics, why)) {
        error = r.path + ": " + why;  // validateBlock already names the block
        return false;
    }
    if (b.levels[0].triangleCount != info.fullTriangles) {
        return fail("full-resolution triangle count differs from the directory");
    }
    if (b.originX != info.originX || b.originY != info.originY)
        return fail("origin differs from the directory");
    if (std::memcmp(b.levels.data(), info.levels.data(), b.levels.size() * sizeof(Level)) != 0)
        return fail("levels differ from the file's level table");
    if (outlineMoves(b) != info.outlineMoves)
        return fail("the directory's outline flag is wrong");
    block = std::move(b);
    return true;
}

bool Reader::readGeometry(std::size_t index, int level, BlockGeometry& geometry,
                          std::string& error) const {
    // The whole block, validated as readBlock does: its checksum covers every byte, and what the
    // engine relies on (ranges, indices, level geometry) is what validateBlock proves.
    Block b;
    if (!readBlock(index, b, error)) return false;
    if (level != kLevelsOnly && level != kAllLevels &&
        (level < 0 || std::size_t(level) >= b.levels.size())) {
        error =
            impl_->path + ": " + blockName(b.col, b.row, b.level) + ": no level " + std::to_string(level);
        return false;
    }
    BlockGeometry g;
    g.col = b.col;
    g.row = b.row;
    g.level = b.level;
    g.firstChild = b.firstChild;
    g.childCount = b.childCount;
    g.originX = b.originX;
    g.originY = b.originY;
    g.minX = b.minX, g.minY = b.minY, g.minZ = b.minZ;
    g.maxX = b.maxX, g.maxY = b.maxY, g.maxZ = b.maxZ;
    g.levels = b.levels;
    g.outlineMoves = impl_->blocks[index].outlineMoves;
    if (level == kAllLevels) {
        g.vertices = std::move(b.vertices);
        g.terrainIndices = std::move(b.terrainIndices);
        g.riverIndices = std::move(b.riverIndices);
    } else if (level != kLevelsOnly) {
        // One level: the vertex prefix it uses and its index ranges, rebased to 0.
        const Level& l = b.levels[std::size_t(level)];
        g.vertices.assign(b.vertices.begin(), b.vertices.begin() + l.vertexCount);
        const auto tris = b.terrainIndices.begin() + l.triangleFirst;
        g.terrainIndices.assign(tris, tris + l.triangleCount);
        const auto edges = b.riverIndices.begin() + l.riverFirst;
        g.riverIndices.assign(edges, edges + l.riverCount);
    }
    geometry = std::move(g);
    return true;
}

}  // namespace unilod::format
