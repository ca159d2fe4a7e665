// `unilod check --errors` (issue "a bound that lies is a defect"): the `max` model error stored at
// every level must be at least the error recomputed from the file's own data (errorcheck.h).
// Models of the bundled data set and of a synthetic world with rivers, built with both deletion
// orders, pass; a file whose stored bound was lowered at one step (otherwise valid: checksums,
// non-decreasing errors, topology) fails with a message naming the file, block, level and values.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "build.h"
#include "synthetic.h"
#include "tools/cliutil.h"
#include "ulod.h"
#include "ulodcheck.h"

namespace fs = std::filesystem;
using namespace unilod;

namespace {

using unilod::test::q;

const std::string kAssets = UNILOD_ASSETS_DIR;

struct Built {
    std::string name, path;
    UlodCheckSummary
        summary;  // checkUlod with --errors, computed once (the suite's costliest step)
};

class CheckErrors : public ::testing::Test {
protected:
    static inline fs::path dir;
    static inline std::vector<Built> models;

    static void build(const std::string& name, const std::string& dem, const std::string& rivers,
                      int blockSize, DeletionOrderKind order) {
        BuildOptions o;
        o.demPath = dem;
        o.riversPath = rivers;
        o.outPath = (dir / (name + ".ulod")).string();
        o.blockSize = blockSize;
        o.order = order;
        o.threads = 2;
        BuildSummary summary;
        std::string error;
        ASSERT_TRUE(runBuild(o, summary, error)) << name << ": " << error;
        UlodCheckOptions options;
        options.errors = true;
        UlodCheckSummary checked;
        ASSERT_TRUE(checkUlod(o.outPath, options, checked, error)) << name << ": " << error;
        models.push_back({name, o.outPath, checked});
    }

