// A .ulod file as bytes, for tests that damage it on purpose (the hostile-file tests and the fuzz
// driver): where the header fields, the directory and each block's arrays lie (the layout of
// engine/format/README.md, pinned here independently of the reader), and resealing, i.e.
// recomputing a block's CRC in its directory entry and the header CRC in the trailer, so that a
// damage reaches the semantic checks instead of stopping at a checksum. Every accessor is
// bounds-checked against the bytes: on a file that is already damaged, resealing does what it can
// and never reads outside the buffer.
#pragma once

#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace unilod::test {

struct UlodBytes {
    // README.md: file header 152 bytes, directory entries 128, trailer 8, block header 152. The
    // array accessors describe raw blocks (`build --encoding raw`); a compact block's payload
    // starts at kBlockHeaderSize and is kPayloadSize bytes long.
    static constexpr std::size_t kHeaderSize = 152, kEntrySize = 128, kBlockHeaderSize = 152;
    // Header fields.
    static constexpr std::size_t kOriginX = 24, kMinX = 40, kMinY = 48, kMinZ = 56, kMaxX = 64,
                                 kMaxY = 72, kMaxZ = 80, kBlockWidth = 88, kBlockHeight = 96,
                                 kBlocksX = 104, kBlocksY = 108, kBlockCount = 120,
                                 kCrsWktSize = 124, kBuildInfoSize = 128, kLevelTableCrc = 132,
                                 kZQuantum = 136, kLevelTableOffset = 144;
    // Directory entry fields.
    static constexpr std::size_t kEntryOffset = 56, kEntrySizeField = 64, kEntryChecksum = 72,
                                 kEntryEncoding = 100, kEntryOriginX = 104, kEntryFlags = 120;
    static constexpr std::size_t kLevelSize = 36;  // one level in a block and in the level table
    // Block header fields; the 17 array counts start at kCounts, in array order.
    static constexpr std::size_t kBlockOriginX = 8, kBlockMinX = 24, kCounts = 72,
                                 kEncoding = 140, kPayloadSize = 144;
    // The arrays of a block in file order and their element sizes.
    enum Array {
        kVertices,
        kSteps,
        kRemovedTriangleOffset,
        kAddedTriangleOffset,
        kRemovedEdgeOffset,
        kAddedEdgeOffset,
        kRemovedTriangles,
        kAddedTriangles,
        kRemovedEdges,
        kAddedEdges,
        kErrorMax,
        kErrorPaper,
        kErrorRiver,
        kLevels,
        kTerrainIndices,
        kRiverIndices,
        kGrid,
        kArrayCount
    };
    static constexpr std::size_t kElementSize[kArrayCount] = {16, 12, 4, 4, 4,  4, 12, 12, 8,
                                                              8,  4,  4, 4, 36, 12, 8, 8};

    std::vector<char> bytes;

    static UlodBytes load(const std::string& path) {
        std::ifstream in(path, std::ios::binary);
        return {std::vector<char>(std::istreambuf_iterator<char>(in), {})};
    }
    bool save(const std::string& path) const {
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        return out.good();
    }

    bool has(std::uint64_t at, std::uint64_t size) const {
        return at <= bytes.size() && size <= bytes.size() - at;
    }
    template <typename T>
    T get(std::uint64_t at) const {
        T v{};
        if (has(at, sizeof(T))) std::memcpy(&v, bytes.data() + at, sizeof(T));
        return v;
    }
    template <typename T>
    void set(std::uint64_t at, T v) {
        if (has(at, sizeof(T))) std::memcpy(bytes.data() + at, &v, sizeof(T));
    }

    static std::uint64_t pad8(std::uint64_t n) { return (n + 7) / 8 * 8; }
    std::uint64_t directoryAt() const {
        return kHeaderSize + pad8(get<std::uint32_t>(kCrsWktSize)) +
               pad8(get<std::uint32_t>(kBuildInfoSize));
    }
    std::uint32_t blockCount() const { return get<std::uint32_t>(kBlockCount); }
    std::uint64_t entry(std::size_t i) const { return directoryAt() + i * kEntrySize; }
    std::uint64_t trailerAt() const { return entry(blockCount()); }
    std::uint64_t blockAt(std::size_t i) const {
        return get<std::uint64_t>(entry(i) + kEntryOffset);
    }
    std::uint64_t blockSize(std::size_t i) const {
        return get<std::uint64_t>(entry(i) + kEntrySizeField);
    }
    std::uint32_t count(std::size_t i, Array a) const {
        return get<std::uint32_t>(blockAt(i) + kCounts + 4 * std::uint64_t(a));
    }
    // File offset of array `a` of block i (each array padded to 8 bytes).
    std::uint64_t arrayAt(std::size_t i, Array a) const {
        std::uint64_t at = blockAt(i) + kBlockHeaderSize;
        for (int k = 0; k < a; ++k)
            at += pad8(std::uint64_t(count(i, Array(k))) * kElementSize[k]);
        return at;
    }

    std::uint32_t crc(std::uint64_t at, std::uint64_t size) const {
        uLong c = crc32(0, nullptr, 0);
        while (size > 0) {
            const uInt chunk = static_cast<uInt>(std::min<std::uint64_t>(size, 1u << 30));
            c = crc32(c, reinterpret_cast<const Bytef*>(bytes.data() + at), chunk);
            at += chunk;
            size -= chunk;
        }
        return static_cast<std::uint32_t>(c);
    }
    // The level table (after the blocks, to the end of the file) and the first level of entry i
    // in it: the entries' levels in directory order.
    std::uint64_t levelTableAt() const { return get<std::uint64_t>(kLevelTableOffset); }
    std::uint64_t levelTableEntry(std::size_t i) const {
        std::uint64_t at = levelTableAt();
        for (std::size_t k = 0; k < i && has(entry(k), kEntrySize); ++k)
            at += kLevelSize * get<std::uint32_t>(entry(k) + 84);  // levelCount
        return at;
    }
    // The level table's CRC into the header, then the header CRC.
    void resealLevelTable() {
        const std::uint64_t at = levelTableAt();
        if (at <= bytes.size()) set<std::uint32_t>(kLevelTableCrc, crc(at, bytes.size() - at));
        resealHeader();
    }
    // The header CRC over everything before the trailer (the directory included).
    void resealHeader() {
        const std::uint64_t trailer = trailerAt();
        if (has(trailer, 8)) set<std::uint32_t>(trailer, crc(0, trailer));
    }
    // Block i's CRC into its directory entry, then the header CRC (which covers the entry).
    void resealBlock(std::size_t i) {
        const std::uint64_t at = blockAt(i), size = blockSize(i);
        if (has(entry(i), kEntrySize) && has(at, size))
            set<std::uint32_t>(entry(i) + kEntryChecksum, crc(at, size));
        resealHeader();
    }
    void resealAll() {
        const std::uint64_t n = blockCount();
        for (std::uint64_t i = 0; i < n && has(entry(i), kEntrySize); ++i) {
            const std::uint64_t at = blockAt(i), size = blockSize(i);
            if (has(at, size)) set<std::uint32_t>(entry(i) + kEntryChecksum, crc(at, size));
        }
        resealLevelTable();
    }
};

}  // namespace unilod::test
