// Deterministic mutation fuzzing of every .ulod reader path (issue 16, part 5): Reader::open,
// readBlock, readGeometry (all levels, one level, levels only), hence validateBlock and
// validateLevelGeometry, the engine loader's refinement tables and a refined mesh of every block
// the reader accepts (engine/lod/refine.h), and `unilod check`'s deeper replay (checkUlod) on
// whatever the reader accepts. The seeds are a small synthetic model with rivers (2 x 2 blocks)
// built here twice: with compact blocks (format/blockcodec.h, the default: mutations reach the zstd
// streams and the record replay) and with raw blocks (the field-aware array edits below apply to
// those). Each case applies 1 to 3 mutations: bit flips, bytes and words set to interesting values
// (0, -1, NaN, infinities, huge counts), field-aware edits of the header, the directory and a
// block's arrays (an index moved to another vertex, a triangle flipped or duplicated, a vertex or
// grid position nudged across its tolerance), truncation or extension; then, in 3 cases out of 4,
// every block CRC and the header CRC are recomputed (tests/ulodbytes.h), so that the semantic
// checks are exercised and not only the checksums. Every case must end without a crash or sanitizer
// report in a clean error naming the file (and the block), or in a file whose blocks all pass
// validateBlock again and read the same through readGeometry.
//
// Bounded by default (ctest, also under ASan/UBSan). Environment:
//   UNILOD_FUZZ_CASES=N     number of cases (default kDefaultCases)
//   UNILOD_FUZZ_SECONDS=S   run for S seconds instead (with UNILOD_FUZZ_CASES: whichever ends
//                           first); the long run: UNILOD_FUZZ_SECONDS=600
//                           build/tests/test_fuzz_ulod
//   UNILOD_FUZZ_SEED=K      another deterministic sequence (default 1)
//   UNILOD_FUZZ_LAST=PATH   each case's input is written there before it runs: after a crash,
//                           PATH holds the input that crashed
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>

#include "build.h"
#include "refine.h"
#include "synthbuild.h"
#include "testutil.h"
#include "ulod.h"
#include "ulodbytes.h"
#include "ulodcheck.h"

using namespace unilod;
using unilod::test::Rng;
using unilod::test::UlodBytes;