    static void SetUpTestSuite() {
        dir = fs::temp_directory_path() / ("unilod_test_check_" + std::to_string(getpid()));
        fs::remove_all(dir);
        fs::create_directories(dir);
        const std::string dem = kAssets + "/jacksboro_dem.tif";
        const std::string rivers = kAssets + "/jacksboro_rivers_grass.geojson";
        build("jacksboro_greedy", dem, rivers, 128, DeletionOrderKind::Greedy);
        build("jacksboro_3ddp", dem, rivers, 128, DeletionOrderKind::ThreeDdp);

        SyntheticOptions so;
        so.targetPoints = 40000;
        so.seed = 11;
        const SyntheticData data = generateSyntheticData(so);
        ASSERT_GT(data.rivers.size(), 0u);
        std::string error;
        const fs::path synth = dir / "synth";
        ASSERT_TRUE(writeSyntheticData(data, synth.string(), error)) << error;
        const int blockSize = (std::max(data.dem.width, data.dem.height) - 1) / 3;
        build("synthetic_greedy", (synth / "dem.tif").string(), (synth / "rivers.geojson").string(),
              blockSize, DeletionOrderKind::Greedy);
        build("synthetic_3ddp", (synth / "dem.tif").string(), (synth / "rivers.geojson").string(),
              blockSize, DeletionOrderKind::ThreeDdp);
    }
    static void TearDownTestSuite() {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
};

// The entry where `check --errors` found the recomputed error closest to the stored one.
format::Block* worstBlock(test::Model& model, const UlodCheckSummary& s) {
    for (format::Block& candidate : model.blocks) {
        if (candidate.col == s.worstCol && candidate.row == s.worstRow &&
            candidate.level == s.worstTreeLevel)
            return &candidate;
    }
    return nullptr;
}

// Lowers the stored `max` bound of `b` to at most `value` at every step up to `step` (so that the
// array stays non-decreasing), its river part with it (a part of it), the levels' copies equal.
void lowerBound(format::Block& b, std::uint32_t step, float value) {
    for (std::uint32_t k = 0; k <= step; ++k) {
        b.errorMax[k] = std::min(b.errorMax[k], value);
        b.errorRiver[k] = std::min(b.errorRiver[k], b.errorMax[k]);
    }
    for (format::Level& l : b.levels)
        l.errorMax = b.errorMax[l.step], l.errorRiver = b.errorRiver[l.step];
}

TEST_F(CheckErrors, StoredBoundsHoldOnEveryModel) {
    ASSERT_EQ(models.size(), 4u);
    for (const Built& m : models) {
        SCOPED_TRACE(m.name);
        const UlodCheckSummary& s = m.summary;
        ASSERT_TRUE(s.errorsChecked);
        EXPECT_GT(s.levels, s.blocks);
        // Where the running maximum has just risen, the current error is the stored one (up to
        // float rounding): the recomputation finds it, it is not trivially small.
        EXPECT_GT(s.worstRatio, 0.99);
        // Recomputed above stored only by the float rounding of z (errorcheck.h: < 0.5 mm here).
        EXPECT_GT(s.smallestMargin, -5e-4);
        // The river part (format version 4) is checked on its own, and holds.
        ASSERT_TRUE(std::isfinite(s.riverMargin));
        EXPECT_GT(s.riverMargin, -5e-4);

        const test::CliResult r = test::runCli("check -q --errors " + q(m.path));
        EXPECT_EQ(r.code, 0) << r.err;
        EXPECT_NE(r.out.find("largest recomputed/stored"), std::string::npos) << r.out;
        if (m.name.find("greedy") != std::string::npos) {
            // Tree nodes (greedy builds have them): the original river points' deviation is
            // recomputed (errorcheck.h NodeOriginalError; its own tests compute it by hand and
            // by brute force) and every stored bound holds it; coarse node levels move the
            // rivers by metres at least.
            EXPECT_GT(s.nodeRiverWorst, 1.0);
            EXPECT_NE(r.out.find("original river points within"), std::string::npos) << r.out;
        }
    }
}

// Lowers errorMax at the stored level where the recomputed error comes closest to the stored one
// (check's summary) to half the recomputed error, the steps before it clamped so that the array
// stays non-decreasing, the levels keeping their copies equal, and rewrites the file with fresh
// checksums: `check` still passes, `check --errors` must not, and names the level.
TEST_F(CheckErrors, LoweredBoundFails) {
    ASSERT_EQ(models.size(), 4u);
    for (const Built& m : models) {
        SCOPED_TRACE(m.name);
        const UlodCheckSummary& s = m.summary;
        std::string error;
        ASSERT_GT(s.worstRecomputed, 0.1) << "no level with a recomputed error above 10 cm";
        test::Model model;
        ASSERT_TRUE(test::readModel(m.path, model, error)) << error;
        format::Block* b = worstBlock(model, s);
        ASSERT_NE(b, nullptr);
        const format::Level& level = b->levels[s.worstLevel];
        const float lowered = float(s.worstRecomputed / 2);
        std::printf("[ tampered  ] %s: %s, level %u lowered from %.3f to %.3f m\n", m.name.c_str(),
                    format::blockName(b->col, b->row, b->level).c_str(), s.worstLevel,
                    double(level.errorMax), double(lowered));
        lowerBound(*b, level.step, lowered);
        const std::string tampered = (dir / (m.name + "_tampered.ulod")).string();
        ASSERT_TRUE(format::writeUlod(tampered, model.header, model.blocks, error)) << error;

        const test::CliResult plain = test::runCli("check -q " + q(tampered));
        EXPECT_EQ(plain.code, 0) << plain.err;
        const test::CliResult r = test::runCli("check -q --errors " + q(tampered));
        EXPECT_EQ(r.code, 1) << r.out;
        // The first lying level is named: this one or, where the clamping made an earlier level
        // lie too, an earlier one of the same block.
        const std::string where = format::blockName(b->col, b->row, b->level) + ": level ";
        EXPECT_NE(r.err.find(tampered), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(where), std::string::npos) << r.err << "\nexpected: " << where;
        EXPECT_NE(r.err.find("): max error lies"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("recomputed"), std::string::npos) << r.err;
    }
}

// A lie of 1 mm beyond what the format allows: a stored error is the true one plus the z quantum,
// rounded up to a multiple of it (format/blockcodec.h), and the heights moved by up to q / 2, so it
// exceeds the recomputed one by less than 2.5q. The stored error of the level where the recomputed
// one comes closest is lowered by 3q + 1 mm
// (the check's own tolerance is < 0.5 mm for these altitudes), the steps before it clamped so
// that the array stays non-decreasing.
TEST_F(CheckErrors, MillimetreLieFails) {
    ASSERT_EQ(models.size(), 4u);
    for (const Built& m : models) {
        SCOPED_TRACE(m.name);
        const UlodCheckSummary& s = m.summary;
        std::string error;
        ASSERT_GT(s.worstStored, 0.01);
        test::Model model;
        ASSERT_TRUE(test::readModel(m.path, model, error)) << error;
        format::Block* b = worstBlock(model, s);
        ASSERT_NE(b, nullptr);
        const float lowered = float(s.worstStored - 3 * model.header.zQuantum - 1e-3);
        lowerBound(*b, b->levels[s.worstLevel].step, lowered);
        const std::string tampered = (dir / (m.name + "_mm.ulod")).string();
        ASSERT_TRUE(format::writeUlod(tampered, model.header, model.blocks, error)) << error;

        const test::CliResult r = test::runCli("check -q --errors " + q(tampered));
        EXPECT_EQ(r.code, 1) << r.out;
        const std::string where =
            format::blockName(s.worstCol, s.worstRow, s.worstTreeLevel) + ": level ";
        EXPECT_NE(r.err.find(where), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("max error lies"), std::string::npos) << r.err;
    }
}

// The river part of the `max` error (format version 4, Level::errorRiver) is a bound of its own:
// in the leaf block and in the tree node with the largest final river part, the river part is
// set to 0 at every step (errorMax untouched, so the combined bound still holds): `check` passes
// (structure), `check --errors` fails and names the entry and the river part.
TEST_F(CheckErrors, LoweredRiverPartFails) {
    ASSERT_EQ(models.size(), 4u);
    for (const Built& m : models) {
        for (const bool node : {false, true}) {
            SCOPED_TRACE(m.name + (node ? " (tree node)" : " (leaf)"));
            test::Model model;
            std::string error;
            ASSERT_TRUE(test::readModel(m.path, model, error)) << error;
            format::Block* b = nullptr;
            for (format::Block& candidate : model.blocks) {
                if ((candidate.level > 0) != node) continue;
                if (b == nullptr || candidate.errorRiver.back() > b->errorRiver.back())
                    b = &candidate;
            }
            if (node && m.name.find("3ddp") != std::string::npos) {
                EXPECT_EQ(b, nullptr);  // 3ddp builds have no tree
                continue;
            }
            ASSERT_NE(b, nullptr);
            ASSERT_GT(b->errorRiver.back(), 0.1f) << "no river part above 10 cm";
            std::fill(b->errorRiver.begin(), b->errorRiver.end(), 0.0f);
            for (format::Level& l : b->levels)
                l.errorRiver = 0;
            const std::string tampered =
                (dir / (m.name + (node ? "_node" : "_leaf") + "_river.ulod")).string();
            ASSERT_TRUE(format::writeUlod(tampered, model.header, model.blocks, error)) << error;
            const test::CliResult plain = test::runCli("check -q " + q(tampered));
            EXPECT_EQ(plain.code, 0) << plain.err;
            const test::CliResult r = test::runCli("check -q --errors " + q(tampered));
            EXPECT_EQ(r.code, 1) << r.out;
            EXPECT_NE(r.err.find(format::blockName(b->col, b->row, b->level) + ": "),
                      std::string::npos)
                << r.err;
            EXPECT_NE(r.err.find("river part lies"), std::string::npos) << r.err;
        }
    }
}

// `check` runs entries on worker threads (ulodcheck.cpp): the summary is the same for any
// number of them, its counts are the file's, and a file with two lying entries is reported at the
// first in file order (a leaf), though the tree nodes, stored after the leaves, are checked first.
TEST_F(CheckErrors, SameResultForAnyThreadCount) {
    ASSERT_EQ(models.size(), 4u);
    const Built& m = models[2];  // synthetic_greedy: leaves and tree nodes, with rivers
    ASSERT_EQ(m.name, "synthetic_greedy");
    test::Model model;
    std::string error;
    ASSERT_TRUE(test::readModel(m.path, model, error)) << error;
    std::size_t levels = 0, steps = 0;
    for (const format::Block& b : model.blocks)
        levels += b.levels.size(), steps += b.steps.size();
    for (const std::size_t threads : {std::size_t(1), std::size_t(3)}) {
        SCOPED_TRACE("threads " + std::to_string(threads));
        UlodCheckOptions options;
        options.errors = true;
        options.threads = threads;
        UlodCheckSummary s;
        ASSERT_TRUE(checkUlod(m.path, options, s, error)) << error;
        EXPECT_EQ(s.blocks, model.blocks.size());
        EXPECT_EQ(s.levels, levels);
        EXPECT_EQ(s.steps, steps);
        const UlodCheckSummary& d = m.summary;  // every core
        EXPECT_EQ(s.blocks, d.blocks);
        EXPECT_EQ(s.errorsChecked, d.errorsChecked);
        EXPECT_EQ(s.worstRatio, d.worstRatio);
        EXPECT_EQ(s.worstStored, d.worstStored);
        EXPECT_EQ(s.worstRecomputed, d.worstRecomputed);
        EXPECT_EQ(s.worstCol, d.worstCol);
        EXPECT_EQ(s.worstRow, d.worstRow);
        EXPECT_EQ(s.worstTreeLevel, d.worstTreeLevel);
        EXPECT_EQ(s.worstLevel, d.worstLevel);
        EXPECT_EQ(s.smallestMargin, d.smallestMargin);
        EXPECT_EQ(s.nodeRiverWorst, d.nodeRiverWorst);
        EXPECT_EQ(s.riverMargin, d.riverMargin);
    }

    // Two lies: the river part zeroed in the leaf and in the tree node with the largest one.
    format::Block* leaf = nullptr;
    format::Block* node = nullptr;
    for (format::Block& b : model.blocks) {
        format::Block*& pick = b.level > 0 ? node : leaf;
        if (pick == nullptr || b.errorRiver.back() > pick->errorRiver.back()) pick = &b;
    }
    ASSERT_NE(leaf, nullptr);
    ASSERT_NE(node, nullptr);
    for (format::Block* b : {leaf, node}) {
        ASSERT_GT(b->errorRiver.back(), 0.1f);
        std::fill(b->errorRiver.begin(), b->errorRiver.end(), 0.0f);
        for (format::Level& l : b->levels)
            l.errorRiver = 0;
    }
    const std::string tampered = (dir / "two_lies.ulod").string();
    ASSERT_TRUE(format::writeUlod(tampered, model.header, model.blocks, error)) << error;
    const test::CliResult r = test::runCli("check -q --errors --threads 3 " + q(tampered));
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.err.find(format::blockName(leaf->col, leaf->row, leaf->level) + ": "),
              std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find(format::blockName(node->col, node->row, node->level) + ": "),
              std::string::npos)
        << r.err;
}

// Neighbouring leaves must meet edge to edge with the same heights (`check` compares their shared
// borders on the exact grid): one border vertex of a leaf raised or lowered by a few z quanta
// (towards the middle of the block's height range, so that the block itself stays valid: its
// box, its topology) is a crack, named with both blocks and the place.
TEST_F(CheckErrors, BorderHeightThatDiffersFromTheNeighbourFails) {
    const Built& m = models.front();
    test::Model model;
    std::string error;
    ASSERT_TRUE(test::readModel(m.path, model, error)) << error;
    // A leaf with an east neighbour, and a locked vertex on its east border line.
    format::Block* b = nullptr;
    std::uint32_t vertex = 0;
    for (format::Block& candidate : model.blocks) {
        if (candidate.level != 0 || b != nullptr) continue;
        const bool east = std::any_of(model.blocks.begin(), model.blocks.end(), [&](auto& o) {
            return o.level == 0 && o.row == candidate.row && o.col == candidate.col + 1;
        });
        if (!east) continue;
        std::int32_t maxX = candidate.grid.front().x;
        for (const format::GridXY& g : candidate.grid)
            maxX = std::max(maxX, g.x);
        const float mid = float((candidate.minZ + candidate.maxZ) / 2);
        for (std::uint32_t i = 0; i < candidate.vertices.size(); ++i) {
            const format::Vertex& v = candidate.vertices[i];
            if (candidate.grid[i].x == maxX && (v.flags & format::kVertexLocked) &&
                std::fabs(v.z - mid) > 1) {
                b = &candidate;
                vertex = i;
                break;
            }
        }
    }
    ASSERT_NE(b, nullptr) << "no leaf with a locked vertex on a shared east border";
    format::Vertex& v = b->vertices[vertex];
    const float mid = float((b->minZ + b->maxZ) / 2);
    v.z += float(4 * model.header.zQuantum) * (v.z < mid ? 1.0f : -1.0f);
    const std::string tampered = (dir / "border_height.ulod").string();
    ASSERT_TRUE(format::writeUlod(tampered, model.header, model.blocks, error)) << error;
    const test::CliResult r = test::runCli("check -q " + q(tampered));
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.err.find(format::blockName(b->col, b->row) + " and " +
                         format::blockName(b->col + 1, b->row)),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("do not meet at"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("its ends' heights differ"), std::string::npos) << r.err;
}

}  // namespace
