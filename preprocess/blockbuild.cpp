// One block end to end (blockbuild.h).
#include "blockbuild.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "blockcodec.h"
#include "cdt.h"
#include "deletion.h"
#include "lodindex.h"

namespace unilod {

const char* deletionOrderName(DeletionOrderKind kind) {
    return kind == DeletionOrderKind::ThreeDdp ? "3ddp" : "greedy";
}

bool buildBlock(const PointSet& set, std::uint32_t col, std::uint32_t row,
                const BlockBuildOptions& options, format::Block& block, BlockBuildStats& stats,
                std::string& error, const NodeErrorInput* node, CoarseState* coarse) {
    const auto t0 = std::chrono::steady_clock::now();
    stats = {};
    stats.points = set.points.size();
    stats.droppedPoints = set.dropped.size();
    for (const Point& p : set.points) {
        stats.riverPoints += p.kind == PointKind::River;
        stats.lockedPoints += p.locked;
    }

    ImportanceResult importance;
    if (options.order == DeletionOrderKind::ThreeDdp &&
        !computeImportance(set, options.importance, importance, error))
        return false;

    Cdt cdt;
    if (!buildCdt(set, {}, cdt, error)) return false;
    LodIndexInput in;
    in.initialTriangles = collectTriangles(cdt);
    in.initialEdges = collectRiverEdges(cdt);

    DeletionOptions del;
    del.maxError = options.maxError;
    del.paperError = options.paperError;
    del.afterStep = options.afterStep;
    ExtraSamples extra;
    auto onGrid = [&](const Point& p) {
        return ExtraSample{std::int32_t(std::llround((p.x - cdt.originX) / cdt.gridUnit)),
                           std::int32_t(std::llround((p.y - cdt.originY) / cdt.gridUnit)), p.z};
    };
    if (node != nullptr) {
        if (options.order != DeletionOrderKind::Greedy) {
            error = "tree nodes are built with the greedy order only";
            return false;
        }
        del.paperError = false;
        del.errorFloor = del.chainSlack = node->errorFloor;
        del.riverFloor = node->riverFloor;
        del.riverCover = &node->riverCover;
        if (node->originals) {
            // Every original point of the node's area (a root's: of the model). The pool takes
            // the references' buffer over (modelerror.h ModelError::init), with room for a
            // quarter more; a point at a sampled DEM cell is referred to by its cell (8 bytes
            // with its height, instead of 16: SampleRef).
            const std::size_t all = node->originalCount + set.points.size();
            extra.refs.reserve(all + all / 4 + 1024);
            const OriginalGrid* g = node->grid;
            SampleGrid& cells = extra.grid;
            std::size_t cols = 0, rows = 0;
            if (g != nullptr && g->dem != nullptr && g->step > 0 && g->cellCol1 >= g->cellCol0 &&
                g->cellRow1 >= g->cellRow0) {
                cols = std::size_t(g->cellCol1 - g->cellCol0) / std::size_t(g->step) + 1;
                rows = std::size_t(g->cellRow1 - g->cellRow0) / std::size_t(g->step) + 1;
                // References below 2^32 (with the set's and the explicit points: a margin; the
                // rows' pitch is a power of two, at most twice the columns).
                if (2.0 * double(cols) * double(rows) + double(all) >= 4.0e9) cols = rows = 0;
            }
            if (cols > 0) {
                const DemGrid& dem = *g->dem;
                for (std::size_t k = 0; k < cols; ++k)
                    cells.gx.push_back(
                        onGrid({dem.centreX(int(g->cellCol0 + k * g->step)), 0, 0}).gx);
                for (std::size_t j = 0; j < rows; ++j)
                    cells.gy.push_back(
                        onGrid({0, dem.centreY(int(g->cellRow0 + j * g->step)), 0}).gy);
            }
            const std::size_t cellCount = cells.cells();
            const int shift = cells.shift();
            node->originals([&](const Point& p) {
                if (cellCount > 0) {
                    // At a sampled cell's centre (on the grid), its height a float exactly.
                    const DemGrid& dem = *g->dem;
                    const double fc = (p.x - dem.originX) / dem.cellX;
                    const double fr = (p.y - dem.originY) / dem.cellY;
                    if (fc >= g->cellCol0 - 0.5 && fc <= g->cellCol1 + 0.5 &&
                        fr >= g->cellRow0 - 0.5 && fr <= g->cellRow1 + 0.5) {
                        const int dc = int(std::lround(fc)) - g->cellCol0;
                        const int dr = int(std::lround(fr)) - g->cellRow0;
                        const std::size_t k = std::size_t(dc / g->step),
                                          j = std::size_t(dr / g->step);
                        const ExtraSample e = onGrid(p);
                        if (dc >= 0 && dr >= 0 && dc % g->step == 0 && dr % g->step == 0 &&
                            k < cols && j < rows && e.gx == cells.gx[k] && e.gy == cells.gy[j] &&
                            double(float(p.z)) == p.z) {
                            extra.refs.push_back({std::uint32_t((j << shift) | k), float(p.z)});
                            return;
                        }
                    }
                }
                extra.refs.push_back({std::uint32_t(cellCount + extra.points.size()), 0.0f});
                extra.points.push_back(onGrid(p));
            });
        }
        del.extraSamples = &extra;
        del.releaseExtraSamples = true;  // a root's are every original point of the model
    } else if (!set.dropped.empty()) {
        // The DEM points the river clearance left out: original points, measured like the rest.
        extra.points.reserve(set.dropped.size());
        for (const Point& p : set.dropped)
            extra.points.push_back(onGrid(p));
        del.extraSamples = &extra;
    }
    DeletionRecords records;
    // The state the parent starts from (CoarseState): the alive mesh at the hand-over, compacted
    // to the vertices it uses.
    auto takeCoarse = [&] {
        *coarse = CoarseState{};
        coarse->triangles = collectTriangles(cdt);
        coarse->rivers = collectRiverEdges(cdt);
        // What each river edge stands for: its report, else (not reported) everything within
        // the error so far.
        const double finalError =
            records.errorMax.empty() ? records.initialErrorMax : records.errorMax.back();
        coarse->riverCover.reserve(coarse->rivers.size());
        for (const RiverEdge& e : coarse->rivers) {
            const auto it =
                std::lower_bound(records.riverCover.begin(), records.riverCover.end(), e,
                                 [](const auto& l, const RiverEdge& r) { return l.first < r; });
            if (it != records.riverCover.end() && it->first == e) {
                coarse->riverCover.push_back(std::move(it->second));
            } else {
                coarse->riverCover.push_back(RiverCover{finalError, {}});
            }
        }
        std::vector<PointId> local(set.points.size(), kNoPoint);
        auto use = [&](PointId& v) {
            if (local[v] == kNoPoint) {
                local[v] = PointId(coarse->points.size());
                coarse->points.push_back(set.points[v]);
            }
            v = local[v];
        };
        for (TriangleTriple& t : coarse->triangles)
            for (PointId& v : t.v)
                use(v);
        for (RiverEdge& e : coarse->rivers) {
            use(e.a);
            use(e.b);
        }
        coarse->errorMax =
            records.errorMax.empty() ? records.initialErrorMax : records.errorMax.back();
        coarse->errorRiver =
            records.errorRiver.empty() ? records.initialErrorRiver : records.errorRiver.back();
    };
    if (options.order == DeletionOrderKind::ThreeDdp) {
        if (!runDeletion(set, cdt, importance.order, del, records, error)) return false;
        if (coarse != nullptr) takeCoarse();  // no hand-over: the last state
    } else {
        // The greedy key needs the max metric; its BAI factors: Eq. 2 (bai.h BaiKeys).
        del.maxError = true;
        del.handoverTriangles = options.handoverTriangles;
        del.handoverKey = options.handoverKey;
        del.handoverKeyTriangles = options.handoverKeyTriangles;
        if (coarse != nullptr) del.onHandover = takeCoarse;
        BaiKeys keys;
        if (options.importance.useBai && options.importance.baiByThreshold) {
            keys = BaiKeys::byThreshold(set, options.importance.baiTable);
        } else if (options.importance.useBai) {
            const int baiRow = options.importance.baiTable.findRow(options.importance.baiRow);
            if (baiRow < 0) {
                error = "the BAI table has no row for threshold " +
                        std::to_string(options.importance.baiRow) + " m";
                return false;
            }
            keys = BaiKeys(baiFactors(set, options.importance.baiTable, baiRow));
        }
        if (!runGreedyDeletion(set, cdt, keys, del, records, error)) return false;
    }

    // A leaf's error before any deletion is that of the points not triangulated (the dropped
    // ones; points merged on the 1 mm grid add at most millimetres).
    if (node == nullptr && !set.dropped.empty()) stats.droppedDeviation = records.initialErrorMax;

    block = format::Block{};
    block.col = col;
    block.row = row;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (const Point& p : set.points) {
        const double c[3] = {p.x, p.y, p.z};
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], c[a]);
            hi[a] = std::max(hi[a], c[a]);
        }
    }
    block.minX = lo[0];
    block.minY = lo[1];
    block.minZ = lo[2];
    block.maxX = hi[0];
    block.maxY = hi[1];
    block.maxZ = hi[2];
    // The CDT's grid origin (the centre of the points' bounding box): vertex x, y are floats
    // relative to it (sub-millimetre for blocks of tens of km) and the exact grid coordinates
    // stored beside them are relative to it too.
    static_assert(format::kGridUnit == 1e-3);
    block.originX = cdt.originX;
    block.originY = cdt.originY;

    in.cdt = &cdt;
    in.points = &set;
    in.records = &records;
    in.originX = block.originX;
    in.originY = block.originY;
    in.ratio = options.lodRatio;
    in.zQuantum = format::kDefaultZQuantum;
    in.maxError = options.maxError;
    in.paperError = del.paperError;
    if (!buildLodIndex(in, block, error)) return false;

    stats.vertices = block.vertices.size();
    stats.steps = records.steps.size();
    stats.kept = records.kept.size();
    stats.deferrals = records.deferrals;
    stats.fullTriangles = in.initialTriangles.size();
    stats.coarsestTriangles = block.levels.back().triangleCount;
    stats.riverEdges = in.initialEdges.size();
    stats.indexTriangles = block.terrainIndices.size();
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return true;
}

}  // namespace unilod