namespace {

constexpr std::uint64_t kDefaultCases = 1500;

std::uint64_t envNumber(const char* name, std::uint64_t fallback) {
    const char* v = std::getenv(name);
    return v && *v ? std::strtoull(v, nullptr, 10) : fallback;
}

// ---- mutations ----------------------------------------------------------------------------

constexpr std::uint32_t kInteresting32[] = {0,
                                            1,
                                            2,
                                            3,
                                            7,
                                            8,
                                            0x7f,
                                            0x80,
                                            0xff,
                                            0x7fff,
                                            0x8000,
                                            0xffff,
                                            0x10000,
                                            0x7fffffff,
                                            0x80000000,
                                            0xfffffffe,
                                            0xffffffff,
                                            0x7fc00000 /* NaN */,
                                            0x7f800000 /* +inf */,
                                            0xff800000 /* -inf */,
                                            0x7f7fffff /* FLT_MAX */,
                                            0x00000001 /* denormal */,
                                            0x10000000 /* 2^28 */};

constexpr double kInterestingDouble[] = {std::numeric_limits<double>::quiet_NaN(),
                                         std::numeric_limits<double>::infinity(),
                                         -std::numeric_limits<double>::infinity(),
                                         0.0,
                                         -0.0,
                                         -1.0,
                                         1e300,
                                         -1e300,
                                         4.9e-324};

// Header fields (offsets, README.md): doubles and u32s.
constexpr std::size_t kHeaderDoubles[] = {24, 32, 40, 48, 56, 64, 72, 80, 88, 96, 136};
constexpr std::size_t kHeaderWords[] = {8, 12, 104, 108, 112, 116, 120, 124, 128, 132, 144, 148};

template <typename T, std::size_t N>
T pick(Rng& rng, const T (&values)[N]) {
    return values[rng.below(N)];
}

std::uint32_t nudge(std::uint32_t v, Rng& rng) {
    const std::uint32_t d = 1 + rng.below(rng.below(2) ? 2 : 64);
    return rng.below(2) ? v + d : v - d;
}

// A random 4-byte word of element `e` of array `a` of block `i`, if the block has such data.
bool pickWord(const UlodBytes& f, Rng& rng, std::uint64_t& at, std::size_t& i, UlodBytes::Array& a,
              std::uint32_t& e) {
    const std::uint32_t blocks = std::min<std::uint32_t>(f.blockCount(), 64);
    if (blocks == 0) return false;
    i = rng.below(blocks);
    // Weighted towards what the engine draws.
    constexpr UlodBytes::Array kArrays[] = {UlodBytes::kVertices,
                                            UlodBytes::kVertices,
                                            UlodBytes::kLevels,
                                            UlodBytes::kLevels,
                                            UlodBytes::kTerrainIndices,
                                            UlodBytes::kTerrainIndices,
                                            UlodBytes::kTerrainIndices,
                                            UlodBytes::kRiverIndices,
                                            UlodBytes::kRiverIndices,
                                            UlodBytes::kGrid,
                                            UlodBytes::kGrid,
                                            UlodBytes::kSteps,
                                            UlodBytes::kRemovedTriangles,
                                            UlodBytes::kAddedTriangles,
                                            UlodBytes::kRemovedEdges,
                                            UlodBytes::kAddedEdges,
                                            UlodBytes::kRemovedTriangleOffset,
                                            UlodBytes::kErrorMax,
                                            UlodBytes::kErrorPaper};
    a = pick(rng, kArrays);
    const std::uint32_t n = f.count(i, a);
    if (n == 0) return false;
    e = rng.below(n);
    const std::uint64_t size = UlodBytes::kElementSize[a];
    at = f.arrayAt(i, a) + e * size + 4 * rng.below(std::uint32_t(size / 4));
    return f.has(at, 4);
}

// A field-aware edit inside a block's arrays.
void mutateBlockArray(UlodBytes& f, Rng& rng) {
    std::uint64_t at = 0;
    std::size_t i = 0;
    UlodBytes::Array a{};
    std::uint32_t e = 0;
    if (!pickWord(f, rng, at, i, a, e)) return;
    const std::uint64_t size = UlodBytes::kElementSize[a];
    const std::uint64_t element = f.arrayAt(i, a) + e * size;
    switch (rng.below(6)) {
        case 0:  // an interesting value
            f.set<std::uint32_t>(at, pick(rng, kInteresting32));
            break;
        case 1:  // off by a little: an index to a neighbouring vertex, a count off by one
            f.set<std::uint32_t>(at, nudge(f.get<std::uint32_t>(at), rng));
            break;
        case 2: {  // the same field of another element (an index to an existing vertex)
            const std::uint32_t other = rng.below(f.count(i, a));
            f.set<std::uint32_t>(
                at, f.get<std::uint32_t>(element - e * size + other * size + (at - element)));
            break;
        }
        case 3:  // two words of the element swapped: a triangle flipped, an edge reversed
            if (size >= 8) {
                const std::uint64_t w = element + 4 * rng.below(std::uint32_t(size / 4));
                const auto x = f.get<std::uint32_t>(at), y = f.get<std::uint32_t>(w);
                f.set<std::uint32_t>(at, y);
                f.set<std::uint32_t>(w, x);
            }
            break;
        case 4: {  // the whole element copied from another one: a duplicated triangle or edge
            const std::uint32_t other = rng.below(f.count(i, a));
            const std::uint64_t src = element - e * size + other * size;
            if (f.has(src, size) && f.has(element, size))
                std::memmove(f.bytes.data() + element, f.bytes.data() + src, size);
            break;
        }
        default: {  // a float nudged (vertices, errors): relatively and absolutely, ulps to km
            constexpr float kRelative[] = {0, 1e-7f, -1e-7f, 1e-6f, -1e-6f, 1e-3f, -1e-3f, 1, -2};
            constexpr float kAbsolute[] = {0, 1e-3f, -1e-3f, 2e-3f, -2e-3f, 1, -1, 1000, -1000};
            const float v = f.get<float>(at);
            f.set<float>(at, v + v * pick(rng, kRelative) + pick(rng, kAbsolute));
            break;
        }
    }
    // A level edited in the block is, most of the time, edited alike in the file's level table
    // (format version 5), so that the block's own level checks are reached and not only the
    // comparison with the table.
    if (a == UlodBytes::kLevels && rng.below(4) != 0) {
        const std::uint64_t mirror = f.levelTableEntry(i) + e * size;
        if (f.has(mirror, size) && f.has(element, size))
            std::memmove(f.bytes.data() + mirror, f.bytes.data() + element, size);
    }
}

void mutate(UlodBytes& f, Rng& rng) {
    if (f.bytes.empty()) return;
    const std::uint32_t n = std::uint32_t(std::min<std::size_t>(f.bytes.size(), 0xffffffffu));
    const std::uint64_t head = std::min<std::uint64_t>(f.trailerAt() + 8, n);
    switch (rng.below(10)) {
        case 0: {  // a bit flip anywhere, or in the header region half of the time
            const std::uint32_t at = rng.below(2) ? rng.below(n) : rng.below(std::uint32_t(head));
            f.bytes[at] = char(f.bytes[at] ^ (1 << rng.below(8)));
            break;
        }
        case 1: {  // a byte set to an interesting value
            constexpr unsigned char kBytes[] = {0, 1, 0x7f, 0x80, 0xff};
            f.bytes[rng.below(n)] = char(pick(rng, kBytes));
            break;
        }
        case 2:  // an aligned word anywhere
            f.set<std::uint32_t>(rng.below(n) / 4 * 4, pick(rng, kInteresting32));
            break;
        case 3: {  // a header double
            const std::size_t at = pick(rng, kHeaderDoubles);
            f.set<double>(at, rng.below(2) ? pick(rng, kInterestingDouble)
                                           : f.get<double>(at) + (rng.below(2) ? 1.0 : -1000.0));
            break;
        }
        case 4: {  // a header word
            const std::size_t at = pick(rng, kHeaderWords);
            f.set<std::uint32_t>(at, rng.below(2) ? pick(rng, kInteresting32)
                                                  : nudge(f.get<std::uint32_t>(at), rng));
            break;
        }
        case 5: {  // a directory entry's word (position, box, range, counts)
            const std::uint32_t blocks = std::min<std::uint32_t>(f.blockCount(), 64);
            if (blocks == 0) break;
            const std::uint64_t at = f.entry(rng.below(blocks)) + 4 * rng.below(24);
            if (rng.below(3) == 0) {
                f.set<double>(at / 8 * 8, pick(rng, kInterestingDouble));
            } else {
                f.set<std::uint32_t>(at, rng.below(2) ? pick(rng, kInteresting32)
                                                      : nudge(f.get<std::uint32_t>(at), rng));
            }
            break;
        }
        case 6: {  // a block header double (origin, box)
            const std::uint32_t blocks = std::min<std::uint32_t>(f.blockCount(), 64);
            if (blocks == 0) break;
            const std::uint64_t at = f.blockAt(rng.below(blocks)) + 8 + 8 * rng.below(8);
            f.set<double>(at, rng.below(2) ? pick(rng, kInterestingDouble)
                                           : f.get<double>(at) + (rng.below(2) ? 0.5 : -0.5));
            break;
        }
        case 7:
        case 8:
            mutateBlockArray(f, rng);
            break;
        default:  // truncated, or extended with zeros
            if (rng.below(2))
                f.bytes.resize(rng.below(n));
            else
                f.bytes.resize(f.bytes.size() + 1 + rng.below(64), 0);
            break;
    }
}

// ---- the reader paths ---------------------------------------------------------------------

struct Tally {
    std::uint64_t openRejected = 0, blockRejected = 0, semanticRejected = 0, accepted = 0,
                  checkRejected = 0, refined = 0, refineRefused = 0;
};

// Runs every reader path on the file at `path` and checks the outcome's contract.
void exercise(const std::string& path, Tally& tally) {
    format::Reader reader;
    std::string error;
    if (!reader.open(path, error)) {
        EXPECT_EQ(error.rfind(path + ": ", 0), 0u) << error;
        ++tally.openRejected;
        return;
    }
    const format::Header& h = reader.header();
    bool all = true, semantic = false;
    for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
        const format::BlockInfo& info = reader.blocks()[i];
        // Open's promises about the directory.
        EXPECT_TRUE(info.minX >= h.minX && info.maxX <= h.maxX && info.minZ >= h.minZ &&
                    info.maxZ <= h.maxZ && info.minX <= info.maxX);
        format::Block b;
        std::string blockError, geometryError;
        const bool ok = reader.readBlock(i, b, blockError);
        format::BlockGeometry g;
        const bool geometryOk = reader.readGeometry(i, format::kAllLevels, g, geometryError);
        EXPECT_EQ(ok, geometryOk) << blockError << " / " << geometryError;  // one validation
        if (!ok) {
            const std::string name =
                path + (info.level == 0 ? ": block (" : ": node (") + std::to_string(info.col) +
                "," + std::to_string(info.row) + ")" +
                (info.level == 0 ? "" : " of tree level " + std::to_string(info.level)) + ": ";
            EXPECT_EQ(blockError.rfind(name, 0), 0u) << blockError;
            EXPECT_EQ(blockError, geometryError);
            semantic = semantic || blockError.find("checksum mismatch") == std::string::npos;
            all = false;
            continue;
        }
        // Accepted: valid again, and what the engine reads is the block's data.
        EXPECT_TRUE(format::validateBlock(b, h.metrics, error)) << error;
        EXPECT_EQ(g.vertices.size(), b.vertices.size());
        EXPECT_EQ(g.terrainIndices.size(), b.terrainIndices.size());
        const int last = int(b.levels.size()) - 1;
        ASSERT_TRUE(reader.readGeometry(i, last, g, error)) << error;
        for (const format::Triangle& t : g.terrainIndices)
            ASSERT_TRUE(t.a < g.vertices.size() && t.b < g.vertices.size() &&
                        t.c < g.vertices.size());
        for (const format::Edge& e : g.riverIndices)
            ASSERT_TRUE(e.a < e.b && e.b < g.vertices.size());
        // What the engine's loader does next with an entry it read (engine/lod/refine.h): its
        // refinement tables, then a refined mesh as a frame takes one. An entry it cannot refine
        // says why (and is drawn at its stored levels); one it can gives indices in range.
        engine::Refinement refinement;
        std::string why;
        if (!refinement.init(b, why)) {
            EXPECT_FALSE(why.empty());
            ++tally.refineRefused;
            continue;
        }
        ++tally.refined;
        for (const double hLim : {0.0, 1.0, 1e9}) {
            engine::ViewSpec view;
            view.kind = engine::ViewSpec::Kind::Uniform;
            view.hLim = hLim;
            engine::RefinedMesh mesh;
            refinement.refine(view, mesh, b.levels.size() > 1 ? b.levels[1].step : 0);
            for (const format::Triangle& t : mesh.triangles)
                ASSERT_TRUE(t.a < b.vertices.size() && t.b < b.vertices.size() &&
                            t.c < b.vertices.size());
            for (const format::Edge& e : mesh.riverEdges)
                ASSERT_TRUE(e.a < e.b && e.b < b.vertices.size());
        }
    }
    if (!all) {
        ++tally.blockRejected;
        tally.semanticRejected += semantic;
        return;
    }
    ++tally.accepted;
    // The deeper replay of `unilod check` on what the reader accepted: no crash, a clean answer.
    UlodCheckSummary summary;
    if (!checkUlod(path, UlodCheckOptions{}, summary, error)) {
        EXPECT_EQ(error.rfind(path + ": ", 0), 0u) << error;
        ++tally.checkRejected;
    }
}

