// .ulod v1 reader/writer: round trip, every truncation and every flipped byte rejected, bad
// magic/version/size, hostile directory and counts, atomic writes, validateBlock.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "ulod.h"

using namespace unilod::format;
namespace fs = std::filesystem;

namespace {

// Layout constants from README.md (the test pins the documented layout).
constexpr std::size_t kFileHeaderSize = 152;
constexpr std::size_t kDirEntrySize = 128;
constexpr std::size_t kBlockHeaderSize = 152;

std::size_t align8(std::size_t n) {
    return (n + 7) / 8 * 8;
}

// A square (corners 0..3, locked) with a centre vertex 4 and a vertex 5 inside triangle (0,1,4);
// a river runs 0-5-4-2. Step 0 deletes 5, step 1 deletes 4 (retention order). Coordinates and
// errors vary with the block position so that blocks differ.
Block makeBlock(std::uint32_t col, std::uint32_t row, std::uint32_t metrics, bool allLevels) {
    Block b;
    b.col = col;
    b.row = row;
    b.originX = 1000.0 * col + 0.25;
    b.originY = 2000.0 * row - 0.5;
    const float dz = 3.0f * col + 7.0f * row;
    const std::uint32_t locked = kVertexLocked, river = kVertexRiver;
    b.vertices = {{0, 0, 100 + dz, locked | river},
                  {10, 0, 101 + dz, locked},
                  {10, 10, 102 + dz, locked | river},
                  {0, 10, 103 + dz, locked},
                  {5, 5, 110 + dz, river},
                  {3, 2, 104.5f + dz, river}};
    b.minX = b.originX;
    b.minY = b.originY;
    b.minZ = 100 + dz;
    b.maxX = b.originX + 10;
    b.maxY = b.originY + 10;
    b.maxZ = 110 + dz;

    const std::vector<Triangle> full = {{0, 1, 5}, {1, 4, 5}, {4, 0, 5},
                                        {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
    const std::vector<Triangle> afterStep0 = {{1, 2, 4}, {2, 3, 4}, {3, 0, 4}, {0, 1, 4}};
    const std::vector<Triangle> afterStep1 = {{0, 1, 2}, {0, 2, 3}};
    const std::vector<Edge> riverFull = {{0, 5}, {4, 5}, {2, 4}};
    const std::vector<Edge> river0 = {{2, 4}, {0, 4}};
    const std::vector<Edge> river1 = {{0, 2}};

    b.steps = {{5, 4, 2}, {4, 2, 1}};
    b.removedTriangleOffset = {0, 3, 7};
    b.removedTriangles = {{0, 1, 5}, {1, 4, 5}, {4, 0, 5}, {0, 1, 4},
                          {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
    b.addedTriangleOffset = {0, 1, 3};
    b.addedTriangles = {{0, 1, 4}, {0, 1, 2}, {0, 2, 3}};
    b.removedEdgeOffset = {0, 2, 4};
    b.removedEdges = {{0, 5}, {4, 5}, {0, 4}, {2, 4}};
    b.addedEdgeOffset = {0, 1, 2};
    b.addedEdges = {{0, 4}, {0, 2}};

    const float scale = 1.0f + 0.5f * col + 0.25f * row;
    b.errorMax = {0.0f, 0.5f * scale, 1.5f * scale};
    b.errorRiver = {0.0f, 0.25f * scale, 0.75f * scale};
    if (metrics & kMetricPaper) b.errorPaper = {0.0f, 0.3f * scale, 1.0f * scale};
    auto paper = [&](std::uint32_t s) { return b.errorPaper.empty() ? 0.0f : b.errorPaper[s]; };

    auto addLevel = [&](std::uint32_t step, const std::vector<Triangle>& tris,
                        const std::vector<Edge>& edges) {
        Level l{};
        l.step = step;
        l.vertexCount = 6 - step;
        l.triangleFirst = static_cast<std::uint32_t>(b.terrainIndices.size());
        l.triangleCount = static_cast<std::uint32_t>(tris.size());
        l.riverFirst = static_cast<std::uint32_t>(b.riverIndices.size());
        l.riverCount = static_cast<std::uint32_t>(edges.size());
        l.errorMax = b.errorMax[step];
        l.errorRiver = b.errorRiver[step];
        l.errorPaper = paper(step);
        b.terrainIndices.insert(b.terrainIndices.end(), tris.begin(), tris.end());
        b.riverIndices.insert(b.riverIndices.end(), edges.begin(), edges.end());
        b.levels.push_back(l);
    };
    addLevel(0, full, riverFull);
    if (allLevels) addLevel(1, afterStep0, river0);
    addLevel(2, afterStep1, river1);
    // Grid positions within a grid unit of the float ones (validateBlock), not equal to them.
    for (std::size_t i = 0; i < b.vertices.size(); ++i) {
        b.grid.push_back({static_cast<std::int32_t>(b.vertices[i].x * 1000) - 1,
                          static_cast<std::int32_t>(b.vertices[i].y * 1000) + int(i % 2)});
    }
    return b;
}

Header makeHeader(std::uint32_t metrics) {
    Header h;
    h.crsWkt = "PROJCS[\"WGS 84 / UTM zone 14N\"]";  // 31 bytes: exercises padding
    h.originX = 612345.5;
    h.originY = 3678901.25;
    h.minX = 0;
    h.minY = -0.5;  // the row-0 blocks start there (their boxes lie inside the extents)
    h.minZ = 100;
    h.maxX = 2000;
    h.maxY = 4000;
    h.maxZ = 130;
    h.blocksX = 2;
    h.blocksY = 2;
    h.blockWidth = 1000;
    h.blockHeight = 2000;
    h.metrics = metrics;
    h.defaultMetric = kMetricMax;
    h.buildInfo = R"({"command":"unilod build","version":"0.1.0"})";
    return h;
}

// 2x2 blocks written out of grid order, two with every level and two with a subset.
std::vector<Block> makeBlocks(std::uint32_t metrics) {
    return {makeBlock(1, 0, metrics, true), makeBlock(0, 0, metrics, false),
            makeBlock(0, 1, metrics, true), makeBlock(1, 1, metrics, false)};
}

template <typename T>
bool sameBytes(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() &&
           (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

void expectSameBlock(const Block& a, const Block& b) {
    EXPECT_EQ(a.col, b.col);
    EXPECT_EQ(a.row, b.row);
    EXPECT_EQ(a.originX, b.originX);
    EXPECT_EQ(a.originY, b.originY);
    EXPECT_EQ(a.minX, b.minX);
    EXPECT_EQ(a.minY, b.minY);
    EXPECT_EQ(a.minZ, b.minZ);
    EXPECT_EQ(a.maxX, b.maxX);
    EXPECT_EQ(a.maxY, b.maxY);
    EXPECT_EQ(a.maxZ, b.maxZ);
    EXPECT_TRUE(sameBytes(a.vertices, b.vertices));
    EXPECT_TRUE(sameBytes(a.steps, b.steps));
    EXPECT_EQ(a.removedTriangleOffset, b.removedTriangleOffset);
    EXPECT_EQ(a.addedTriangleOffset, b.addedTriangleOffset);
    EXPECT_EQ(a.removedEdgeOffset, b.removedEdgeOffset);
    EXPECT_EQ(a.addedEdgeOffset, b.addedEdgeOffset);
    EXPECT_TRUE(sameBytes(a.removedTriangles, b.removedTriangles));
    EXPECT_TRUE(sameBytes(a.addedTriangles, b.addedTriangles));
    EXPECT_TRUE(sameBytes(a.removedEdges, b.removedEdges));
    EXPECT_TRUE(sameBytes(a.addedEdges, b.addedEdges));
    EXPECT_EQ(a.errorMax, b.errorMax);
    EXPECT_EQ(a.errorPaper, b.errorPaper);
    EXPECT_TRUE(sameBytes(a.levels, b.levels));
    EXPECT_TRUE(sameBytes(a.terrainIndices, b.terrainIndices));
    EXPECT_TRUE(sameBytes(a.riverIndices, b.riverIndices));
    EXPECT_TRUE(sameBytes(a.grid, b.grid));
    EXPECT_FALSE(a.grid.empty());
}

std::vector<char> readBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeBytes(const std::string& path, const char* data, std::size_t size) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(data, static_cast<std::streamsize>(size));
    ASSERT_TRUE(out.good());
}

// Overwrites one byte of an existing file in place. Rewriting the whole file each time is slow:
// ext4 flushes a file truncated to 0 and rewritten when it is closed.
void patchByte(const std::string& path, std::size_t at, char value) {
    const int fd = ::open(path.c_str(), O_WRONLY);
    ASSERT_GE(fd, 0) << path;
    ASSERT_EQ(::pwrite(fd, &value, 1, static_cast<off_t>(at)), 1);
    ::close(fd);
}

template <typename T>
T load(const std::vector<char>& bytes, std::size_t at) {
    T v;
    std::memcpy(&v, bytes.data() + at, sizeof(T));
    return v;
}

template <typename T>
void store(std::vector<char>& bytes, std::size_t at, T v) {
    std::memcpy(bytes.data() + at, &v, sizeof(T));
}

std::uint32_t crcOf(const std::vector<char>& bytes, std::size_t at, std::size_t size) {
    return static_cast<std::uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(bytes.data() + at), static_cast<uInt>(size)));
}

// Opens the file and reads every block; false with the first error.
bool readAll(const std::string& path, std::string& error) {
    Reader reader;
    if (!reader.open(path, error)) return false;
    for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
        Block b;
        if (!reader.readBlock(i, b, error)) return false;
    }
    return true;
}

class UlodTest : public ::testing::Test {
protected:
    void SetUp() override {
        std::string templ = (fs::temp_directory_path() / "ulod-test-XXXXXX").string();
        ASSERT_NE(::mkdtemp(templ.data()), nullptr);
        dir = templ;
    }
    void TearDown() override { fs::remove_all(dir); }

    std::string file(const std::string& name) const { return (dir / name).string(); }

    // Names in the folder other than `except`: temporary files left behind show up here.
    std::vector<std::string> otherFiles(const std::string& except = "") const {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(dir)) {
            if (e.path().filename() != except) names.push_back(e.path().filename().string());
        }
        return names;
    }

    // Writes the standard 2x2 file and returns its path.
    std::string writeStandard(std::uint32_t metrics = kMetricMax | kMetricPaper) {
        const std::string path = file("model.ulod");
        std::string error;
        EXPECT_TRUE(writeUlod(path, makeHeader(metrics), makeBlocks(metrics), error)) << error;
        return path;
    }

    // Offset of the directory and of the first block in the standard file.
    static std::size_t dirOffset() {
        const Header h = makeHeader(kMetricMax);
        return kFileHeaderSize + align8(h.crsWkt.size()) + align8(h.buildInfo.size());
    }
    static std::size_t dataStart() { return dirOffset() + 4 * kDirEntrySize + 8; }

    fs::path dir;
};

TEST(UlodValidate, SampleBlocksAreValid) {
    std::string error;
    for (const Block& b : makeBlocks(kMetricMax | kMetricPaper)) {
        EXPECT_TRUE(validateBlock(b, kMetricMax | kMetricPaper, error)) << error;
    }
    for (const Block& b : makeBlocks(kMetricMax)) {
        EXPECT_TRUE(validateBlock(b, kMetricMax, error)) << error;
    }
}

TEST_F(UlodTest, RoundTrip) {
    for (const std::uint32_t metrics : {kMetricMax | kMetricPaper, std::uint32_t(kMetricMax)}) {
        SCOPED_TRACE(metrics);
        const Header header = makeHeader(metrics);
        const std::vector<Block> blocks = makeBlocks(metrics);
        const std::string path = file("round.ulod");
        std::string error;
        ASSERT_TRUE(writeUlod(path, header, blocks, error)) << error;

        Reader reader;
        ASSERT_TRUE(reader.open(path, error)) << error;
        EXPECT_EQ(reader.path(), path);
        const Header& h = reader.header();
        EXPECT_EQ(h.crsWkt, header.crsWkt);
        EXPECT_EQ(h.originX, header.originX);
        EXPECT_EQ(h.originY, header.originY);
        EXPECT_EQ(h.minX, header.minX);
        EXPECT_EQ(h.minY, header.minY);
        EXPECT_EQ(h.minZ, header.minZ);
        EXPECT_EQ(h.maxX, header.maxX);
        EXPECT_EQ(h.maxY, header.maxY);
        EXPECT_EQ(h.maxZ, header.maxZ);
        EXPECT_EQ(h.blocksX, header.blocksX);
        EXPECT_EQ(h.blocksY, header.blocksY);
        EXPECT_EQ(h.blockWidth, header.blockWidth);
        EXPECT_EQ(h.blockHeight, header.blockHeight);
        EXPECT_EQ(h.metrics, header.metrics);
        EXPECT_EQ(h.defaultMetric, header.defaultMetric);
        EXPECT_EQ(h.buildInfo, header.buildInfo);

        const std::vector<char> bytes = readBytes(path);
        ASSERT_EQ(reader.blocks().size(), blocks.size());
        for (std::size_t i = 0; i < blocks.size(); ++i) {
            const BlockInfo& info = reader.blocks()[i];
            const Block& b = blocks[i];
            EXPECT_EQ(info.col, b.col);
            EXPECT_EQ(info.row, b.row);
            EXPECT_EQ(info.minX, b.minX);
            EXPECT_EQ(info.minY, b.minY);
            EXPECT_EQ(info.minZ, b.minZ);
            EXPECT_EQ(info.maxX, b.maxX);
            EXPECT_EQ(info.maxY, b.maxY);
            EXPECT_EQ(info.maxZ, b.maxZ);
            EXPECT_EQ(info.offset % 8, 0u);
            EXPECT_EQ(
                info.offset,
                i == 0 ? dataStart() : reader.blocks()[i - 1].offset + reader.blocks()[i - 1].size);
            EXPECT_EQ(info.checksum, crcOf(bytes, info.offset, info.size));
            EXPECT_EQ(info.vertexCount, b.vertices.size());
            EXPECT_EQ(info.stepCount, b.steps.size());
            EXPECT_EQ(info.levelCount, b.levels.size());
            EXPECT_EQ(info.fullTriangles, 6u);
            // Version 5: the origin, the outline flag and the levels without reading the block.
            EXPECT_EQ(info.originX, b.originX);
            EXPECT_EQ(info.originY, b.originY);
            EXPECT_EQ(info.outlineMoves, outlineMoves(b));
            ASSERT_EQ(info.levels.size(), b.levels.size());
            EXPECT_EQ(std::memcmp(info.levels.data(), b.levels.data(),
                                  b.levels.size() * sizeof(Level)),
                      0);

            Block read;
            ASSERT_TRUE(reader.readBlock(i, read, error)) << error;
            expectSameBlock(read, b);
        }
        // The level table follows the last block to the end of the file.
        std::size_t levels = 0;
        for (const Block& b : blocks) levels += b.levels.size();
        EXPECT_EQ(reader.blocks().back().offset + reader.blocks().back().size +
                      align8(levels * sizeof(Level)),
                  bytes.size());
    }
}

TEST_F(UlodTest, EmptyFileRoundTrips) {
    Header header = makeHeader(kMetricPaper);
    header.defaultMetric = kMetricPaper;
    header.crsWkt.clear();
    header.buildInfo.clear();
    const std::string path = file("empty.ulod");
    std::string error;
    ASSERT_TRUE(writeUlod(path, header, {}, error)) << error;
    Reader reader;
    ASSERT_TRUE(reader.open(path, error)) << error;
    EXPECT_TRUE(reader.blocks().empty());
    EXPECT_EQ(reader.header().defaultMetric, std::uint32_t(kMetricPaper));
    EXPECT_EQ(fs::file_size(path), kFileHeaderSize + 8);
}

TEST_F(UlodTest, EveryTruncationRejected) {
    const std::vector<char> bytes = readBytes(writeStandard());
    ASSERT_GT(bytes.size(), dataStart());
    const std::string cut = file("cut.ulod");
    writeBytes(cut, bytes.data(), bytes.size());
    for (std::size_t len = bytes.size(); len-- > 0;) {  // shrink one file: see patchByte
        ASSERT_EQ(::truncate(cut.c_str(), static_cast<off_t>(len)), 0);
        std::string error;
        EXPECT_FALSE(readAll(cut, error)) << "length " << len;
        EXPECT_NE(error.find(cut), std::string::npos) << error;
        if (len >= kFileHeaderSize) {
            EXPECT_NE(error.find("truncated"), std::string::npos) << len << ": " << error;
        }
    }
}

TEST_F(UlodTest, TrailingBytesRejected) {
    std::vector<char> bytes = readBytes(writeStandard());
    for (std::size_t extra : {1, 8, 1000}) {
        std::vector<char> longer = bytes;
        longer.insert(longer.end(), extra, '\0');
        const std::string path = file("long.ulod");
        writeBytes(path, longer.data(), longer.size());
        Reader reader;
        std::string error;
        EXPECT_FALSE(reader.open(path, error));
        EXPECT_NE(error.find("trailing bytes"), std::string::npos) << error;
    }
}

TEST_F(UlodTest, EveryFlippedBlockByteDetected) {
    const std::string path = writeStandard();
    const std::vector<char> bytes = readBytes(path);
    std::vector<BlockInfo> infos;
    {
        Reader reader;
        std::string error;
        ASSERT_TRUE(reader.open(path, error)) << error;
        infos = reader.blocks();
    }
    const std::string bad = file("flip.ulod");
    writeBytes(bad, bytes.data(), bytes.size());
    for (std::size_t i = 0; i < infos.size(); ++i) {
        for (std::uint64_t at = infos[i].offset; at < infos[i].offset + infos[i].size; ++at) {
            patchByte(bad, at, static_cast<char>(bytes[at] ^ 0x5a));

            Reader reader;
            std::string error;
            ASSERT_TRUE(reader.open(bad, error)) << error;  // the header does not cover blocks
            Block b;
            EXPECT_FALSE(reader.readBlock(i, b, error)) << "byte " << at;
            const std::string expected = "block (" + std::to_string(infos[i].col) + "," +
                                         std::to_string(infos[i].row) + "): checksum mismatch";
            EXPECT_NE(error.find(expected), std::string::npos) << error;
            EXPECT_NE(error.find(bad), std::string::npos) << error;
            // The engine's path checks the same checksum, whatever part it reads.
            BlockGeometry g;
            EXPECT_FALSE(reader.readGeometry(i, kLevelsOnly, g, error)) << "byte " << at;
            EXPECT_NE(error.find(expected), std::string::npos) << error;
            // The other blocks are untouched and still read.
            for (std::size_t j = 0; j < infos.size(); ++j) {
                if (j != i) {
                    EXPECT_TRUE(reader.readBlock(j, b, error)) << error;
                }
            }
            patchByte(bad, at, bytes[at]);
        }
    }
}

TEST_F(UlodTest, EveryFlippedHeaderByteRejected) {
    const std::vector<char> bytes = readBytes(writeStandard());
    const std::string bad = file("flip.ulod");
    writeBytes(bad, bytes.data(), bytes.size());
    for (std::size_t at = 0; at < dataStart(); ++at) {
        patchByte(bad, at, static_cast<char>(bytes[at] ^ 0x01));  // one bit: the weakest change
        Reader reader;
        std::string error;
        EXPECT_FALSE(reader.open(bad, error)) << "byte " << at;
        EXPECT_NE(error.find(bad), std::string::npos) << error;
        patchByte(bad, at, bytes[at]);
    }
}

TEST_F(UlodTest, BadMagicRejected) {
    std::vector<char> bytes = readBytes(writeStandard());
    bytes[0] = 'X';
    const std::string path = file("magic.ulod");
    writeBytes(path, bytes.data(), bytes.size());
    Reader reader;
    std::string error;
    EXPECT_FALSE(reader.open(path, error));
    EXPECT_NE(error.find("not a .ulod file"), std::string::npos) << error;

    const std::string text = file("text.ulod");
    writeBytes(text, "hello, world\n", 13);
    EXPECT_FALSE(reader.open(text, error));
    EXPECT_NE(error.find(text + ": not a .ulod file"), std::string::npos) << error;
}

TEST_F(UlodTest, WrongVersionRejectedWithTheVersion) {
    std::vector<char> bytes = readBytes(writeStandard());
    for (std::uint32_t version : {0u, 1u, 3u, 4u, 77u}) {
        store<std::uint32_t>(bytes, 8, version);
        const std::string path = file("version.ulod");
        writeBytes(path, bytes.data(), bytes.size());
        Reader reader;
        std::string error;
        EXPECT_FALSE(reader.open(path, error));
        EXPECT_NE(error.find("unsupported .ulod version " + std::to_string(version) +
                             " (this build reads 5)"),
                  std::string::npos)
            << error;
    }
}

TEST_F(UlodTest, HeaderSizeMismatchRejected) {
    std::vector<char> bytes = readBytes(writeStandard());
    store<std::uint32_t>(bytes, 12, 144);
    const std::string path = file("hsize.ulod");
    writeBytes(path, bytes.data(), bytes.size());
    Reader reader;
    std::string error;
    EXPECT_FALSE(reader.open(path, error));
    EXPECT_NE(error.find("header size 144"), std::string::npos) << error;
}

// Hostile files with valid checksums: the structural checks alone must catch them.
class UlodHostile : public UlodTest {
protected:
    void SetUp() override {
        UlodTest::SetUp();
        bytes = readBytes(writeStandard());
    }
    std::size_t entry(std::size_t i) const { return dirOffset() + i * kDirEntrySize; }
    void resealHeader() {
        const std::size_t trailer = dirOffset() + 4 * kDirEntrySize;
        store<std::uint32_t>(bytes, trailer, crcOf(bytes, 0, trailer));
    }
    void resealBlock(std::size_t i) {
        const auto offset = load<std::uint64_t>(bytes, entry(i) + 56);
        const auto size = load<std::uint64_t>(bytes, entry(i) + 64);
        store<std::uint32_t>(bytes, entry(i) + 72, crcOf(bytes, offset, size));
        resealHeader();
    }
    // Opens the modified file; returns the error of open, or of readBlock(block).
    std::string failure(std::size_t block = 0) {
        const std::string path = file("hostile.ulod");
        writeBytes(path, bytes.data(), bytes.size());
        Reader reader;
        std::string error;
        if (!reader.open(path, error)) return error;
        Block b;
        if (!reader.readBlock(block, b, error)) return error;
        return "";
    }
    std::vector<char> bytes;
};

TEST_F(UlodHostile, Untouched) {
    EXPECT_EQ(failure(), "");
}

// Version 5: the level table after the blocks (each entry's levels, in directory order) and the
// directory's origin and outline flag. The engine draws from them before it reads a block, so
// open checks the table's checksum and rules and readBlock checks all three against the block.
class UlodLevelTable : public UlodHostile {
protected:
    std::uint64_t tableAt() const { return load<std::uint64_t>(bytes, 144); }
    // Level l of entry 0 (its levels come first).
    std::size_t level0(std::size_t l) const { return std::size_t(tableAt()) + l * sizeof(Level); }
    void resealTable() {
        store<std::uint32_t>(bytes, 132, crcOf(bytes, tableAt(), bytes.size() - tableAt()));
        resealHeader();
    }
};

TEST_F(UlodLevelTable, DamageIsCaughtByItsChecksum) {
    bytes[level0(1) + 5] ^= 0x10;
    EXPECT_NE(failure().find("level table checksum mismatch"), std::string::npos) << failure();
}

TEST_F(UlodLevelTable, ItsRulesAreCheckedAtOpen) {
    store<std::uint32_t>(bytes, level0(1), 0);  // level 1's step: not above level 0's
    resealTable();
    EXPECT_NE(failure().find("level table: level 1: step 0 is not above"), std::string::npos)
        << failure();
}

TEST_F(UlodLevelTable, RangesBeyondWhatTheBlockCanHoldAreRefusedAtOpen) {
    // The engine sizes its staging and arena by the levels before it reads the block: a range
    // reaching 4 billion triangles must not get that far.
    store<std::uint32_t>(bytes, level0(1) + offsetof(Level, triangleFirst), 0xFFFFFFF0u);
    resealTable();
    EXPECT_NE(failure().find("level table: its vertices and levels need"), std::string::npos)
        << failure();
}

TEST_F(UlodLevelTable, LevelsThatDifferFromTheBlockFailItsRead) {
    // A larger error at the coarsest level (still non-decreasing): the engine would draw that
    // level at a view the block's own errors allow.
    Reader reader;
    std::string error;
    const std::string path = file("levels.ulod");
    writeBytes(path, bytes.data(), bytes.size());
    ASSERT_TRUE(reader.open(path, error)) << error;
    const std::size_t last = reader.blocks()[0].levelCount - 1;
    const std::size_t at = level0(last) + offsetof(Level, errorMax);
    store<float>(bytes, at, load<float>(bytes, at) + 1.0f);
    resealTable();
    EXPECT_NE(failure(0).find("levels differ from the file's level table"), std::string::npos)
        << failure(0);
}

TEST_F(UlodLevelTable, DirectoryOriginAndOutlineFlagAreCheckedAgainstTheBlock) {
    const std::vector<char> pristine = bytes;
    store<double>(bytes, entry(1) + 104, load<double>(bytes, entry(1) + 104) + 1.0);
    resealHeader();
    EXPECT_NE(failure(1).find("origin differs from the directory"), std::string::npos)
        << failure(1);
    bytes = pristine;
    store<std::uint32_t>(bytes, entry(1) + 120, load<std::uint32_t>(bytes, entry(1) + 120) ^ 1u);
    resealHeader();
    EXPECT_NE(failure(1).find("the directory's outline flag is wrong"), std::string::npos)
        << failure(1);
    bytes = pristine;
    store<std::uint32_t>(bytes, entry(1) + 120, 2u);  // an unknown flag
    resealHeader();
    EXPECT_NE(failure(1).find("unknown flags"), std::string::npos) << failure(1);
}

TEST_F(UlodHostile, DirectoryOutOfBounds) {
    store<std::uint64_t>(bytes, entry(3) + 64, ~std::uint64_t(0) - 4);  // size near 2^64
    resealHeader();
    EXPECT_NE(failure().find("out of bounds"), std::string::npos) << failure();
}

TEST_F(UlodHostile, DirectoryOffsetPastTheEnd) {
    store<std::uint64_t>(bytes, entry(2) + 56, ~std::uint64_t(0) - 7);
    resealHeader();
    EXPECT_NE(failure().find("out of bounds"), std::string::npos) << failure();
}

TEST_F(UlodHostile, DirectoryIntoTheHeader) {
    store<std::uint64_t>(bytes, entry(0) + 56, 8);
    resealHeader();
    EXPECT_NE(failure().find("out of bounds"), std::string::npos) << failure();
}

TEST_F(UlodHostile, DirectoryOverlap) {
    const auto offset0 = load<std::uint64_t>(bytes, entry(0) + 56);
    store<std::uint64_t>(bytes, entry(1) + 56, offset0 + 8);
    store<std::uint64_t>(bytes, entry(1) + 64, kBlockHeaderSize);
    resealHeader();
    EXPECT_NE(failure().find("overlap"), std::string::npos) << failure();
}

TEST_F(UlodHostile, DuplicateBlockPosition) {
    store<std::uint32_t>(bytes, entry(1), load<std::uint32_t>(bytes, entry(0)));
    store<std::uint32_t>(bytes, entry(1) + 4, load<std::uint32_t>(bytes, entry(0) + 4));
    resealHeader();
    EXPECT_NE(failure().find("duplicate"), std::string::npos) << failure();
}

TEST_F(UlodHostile, HugeCountRejectedBeforeAllocation) {
    // vertexCount = 2^32 - 1 would be a 64 GiB allocation if trusted.
    const auto offset = load<std::uint64_t>(bytes, entry(0) + 56);
    store<std::uint32_t>(bytes, offset + 72, 0xffffffffu);
    resealBlock(0);
    EXPECT_NE(failure().find("counts need"), std::string::npos) << failure();
}

TEST_F(UlodHostile, ShiftedCountsRejected) {
    // 7 removed + 3 added triangles -> 5 + 5 keeps the padded byte size (88 + 40 = 64 + 64):
    // only validateBlock can catch it.
    const auto offset = load<std::uint64_t>(bytes, entry(0) + 56);
    const std::size_t removedTriangles = offset + 72 + 6 * 4, addedTriangles = removedTriangles + 4;
    ASSERT_EQ(load<std::uint32_t>(bytes, removedTriangles), 7u);
    ASSERT_EQ(load<std::uint32_t>(bytes, addedTriangles), 3u);
    store<std::uint32_t>(bytes, removedTriangles, 5);
    store<std::uint32_t>(bytes, addedTriangles, 5);
    resealBlock(0);
    const std::string error = failure();
    EXPECT_NE(error.find("block (1,0)"), std::string::npos) << error;
    EXPECT_NE(error.find("TriangleOffset"), std::string::npos) << error;
}

TEST_F(UlodHostile, BlockHeaderReservedWordMustBeZero) {
    // Version 4's block header ends in a reserved word (offset 148), which a reader must see 0.
    const auto offset = load<std::uint64_t>(bytes, entry(0) + 56);
    ASSERT_EQ(load<std::uint32_t>(bytes, offset + 148), 0u);
    store<std::uint32_t>(bytes, offset + 148, 1);
    resealBlock(0);
    const std::string error = failure();
    EXPECT_NE(error.find("reserved block header field not 0"), std::string::npos) << error;
}

// The river part of errorMax may not exceed it (the raw errorRiver array, right after
// errorPaper: both 3 floats, padded to 16 bytes).
TEST_F(UlodHostile, RiverPartAboveTheMaxErrorRejected) {
    const auto offset = load<std::uint64_t>(bytes, entry(0) + 56);
    std::uint64_t at = offset + kBlockHeaderSize;
    const std::size_t sizes[13] = {16, 12, 4, 4, 4, 4, 12, 12, 8, 8, 4, 4, 4};
    for (int i = 0; i < 12; ++i)
        at += (std::uint64_t(load<std::uint32_t>(bytes, offset + 72 + 4 * i)) * sizes[i] + 7) / 8 * 8;
    ASSERT_EQ(load<std::uint32_t>(bytes, offset + 72 + 4 * 12), 3u);  // errorRiverCount
    store<float>(bytes, at + 8, 1e6f);  // errorRiver[2], above errorMax[2]
    resealBlock(0);
    const std::string error = failure();
    EXPECT_NE(error.find("errorRiver[2] exceeds errorMax[2]"), std::string::npos) << error;
}

TEST_F(UlodHostile, IndexOutOfRangeInFileRejected) {
    // The last river index of the block (level 2's edge (0,2)): make it (0,200). The grid array
    // (8 bytes per vertex) follows the river indices.
    const auto offset = load<std::uint64_t>(bytes, entry(0) + 56);
    const auto size = load<std::uint64_t>(bytes, entry(0) + 64);
    const auto vertexCount = load<std::uint32_t>(bytes, offset + 72);
    store<std::uint32_t>(bytes, offset + size - 8 * std::uint64_t(vertexCount) - 4, 200);
    resealBlock(0);
    const std::string error = failure();
    EXPECT_NE(error.find("level 2 river"), std::string::npos) << error;
}

// The header's values and the directory's boxes (Reader::open), with the header CRC recomputed.
TEST_F(UlodHostile, NonFiniteOrInvertedHeaderValues) {
    const std::vector<char> original = bytes;
    for (std::size_t at : {24, 40, 56, 80, 88, 96}) {  // originX, minX, minZ, maxZ, block size
        bytes = original;
        store<double>(bytes, at, std::numeric_limits<double>::quiet_NaN());
        resealHeader();
        EXPECT_NE(failure().find("is not finite"), std::string::npos) << at << ": " << failure();
        bytes = original;
        store<double>(bytes, at, -std::numeric_limits<double>::infinity());
        resealHeader();
        EXPECT_NE(failure().find("is not finite"), std::string::npos) << at << ": " << failure();
    }
    bytes = original;
    store<double>(bytes, 40, 5000.0);  // minX above maxX (2000)
    resealHeader();
    EXPECT_NE(failure().find("extents are inverted"), std::string::npos) << failure();
}

TEST_F(UlodHostile, BlockSizeNotPositive) {
    for (double width : {0.0, -1000.0}) {
        store<double>(bytes, 88, width);
        resealHeader();
        EXPECT_NE(failure().find("is not positive"), std::string::npos) << failure();
    }
}

TEST_F(UlodHostile, GridLargerThanTheFile) {
    store<std::uint32_t>(bytes, 104, 0xffffffffu);
    store<std::uint32_t>(bytes, 108, 0xffffffffu);
    resealHeader();
    EXPECT_NE(failure().find("4294967295x4294967295 has more cells than the file has bytes"),
              std::string::npos)
        << failure();
}

TEST_F(UlodHostile, DirectoryBoxOutsideTheExtents) {
    // Entry 2 is block (0,1): y from 1999.5; the header's minY is -0.5. Below it, then NaN.
    store<double>(bytes, entry(2) + 16, -1.0);
    resealHeader();
    EXPECT_NE(failure().find("(block (0,1)): bounding box is not finite, inverted or outside"),
              std::string::npos)
        << failure();
    store<double>(bytes, entry(2) + 16, std::numeric_limits<double>::quiet_NaN());
    resealHeader();
    EXPECT_NE(failure().find("bounding box is not finite"), std::string::npos) << failure();
}

// A block changed with its CRC recomputed: the semantic checks of readBlock and readGeometry.
TEST_F(UlodHostile, BlockSemanticsCheckedOnEveryReadPath) {
    const auto offset = load<std::uint64_t>(bytes, entry(0) + 56);
    store<double>(bytes, offset + 8, std::numeric_limits<double>::quiet_NaN());  // originX
    resealBlock(0);
    EXPECT_NE(failure().find("block (1,0): origin"), std::string::npos) << failure();
    const std::string path = file("hostile.ulod");
    Reader reader;
    std::string error;
    ASSERT_TRUE(reader.open(path, error)) << error;
    for (int level : {kLevelsOnly, kAllLevels, 0}) {
        BlockGeometry g;
        EXPECT_FALSE(reader.readGeometry(0, level, g, error));
        EXPECT_NE(error.find(path + ": block (1,0): origin"), std::string::npos) << error;
    }
}

TEST_F(UlodTest, MissingFileRejected) {
    Reader reader;
    std::string error;
    const std::string path = file("nope.ulod");
    EXPECT_FALSE(reader.open(path, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
}

TEST_F(UlodTest, UnwritablePathRejected) {
    const std::string path = file("no/such/folder/model.ulod");
    std::string error;
    EXPECT_FALSE(writeUlod(path, makeHeader(kMetricMax), makeBlocks(kMetricMax), error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_FALSE(fs::exists(path));
    EXPECT_TRUE(otherFiles().empty());
}

TEST_F(UlodTest, FailedWriteLeavesOldFileAndNoTemporary) {
    const std::string path = writeStandard();
    const std::vector<char> before = readBytes(path);

    std::vector<Block> blocks = makeBlocks(kMetricMax | kMetricPaper);
    blocks[2].terrainIndices[0].b = 99;  // rejected by validateBlock after two blocks are written
    std::string error;
    EXPECT_FALSE(writeUlod(path, makeHeader(kMetricMax | kMetricPaper), blocks, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("block (0,1)"), std::string::npos) << error;
    EXPECT_EQ(readBytes(path), before);
    EXPECT_TRUE(otherFiles("model.ulod").empty());

    // Same failure with no previous file: nothing at all is left.
    const std::string fresh = file("fresh.ulod");
    EXPECT_FALSE(writeUlod(fresh, makeHeader(kMetricMax | kMetricPaper), blocks, error));
    EXPECT_FALSE(fs::exists(fresh));
    EXPECT_TRUE(otherFiles("model.ulod").empty());
}

TEST_F(UlodTest, OverwriteReplacesTheFile) {
    const std::string path = writeStandard();
    std::string error;
    ASSERT_TRUE(writeUlod(path, makeHeader(kMetricMax), makeBlocks(kMetricMax), error)) << error;
    Reader reader;
    ASSERT_TRUE(reader.open(path, error)) << error;
    EXPECT_EQ(reader.header().metrics, std::uint32_t(kMetricMax));
    EXPECT_TRUE(otherFiles("model.ulod").empty());
}

TEST_F(UlodTest, BadHeaderOrGridRejectedByWriter) {
    const std::string path = file("bad.ulod");
    std::string error;
    Header header = makeHeader(kMetricMax);
    header.defaultMetric = kMetricPaper;  // not in the mask
    EXPECT_FALSE(writeUlod(path, header, makeBlocks(kMetricMax), error));
    EXPECT_NE(error.find("default metric"), std::string::npos) << error;

    header = makeHeader(kMetricMax);
    header.blocksX = 1;
    EXPECT_FALSE(writeUlod(path, header, makeBlocks(kMetricMax), error));
    EXPECT_NE(error.find("outside"), std::string::npos) << error;

    std::vector<Block> blocks = makeBlocks(kMetricMax);
    blocks[3].col = 0;
    blocks[3].row = 0;
    EXPECT_FALSE(writeUlod(path, makeHeader(kMetricMax), blocks, error));
    EXPECT_NE(error.find("duplicate block position"), std::string::npos) << error;

    // What the reader would reject is not written either.
    header = makeHeader(kMetricMax);
    header.minZ = std::numeric_limits<double>::quiet_NaN();
    EXPECT_FALSE(writeUlod(path, header, makeBlocks(kMetricMax), error));
    EXPECT_NE(error.find("header minZ is not finite"), std::string::npos) << error;
    header = makeHeader(kMetricMax);
    header.maxX = 1005;  // the blocks of column 1 reach 1010.25
    EXPECT_FALSE(writeUlod(path, header, makeBlocks(kMetricMax), error));
    EXPECT_NE(error.find("outside the header's extents"), std::string::npos) << error;
    EXPECT_TRUE(otherFiles().empty());
}

// ---- validateBlock on hand-made errors -----------------------------------------------------

class UlodValidateError : public ::testing::Test {
protected:
    std::string check(const Block& b, std::uint32_t metrics = kMetricMax | kMetricPaper) {
        std::string error;
        return validateBlock(b, metrics, error) ? "" : error;
    }
    Block block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
};

TEST_F(UlodValidateError, RecordIndexOutOfRange) {
    block.removedTriangles[1].c = 6;  // only 6 vertices
    const std::string error = check(block);
    EXPECT_NE(error.find("block (1,0): step 0 removed: triangle"), std::string::npos) << error;
}

TEST_F(UlodValidateError, AddedTriangleUsesDeletedVertex) {
    block.addedTriangles[0].c = 5;  // vertex 5 is gone after step 0
    EXPECT_NE(check(block).find("step 0 added"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, NonMonotoneOffsets) {
    block.removedTriangleOffset = {0, 8, 7};
    EXPECT_NE(check(block).find("removedTriangleOffset decreases"), std::string::npos)
        << check(block);
}

TEST_F(UlodValidateError, OffsetsNotMatchingTheirArray) {
    block.addedEdges.push_back({0, 1});
    EXPECT_NE(check(block).find("addedEdgeOffset ends at 2"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, DecreasingErrors) {
    block.errorPaper[2] = 0.1f;
    EXPECT_NE(check(block).find("errorPaper decreases at step 2"), std::string::npos)
        << check(block);
}

TEST_F(UlodValidateError, NonFiniteError) {
    block.errorMax[1] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_NE(check(block).find("errorMax[1]"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, ErrorCountsMatchMetrics) {
    EXPECT_NE(check(block, kMetricMax).find("errorPaper has 3 entries"), std::string::npos);
    block.errorMax.pop_back();
    EXPECT_NE(check(block).find("errorMax has 2 entries"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, LevelRangeOutsideIndexArrays) {
    block.levels[2].triangleFirst = 11;  // 11 + 2 > 12 terrain triangles
    EXPECT_NE(check(block).find("level 2: terrain range"), std::string::npos) << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.levels[1].riverFirst = 0xffffffffu;  // must not wrap around
    EXPECT_NE(check(block).find("level 1: river range"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, LevelIndexAtOrAboveVertexCount) {
    // Level 2 keeps 4 vertices: index 4 is alive in level 0 but not here.
    block.terrainIndices[block.levels[2].triangleFirst].b = 4;
    EXPECT_NE(check(block).find("level 2 terrain: triangle (0,4,2) has an index >= 4"),
              std::string::npos)
        << check(block);
}

TEST_F(UlodValidateError, LevelsNotAscending) {
    std::swap(block.levels[1], block.levels[2]);
    EXPECT_NE(check(block).find("level 2: step 1 is not above"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, MissingFullResolutionLevel) {
    block.levels.erase(block.levels.begin());
    EXPECT_NE(check(block).find("levels[0].step is 1"), std::string::npos) << check(block);
    block.levels.clear();
    EXPECT_NE(check(block).find("no levels"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, StepCountsInconsistent) {
    block.steps[1].trianglesAlive = 3;
    EXPECT_NE(check(block).find("step 1: trianglesAlive is 3"), std::string::npos) << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.steps[0].vertex = 4;  // retention order: step 0 deletes the last vertex
    EXPECT_NE(check(block).find("step 0 deletes vertex 4"), std::string::npos) << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.vertices[4].flags |= kVertexLocked;  // deleted by step 1
    EXPECT_NE(check(block).find("step 1 deletes locked vertex 4"), std::string::npos)
        << check(block);
}

TEST_F(UlodValidateError, LevelVertexCountAndErrors) {
    block.levels[1].vertexCount = 6;
    EXPECT_NE(check(block).find("level 1: vertexCount 6"), std::string::npos) << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.levels[1].errorMax = 9;  // above level 2's: the level table's own rule
    EXPECT_NE(check(block).find("level 2: an error is not finite, negative or below the level "
                                "before"),
              std::string::npos)
        << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    // Monotone and above the river part, but not the error table's value at the level's step.
    block.levels[1].errorMax = std::max(block.levels[0].errorMax, block.levels[1].errorRiver);
    ASSERT_LT(block.levels[1].errorMax, block.errorMax[block.levels[1].step]);
    EXPECT_NE(check(block).find("level 1: errors differ"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, RiverEdgeNotOrdered) {
    block.riverIndices[0] = {5, 0};
    EXPECT_NE(check(block).find("level 0 river: edge (5,0)"), std::string::npos) << check(block);
}

// ---- the level geometry and the vertices (validateLevelGeometry, validateBlock) -------------

TEST_F(UlodValidateError, FlippedTriangle) {
    std::swap(block.terrainIndices[0].b, block.terrainIndices[0].c);  // level 0: (0,1,5)
    EXPECT_NE(check(block).find("block (1,0): level 0: triangle (0,5,1) is not counter-clockwise"),
              std::string::npos)
        << check(block);
    // Without grid positions the orientation is not proved, but the flipped triangle's edges run
    // the same way as its neighbours'.
    block.grid.clear();
    EXPECT_NE(check(block).find("level 0: edge"), std::string::npos) << check(block);
    EXPECT_NE(check(block).find("in the same direction"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, DuplicatedTriangle) {
    block.terrainIndices[1] = block.terrainIndices[0];
    EXPECT_NE(check(block).find("level 0: edge 0->1 is used by two triangles in the same "
                                "direction"),
              std::string::npos)
        << check(block);
}

TEST_F(UlodValidateError, DegenerateTriangle) {
    block.terrainIndices[0].c = 1;
    EXPECT_NE(check(block).find("level 0: triangle (0,1,1) repeats a vertex"), std::string::npos)
        << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.grid[5] = block.grid[1];  // vertex 5 moved onto vertex 1: (0,1,5) has no area
    block.vertices[5].x = float(block.grid[5].x * 1e-3);
    block.vertices[5].y = float(block.grid[5].y * 1e-3);
    EXPECT_NE(check(block).find("triangle (0,1,5) is not counter-clockwise"), std::string::npos)
        << check(block);
}

TEST_F(UlodValidateError, RiverEdgeNotOnTheLevelsTriangles) {
    block.riverIndices[0] = {1, 3};  // level 0: the diagonal 1-3 is no edge
    EXPECT_NE(
        check(block).find("level 0: river edge (1,3) is not an edge of the level's triangles"),
        std::string::npos)
        << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.riverIndices[1] = block.riverIndices[0];
    EXPECT_NE(check(block).find("level 0: river edge (0,5) appears twice"), std::string::npos)
        << check(block);
}

TEST_F(UlodValidateError, VertexOutsideTheBoxBeyondTheTolerance) {
    // Vertex 4 holds the maximum z. The box may miss it by the float rounding the format allows
    // (kFloatSlack * |z| + kAbsoluteSlack), not more.
    const double z = block.vertices[4].z;
    const double slack = kFloatSlack * z + kAbsoluteSlack;
    block.maxZ = z - 0.5 * slack;
    EXPECT_EQ(check(block), "");
    block.maxZ = z - 2 * slack;
    EXPECT_NE(check(block).find("block (1,0): vertex 4 ("), std::string::npos) << check(block);
    EXPECT_NE(check(block).find("lies outside the block's bounding box"), std::string::npos);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.vertices[2].x = 10.5f;  // the box ends at x = 10
    EXPECT_NE(check(block).find("vertex 2 ("), std::string::npos) << check(block);
    // x, y may miss the box by a grid unit (1 mm): built vertices sit on their grid position.
    ASSERT_FALSE(block.grid.empty());
    block.vertices[2].x = 10.0009f;
    block.grid[2].x = 10001;
    EXPECT_EQ(check(block), "");
    block.vertices[2].x = 10.0021f;
    block.grid[2].x = 10002;
    EXPECT_NE(check(block).find("vertex 2 ("), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, BoxAndOrigin) {
    block.originX = std::numeric_limits<double>::quiet_NaN();
    EXPECT_NE(check(block).find("block (1,0): origin (nan"), std::string::npos) << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.originY = block.maxY + 1;
    EXPECT_NE(check(block).find("lies outside the bounding box"), std::string::npos)
        << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.minZ = block.maxZ + 1;
    EXPECT_NE(check(block).find("bounding box is not finite or inverted"), std::string::npos)
        << check(block);
}

TEST_F(UlodValidateError, GridPositionFarFromTheFloatOne) {
    block.grid[4].x += 3;  // 3 mm: more than a grid unit
    EXPECT_NE(check(block).find("vertex 4: float position"), std::string::npos) << check(block);
    block = makeBlock(1, 0, kMetricMax | kMetricPaper, true);
    block.grid[4].y = 1 << 28;  // beyond the exact range of orient2d
    EXPECT_NE(check(block).find("vertex 4: grid position"), std::string::npos) << check(block);
}

TEST_F(UlodValidateError, LevelGeometryOnItsOwn) {
    std::string error;
    for (std::size_t l = 0; l < block.levels.size(); ++l)
        EXPECT_TRUE(validateLevelGeometry(block, l, error)) << error;
    EXPECT_FALSE(validateLevelGeometry(block, block.levels.size(), error));
    block.levels[2].triangleFirst = 0xfffffff0u;  // a range outside the arrays: no read
    EXPECT_FALSE(validateLevelGeometry(block, 2, error));
    EXPECT_NE(error.find("level 2: its vertices or index ranges lie outside"), std::string::npos)
        << error;
}

}  // namespace
