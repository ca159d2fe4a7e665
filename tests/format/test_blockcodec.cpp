// The compact block encoding (issue 19, format/blockcodec.h): a real model (a synthetic world with
// rivers, a few blocks and their tree nodes) is built twice, compact and raw; every block decodes
// to exactly the arrays the raw file stores (the uncompressed replay), `check` replays the
// compact file, the stored errors carry the z quantum, and damaged compact data is rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "blockcodec.h"
#include "build.h"
#include "synthbuild.h"
#include "testutil.h"
#include "ulod.h"
#include "ulodbytes.h"
#include "ulodcheck.h"

using namespace unilod;
using unilod::test::UlodBytes;

namespace {

class BlockCodec : public ::testing::Test {
protected:
    static inline test::TempDir* dir = nullptr;
    static inline std::string compact, raw;

    static void SetUpTestSuite() {
        dir = new test::TempDir("blockcodec");
        BuildOptions o;
        std::string error;
        ASSERT_TRUE(test::writeTwoByTwoWorld(*dir, 6000, 11, o, error)) << error;
        o.threads = 2;
        BuildSummary summary;
        compact = o.outPath = dir->file("compact.ulod");
        ASSERT_TRUE(runBuild(o, summary, error)) << error;
        raw = o.outPath = dir->file("raw.ulod");
        o.rawBlocks = true;
        ASSERT_TRUE(runBuild(o, summary, error)) << error;
    }
    static void TearDownTestSuite() {
        delete dir;
        dir = nullptr;
    }
};

template <class T>
void expectSame(const std::vector<T>& a, const std::vector<T>& b, const char* what) {
    ASSERT_EQ(a.size(), b.size()) << what;
    EXPECT_TRUE(a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0) << what;
}

TEST_F(BlockCodec, EveryBlockDecodesToTheUncompressedReplay) {
    format::Reader c, r;
    std::string error;
    ASSERT_TRUE(c.open(compact, error)) << error;
    ASSERT_TRUE(r.open(raw, error)) << error;
    ASSERT_GE(c.blocks().size(), 5u);  // at least 2 x 2 blocks and a tree node
    EXPECT_GT(c.blocks().back().level, 0u);
    ASSERT_EQ(r.blocks().size(), c.blocks().size());
    EXPECT_EQ(c.header().zQuantum, format::kDefaultZQuantum);
    std::uint64_t compactBytes = 0, rawBytes = 0, compactBlocks = 0;
    for (std::size_t i = 0; i < c.blocks().size(); ++i) {
        SCOPED_TRACE("block " + std::to_string(i));
        compactBytes += c.blocks()[i].size;
        rawBytes += r.blocks()[i].size;
        compactBlocks += c.blocks()[i].encoding == std::uint32_t(format::BlockEncoding::kCompact);
        EXPECT_EQ(r.blocks()[i].encoding, std::uint32_t(format::BlockEncoding::kRaw));
        // Never larger than raw (a tiny block whose streams cost more is stored raw).
        EXPECT_LE(c.blocks()[i].size, r.blocks()[i].size);
        format::Block a, b;
        ASSERT_TRUE(c.readBlock(i, a, error)) << error;
        ASSERT_TRUE(r.readBlock(i, b, error)) << error;
        expectSame(a.vertices, b.vertices, "vertices");
        expectSame(a.grid, b.grid, "grid");
        expectSame(a.steps, b.steps, "steps");
        expectSame(a.removedTriangleOffset, b.removedTriangleOffset, "removed offsets");
        expectSame(a.addedTriangleOffset, b.addedTriangleOffset, "added offsets");
        expectSame(a.removedEdgeOffset, b.removedEdgeOffset, "removed edge offsets");
        expectSame(a.addedEdgeOffset, b.addedEdgeOffset, "added edge offsets");
        expectSame(a.removedTriangles, b.removedTriangles, "removed triangles");
        expectSame(a.addedTriangles, b.addedTriangles, "added triangles");
        expectSame(a.removedEdges, b.removedEdges, "removed edges");
        expectSame(a.addedEdges, b.addedEdges, "added edges");
        expectSame(a.errorMax, b.errorMax, "max errors");
        expectSame(a.errorPaper, b.errorPaper, "paper errors");
        expectSame(a.levels, b.levels, "levels");
        expectSame(a.terrainIndices, b.terrainIndices, "terrain indices");
        expectSame(a.riverIndices, b.riverIndices, "river indices");
        EXPECT_TRUE(format::sameArrays(a, b));
        // Heights on the quantum; errors include it and are rounded to the stored precision.
        for (const format::Vertex& v : a.vertices)
            ASSERT_EQ(double(v.z), format::quantizeZ(v.z, format::kDefaultZQuantum));
        ASSERT_FALSE(a.errorMax.empty());
        EXPECT_GE(a.errorMax[0], format::kDefaultZQuantum);
        for (float e : a.errorMax)
            ASSERT_EQ(e, format::quantizeError(e, format::kDefaultZQuantum));
    }
    // Every block with deletion steps is compact, and the whole is far smaller than raw.
    EXPECT_GE(compactBlocks, c.blocks().size() - 2);
    EXPECT_LT(compactBytes * 8, rawBytes);
}

// A valid block whose levels store their triangles in another order than the paired layout (here
// two triangles of the full-resolution level swapped) is not in canonical form: the writer stores
// it raw, and it reads back exactly.
TEST_F(BlockCodec, ReorderedLevelIsStoredRaw) {
    format::Reader r;
    std::string error;
    ASSERT_TRUE(r.open(raw, error)) << error;
    format::Block b;
    ASSERT_TRUE(r.readBlock(0, b, error)) << error;
    std::vector<unsigned char> bytes;
    ASSERT_TRUE(format::encodeCompact(b, r.header().zQuantum, bytes, error)) << error;
    const format::Level& full = b.levels[0];
    ASSERT_GE(full.triangleCount, 2u);
    std::swap(b.terrainIndices[full.triangleFirst], b.terrainIndices[full.triangleFirst + 1]);
    ASSERT_TRUE(format::validateBlock(b, r.header().metrics, error)) << error;
    std::string why;
    EXPECT_FALSE(format::encodeCompact(b, r.header().zQuantum, bytes, why));
    EXPECT_NE(why.find("paired layout"), std::string::npos) << why;
    const std::string path = dir->file("reordered.ulod");
    format::Header h = r.header();
    ASSERT_TRUE(format::writeUlod(path, h, {b}, error)) << error;
    format::Reader back;
    ASSERT_TRUE(back.open(path, error)) << error;
    EXPECT_EQ(back.blocks()[0].encoding, std::uint32_t(format::BlockEncoding::kRaw));
    format::Block read;
    ASSERT_TRUE(back.readBlock(0, read, error)) << error;
    EXPECT_TRUE(format::sameArrays(read, b));
}

TEST_F(BlockCodec, CheckReplaysTheCompactFile) {
    UlodCheckOptions o;
    o.errors = true;
    UlodCheckSummary s;
    std::string error;
    ASSERT_TRUE(checkUlod(compact, o, s, error)) << error;
    EXPECT_GE(s.blocks, 5u);
}

TEST(BlockCodecUnit, QuantizedErrorsRoundUpMonotonically) {
    const double q = format::kDefaultZQuantum;
    float lastQ = 0;
    for (double e = 0; e < 5000; e = e * 1.37 + 0.0013) {
        const float x = format::quantizeError(e, q);
        EXPECT_GE(double(x), e);
        EXPECT_LT(double(x), e + q);
        EXPECT_EQ(double(x) / q, std::floor(double(x) / q));
        EXPECT_GE(x, lastQ);
        lastQ = x;
    }
    EXPECT_EQ(format::quantizeError(2.0, q), 2.0f);
    EXPECT_EQ(format::quantizeError(2.0001, q), float(2 + q));
    EXPECT_EQ(format::quantizeZ(312.4, q), 312.3984375);
    EXPECT_EQ(format::quantizeZ(-0.003, q), 0.0);
    EXPECT_EQ(format::quantizeZ(-0.004, q), -q);
}

// A block not in canonical form (here: no grid positions) is stored raw, and reads back.
TEST(BlockCodecUnit, NonCanonicalBlockIsStoredRaw) {
    format::Block b;
    b.vertices = {{0, 0, 1, format::kVertexLocked}, {1, 0, 1, format::kVertexLocked},
                  {0, 1, 1, format::kVertexLocked}};
    b.maxX = b.maxY = 1;
    b.minZ = b.maxZ = 1;
    b.removedTriangleOffset = b.addedTriangleOffset = b.removedEdgeOffset = b.addedEdgeOffset = {0};
    b.errorMax = b.errorRiver = {0};
    b.levels = {{0, 3, 0, 1, 0, 0, 0, 0, 0}};
    b.terrainIndices = {{0, 1, 2}};
    std::vector<unsigned char> bytes;
    std::string why;
    EXPECT_FALSE(format::encodeCompact(b, format::kDefaultZQuantum, bytes, why));
    EXPECT_NE(why.find("grid"), std::string::npos) << why;

    test::TempDir dir("blockcodec-raw");
    format::Header h;
    h.maxX = h.maxY = 1;
    h.minZ = h.maxZ = 1;
    h.blocksX = h.blocksY = 1;
    h.blockWidth = h.blockHeight = 1;
    h.metrics = format::kMetricMax;
    std::string error;
    ASSERT_TRUE(format::writeUlod(dir.file("r.ulod"), h, {b}, error)) << error;
    format::Reader r;
    ASSERT_TRUE(r.open(dir.file("r.ulod"), error)) << error;
    EXPECT_EQ(r.blocks()[0].encoding, std::uint32_t(format::BlockEncoding::kRaw));
    format::Block back;
    ASSERT_TRUE(r.readBlock(0, back, error)) << error;
    EXPECT_TRUE(format::sameArrays(back, b));
}

// Damaged compact data WITH its checksums recomputed: every truncation of a block's payload and
// every single-byte change in it ends in a clean error naming the block, or (a change zstd and the
// replay cannot see) in a block that passes validateBlock. Never a crash or a sanitizer report.
TEST_F(BlockCodec, DamagedPayloadEndsCleanly) {
    const UlodBytes pristine = UlodBytes::load(compact);
    const std::size_t i = 1;
    const std::uint64_t at = pristine.blockAt(i) + UlodBytes::kBlockHeaderSize;
    const auto payload = pristine.get<std::uint32_t>(pristine.blockAt(i) + UlodBytes::kPayloadSize);
    ASSERT_GT(payload, 100u);
    const std::string path = dir->file("damaged.ulod");
    std::size_t rejected = 0, accepted = 0;
    auto run = [&](const UlodBytes& f) {
        ASSERT_TRUE(f.save(path));
        format::Reader r;
        std::string error;
        ASSERT_TRUE(r.open(path, error)) << error;
        format::Block b;
        if (r.readBlock(i, b, error)) {
            ++accepted;
            EXPECT_TRUE(format::validateBlock(b, r.header().metrics, error)) << error;
        } else {
            ++rejected;
            EXPECT_EQ(error.rfind(path + ": block (", 0), 0u) << error;
        }
    };
    // Every truncation of the payload, given to the decoder directly with the block's counts.
    {
        format::Reader r;
        std::string error;
        ASSERT_TRUE(r.open(compact, error)) << error;
        format::Block b;
        ASSERT_TRUE(r.readBlock(i, b, error)) << error;
        const format::BlockCounts counts = format::countsOf(b);
        const auto* data = reinterpret_cast<const unsigned char*>(pristine.bytes.data() + at);
        format::Block out;
        ASSERT_TRUE(format::decodeCompact(data, payload, counts, format::kDefaultZQuantum, out, error))
            << error;
        EXPECT_TRUE(format::sameArrays(out, b));
        for (std::uint32_t cut = 0; cut < payload; ++cut) {
            EXPECT_FALSE(format::decodeCompact(data, cut, counts, format::kDefaultZQuantum, out, error))
                << cut;
        }
    }
    // Bytes changed (stride through the payload, three kinds of change).
    for (std::uint64_t k = 0; k < payload; k += 1 + payload / 400) {
        for (unsigned char x : {0x01, 0x80, 0xFF}) {
            UlodBytes f = pristine;
            f.bytes[at + k] = char(f.bytes[at + k] ^ x);
            f.resealAll();
            run(f);
            if (HasFatalFailure()) return;
        }
    }
    EXPECT_GT(rejected, 0u);
    std::printf("damaged payloads: %zu rejected, %zu accepted as valid blocks\n", rejected, accepted);
}

}  // namespace