class Fuzz : public ::testing::Test {
protected:
    static inline test::TempDir* dir = nullptr;
    static inline UlodBytes seed, rawSeed;

    // A small synthetic world with rivers in 2 x 2 blocks, with compact blocks (the default) and
    // with raw blocks (whose arrays the field-aware edits reach).
    static void SetUpTestSuite() {
        dir = new test::TempDir("fuzz");
        BuildOptions o;
        std::string error;
        ASSERT_TRUE(test::writeTwoByTwoWorld(*dir, 1500, 5, o, error)) << error;
        o.outPath = dir->file("seed.ulod");
        o.threads = 1;
        o.tree = true;  // the tree links and a node are fuzzed too
        BuildSummary summary;
        ASSERT_TRUE(runBuild(o, summary, error)) << error;
        seed = UlodBytes::load(o.outPath);
        ASSERT_EQ(seed.blockCount(), 5u);  // 2 x 2 blocks and the root of their tree
        std::size_t compact = 0;
        for (std::size_t i = 0; i < seed.blockCount(); ++i)
            compact += seed.get<std::uint32_t>(seed.entry(i) + UlodBytes::kEntryEncoding) == 1;
        ASSERT_GE(compact, 4u);
        o.outPath = dir->file("raw_seed.ulod");
        o.rawBlocks = true;
        ASSERT_TRUE(runBuild(o, summary, error)) << error;
        rawSeed = UlodBytes::load(o.outPath);
    }
    static void TearDownTestSuite() {
        delete dir;
        dir = nullptr;
    }
};

void fuzz(const UlodBytes& seed, std::uint64_t defaultCases) {
    const std::uint64_t seconds = envNumber("UNILOD_FUZZ_SECONDS", 0);
    const std::uint64_t cases =
        envNumber("UNILOD_FUZZ_CASES", seconds > 0 ? ~std::uint64_t(0) : defaultCases);
    const std::uint64_t rngSeed = envNumber("UNILOD_FUZZ_SEED", 1);
    const char* last = std::getenv("UNILOD_FUZZ_LAST");
    // The case file lives in memory (memfd): no disk traffic per case.
    const int fd = memfd_create("fuzz.ulod", 0);
    ASSERT_GE(fd, 0);
    const std::string path = "/proc/self/fd/" + std::to_string(fd);

    {  // The unmutated seed passes everything.
        Tally tally;
        ASSERT_EQ(::pwrite(fd, seed.bytes.data(), seed.bytes.size(), 0),
                  ssize_t(seed.bytes.size()));
        exercise(path, tally);
        ASSERT_EQ(tally.accepted, 1u);
        ASSERT_EQ(tally.checkRejected, 0u);
    }

    Tally tally;
    std::uint64_t resealed = 0, done = 0;
    const auto start = std::chrono::steady_clock::now();
    for (std::uint64_t c = 0; c < cases; ++c) {
        if (seconds > 0 && std::chrono::steady_clock::now() - start > std::chrono::seconds(seconds))
            break;
        Rng rng(rngSeed * 0x100000001b3ull + c);
        UlodBytes f = seed;
        const std::uint32_t mutations = 1 + rng.below(3);
        for (std::uint32_t m = 0; m < mutations; ++m)
            mutate(f, rng);
        if (rng.below(4) != 0) {
            f.resealAll();
            ++resealed;
        }
        if (last) f.save(last);
        ASSERT_EQ(::ftruncate(fd, off_t(f.bytes.size())), 0);
        ASSERT_EQ(::pwrite(fd, f.bytes.data(), f.bytes.size(), 0), ssize_t(f.bytes.size()));
        SCOPED_TRACE("case " + std::to_string(c) + " (UNILOD_FUZZ_SEED=" + std::to_string(rngSeed) +
                     ")");
        exercise(path, tally);
        ++done;
        if (::testing::Test::HasFatalFailure()) break;
    }
    ::close(fd);
    std::printf(
        "%llu cases (%llu resealed): open rejected %llu, a block rejected %llu (%llu of "
        "them with valid checksums), accepted %llu (then check rejected %llu); blocks read and "
        "refined %llu, not refinable %llu\n",
        (unsigned long long)done, (unsigned long long)resealed,
        (unsigned long long)tally.openRejected, (unsigned long long)tally.blockRejected,
        (unsigned long long)tally.semanticRejected, (unsigned long long)tally.accepted,
        (unsigned long long)tally.checkRejected, (unsigned long long)tally.refined,
        (unsigned long long)tally.refineRefused);
    // The mutations reach every outcome, so the semantic checks (not only the CRCs) ran.
    if (done >= defaultCases) {
        EXPECT_GT(tally.openRejected, 0u);
        EXPECT_GT(tally.semanticRejected, 0u);
        EXPECT_GT(tally.accepted, 0u);
        EXPECT_GT(tally.refined, 0u);
    }
}

TEST_F(Fuzz, EveryMutationOfACompactFileEndsCleanly) {
    fuzz(seed, kDefaultCases);
}

TEST_F(Fuzz, EveryMutationOfARawFileEndsCleanly) {
    fuzz(rawSeed, kDefaultCases / 2);
}

}  // namespace
