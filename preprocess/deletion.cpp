// Deletion sequence, records and deferral (paper §3.3 local re-triangulation, §3.2 error):
// see deletion.h for the rules.
#include "deletion.h"

#include <algorithm>
#include <cassert>
#include <queue>
#include <set>

#include "modelerror.h"

namespace unilod {

namespace {

constexpr std::uint32_t kNil = 0xFFFFFFFFu;

// push_back that grows the capacity by a quarter instead of doubling it.
template <typename T>
void pushGrow(std::vector<T>& v, const T& x) {
    if (v.size() == v.capacity()) v.reserve(v.capacity() + v.capacity() / 4 + 16);
    v.push_back(x);
}

enum class State : std::uint8_t { Pending = 0, Deleted = 1, Deferred = 2, Kept = 3 };
enum class Outcome : std::uint8_t { Deleted, Deferred, Refused };

class Sequence {
public:
    Sequence(const PointSet& set, Cdt& cdt, const DeletionOptions& options, DeletionRecords& rec)
        : set_(set), cdt_(cdt), options_(options), rec_(rec) {}

    bool run(const std::vector<PointId>& order, std::string& error);

private:
    Outcome attempt(PointId x, KeptReason& reason);
    void perform(PointId x, PointId a, PointId c);
    void block(PointId x, std::initializer_list<PointId> blockers);
    void handle(PointId x);
    void drain();

    const PointSet& set_;
    Cdt& cdt_;
    const DeletionOptions& options_;
    DeletionRecords& rec_;
    ModelError error_;
    std::vector<State> state_;
    std::vector<std::uint32_t> orderPos_;
    std::vector<std::uint32_t> waitHead_;
    struct Wait {
        PointId vertex;
        std::uint32_t next;
    };
    std::vector<Wait> waits_;
    std::priority_queue<std::pair<std::uint32_t, PointId>,
                        std::vector<std::pair<std::uint32_t, PointId>>, std::greater<>>
        retry_;
    std::uint32_t step_ = 0;
    // Scratch.
    std::vector<PointId> link_;
    std::vector<std::uint32_t> tris_, added_;
    std::vector<PointId> path_;
    Cdt::Trace trace_;
    std::vector<TriangleTriple> removedT_, addedT_;
};

bool Sequence::run(const std::vector<PointId>& order, std::string& error) {
    const std::size_t n = set_.points.size();
    assert(cdt_.vertexTriangle.size() == n);
    orderPos_.assign(n, kNil);
    for (std::uint32_t i = 0; i < order.size(); ++i) {
        const PointId v = order[i];
        if (v >= n) {
            error = "deletion order entry " + std::to_string(i) + ": point id " +
                    std::to_string(v) + " out of range";
            return false;
        }
        if (orderPos_[v] != kNil) {
            error = "deletion order entry " + std::to_string(i) + ": point id " +
                    std::to_string(v) + " repeated";
            return false;
        }
        orderPos_[v] = i;
    }
    state_.assign(n, State::Pending);
    waitHead_.assign(n, kNil);
    rec_ = DeletionRecords();
    rec_.removedTriangleOffset = rec_.addedTriangleOffset = {0};
    rec_.removedEdgeOffset = rec_.addedEdgeOffset = {0};
    // Records: about 6.1 removed and 4.1 added triangles per step (net -2); reserved up front and
    // grown by a quarter when exceeded, so that the slack stays small at 10^6 steps.
    rec_.steps.reserve(order.size());
    for (auto* v : {&rec_.removedTriangleOffset, &rec_.addedTriangleOffset, &rec_.removedEdgeOffset,
                    &rec_.addedEdgeOffset})
        v->reserve(order.size() + 1);
    rec_.removedTriangles.reserve(order.size() * 25 / 4);
    rec_.addedTriangles.reserve(order.size() * 17 / 4);
    if (options_.maxError || options_.paperError) {
        error_.init(set_, cdt_, options_.maxError, options_.paperError);
        rec_.initialErrorMax = error_.runningMax();
        rec_.initialErrorPaper = error_.runningPaper();
        if (options_.maxError) rec_.errorMax.reserve(order.size());
        if (options_.paperError) rec_.errorPaper.reserve(order.size());
    }
    for (PointId v : order) {
        if (step_ >= options_.maxSteps) break;
        if (cdt_.representative[v] != v) {
            ++rec_.mergedSkipped;
            continue;
        }
        handle(v);
        drain();
    }
    if (step_ < options_.maxSteps) {
        std::vector<PointId> left;
        for (PointId v : order) {
            if (state_[v] == State::Deferred) left.push_back(v);
        }
        for (PointId v : left)
            rec_.kept.push_back({v, KeptReason::Deferred});
    }
    return true;
}

void Sequence::handle(PointId x) {
    KeptReason reason = KeptReason::Locked;
    const Outcome o = attempt(x, reason);
    if (o == Outcome::Deleted) {
        state_[x] = State::Deleted;
        for (std::uint32_t w = waitHead_[x]; w != kNil; w = waits_[w].next) {
            const PointId v = waits_[w].vertex;
            if (state_[v] == State::Deferred) retry_.push({orderPos_[v], v});
        }
        waitHead_[x] = kNil;
    } else if (o == Outcome::Deferred) {
        if (state_[x] != State::Deferred) ++rec_.deferredVertices;
        state_[x] = State::Deferred;
        ++rec_.deferrals;
    } else {
        state_[x] = State::Kept;
        rec_.kept.push_back({x, reason});
    }
}

void Sequence::drain() {
    while (!retry_.empty() && step_ < options_.maxSteps) {
        const PointId v = retry_.top().second;
        retry_.pop();
        if (state_[v] == State::Deferred) handle(v);
    }
}

void Sequence::block(PointId x, std::initializer_list<PointId> blockers) {
    for (PointId b : blockers) {
        waits_.push_back({x, waitHead_[b]});
        waitHead_[b] = std::uint32_t(waits_.size() - 1);
    }
}

Outcome Sequence::attempt(PointId x, KeptReason& reason) {
    if (cdt_.locked[x]) {
        reason = KeptReason::Locked;
        return Outcome::Refused;
    }
    if (!cdt_.star(x, link_, tris_)) {
        reason = KeptReason::Hull;
        return Outcome::Refused;
    }
    // River edges at x: in triangle (x, link[k], link[k+1]) the edge x -> link[k] is the
    // half-edge opposite link[k+1].
    PointId river[2] = {kNil, kNil};
    std::uint32_t degree = 0;
    for (std::size_t k = 0; k < tris_.size(); ++k) {
        const std::uint32_t h = tris_[k], t = h / 3, i = h % 3;
        if (cdt_.isConstrained(3 * t + (i + 2) % 3)) {
            if (degree < 2) river[degree] = link_[k];
            ++degree;
        }
    }
    if (degree == 0) {
        perform(x, kNil, kNil);
        return Outcome::Deleted;
    }
    if (degree != 2) {
        reason = KeptReason::RiverEnd;
        return Outcome::Refused;
    }
    const PointId a = river[0], c = river[1];
    const std::uint32_t existing = cdt_.findEdge(a, c);
    if (existing != Cdt::kNone && cdt_.isConstrained(existing)) {
        block(x, {a, c});
        return Outcome::Deferred;
    }
    // Exact test on the mesh with x still in it: walk a -> c; only x may lie on the segment.
    cdt_.traceSegment(a, c, trace_);
    if (trace_.end == Cdt::TraceEnd::Vertex && trace_.vertex == x) cdt_.traceSegment(x, c, trace_);
    if (trace_.end == Cdt::TraceEnd::Vertex) {
        block(x, {a, c, trace_.vertex});
        return Outcome::Deferred;
    }
    if (trace_.end == Cdt::TraceEnd::Constraint) {
        block(x, {a, c, cdt_.origin(trace_.edge), cdt_.destination(trace_.edge)});
        return Outcome::Deferred;
    }
    perform(x, a, c);
    return Outcome::Deleted;
}

void Sequence::perform(PointId x, PointId a, PointId c) {
    ++step_;
    cdt_.beginJournal(step_);
    cdt_.removeVertex(x, link_, tris_);
    if (a != kNil) {
        cdt_.constraintEdgeCount -= 2;
        std::string why;
        const bool ok = cdt_.insertSegment(a, c, path_, why);
        assert(ok && path_.size() == 2);
        (void)ok;
        rec_.removedEdges.push_back(makeRiverEdge(a, x));
        rec_.removedEdges.push_back(makeRiverEdge(x, c));
        rec_.addedEdges.push_back(makeRiverEdge(a, c));
    }
    cdt_.endJournal();
    // Created slots still alive, once each.
    added_.clear();
    std::vector<std::uint32_t>& created = cdt_.journalCreated;
    std::sort(created.begin(), created.end());
    created.erase(std::unique(created.begin(), created.end()), created.end());
    for (std::uint32_t t : created) {
        if (cdt_.triangleAlive(t) && cdt_.stamp[t] == step_ && !cdt_.isGhost(t))
            added_.push_back(t);
    }
    // Records: removed minus re-created identical triangles.
    removedT_ = cdt_.journalRemoved;
    addedT_.clear();
    for (std::uint32_t t : added_) {
        addedT_.push_back(
            canonicalTriangle(cdt_.tv[3 * t], cdt_.tv[3 * t + 1], cdt_.tv[3 * t + 2]));
    }
    std::sort(removedT_.begin(), removedT_.end());
    std::sort(addedT_.begin(), addedT_.end());
    {
        std::size_t i = 0, j = 0;
        while (i < removedT_.size() || j < addedT_.size()) {
            if (j == addedT_.size() || (i < removedT_.size() && removedT_[i] < addedT_[j])) {
                pushGrow(rec_.removedTriangles, removedT_[i++]);
            } else if (i == removedT_.size() || addedT_[j] < removedT_[i]) {
                pushGrow(rec_.addedTriangles, addedT_[j++]);
            } else {
                ++i, ++j;
            }
        }
    }
    rec_.steps.push_back({x, cdt_.realTriangleCount, cdt_.constraintEdgeCount});
    rec_.removedTriangleOffset.push_back(std::uint32_t(rec_.removedTriangles.size()));
    rec_.addedTriangleOffset.push_back(std::uint32_t(rec_.addedTriangles.size()));
    rec_.removedEdgeOffset.push_back(std::uint32_t(rec_.removedEdges.size()));
    rec_.addedEdgeOffset.push_back(std::uint32_t(rec_.addedEdges.size()));
    if (options_.maxError) {
        error_.updateMax(cdt_, cdt_.journalRemovedSlots, added_);
        rec_.errorMax.push_back(error_.runningMax());
    }
    if (options_.paperError) {
        error_.removeVertex(x);
        rec_.errorPaper.push_back(error_.runningPaper());
    }
    if (options_.afterStep) options_.afterStep(step_);
}

}  // namespace

std::size_t DeletionRecords::memoryBytes() const {
    return steps.capacity() * sizeof(DeletionStep) +
           (removedTriangleOffset.capacity() + addedTriangleOffset.capacity() +
            removedEdgeOffset.capacity() + addedEdgeOffset.capacity()) *
               4 +
           (removedTriangles.capacity() + addedTriangles.capacity()) * sizeof(TriangleTriple) +
           (removedEdges.capacity() + addedEdges.capacity()) * sizeof(RiverEdge) +
           (errorMax.capacity() + errorPaper.capacity()) * 8 + kept.capacity() * sizeof(KeptVertex);
}

bool runDeletion(const PointSet& set, Cdt& cdt, const std::vector<PointId>& order,
                 const DeletionOptions& options, DeletionRecords& records, std::string& error) {
    Sequence sequence(set, cdt, options, records);
    return sequence.run(order, error);
}

namespace {
template <typename T>
std::vector<T> replay(const std::vector<T>& initial, const std::vector<std::uint32_t>& removedOff,
                      const std::vector<T>& removed, const std::vector<std::uint32_t>& addedOff,
                      const std::vector<T>& added, std::uint32_t k) {
    std::set<T> current(initial.begin(), initial.end());
    for (std::uint32_t s = 0; s < k; ++s) {
        for (std::uint32_t i = removedOff[s]; i < removedOff[s + 1]; ++i) {
            current.erase(removed[i]);
        }
        for (std::uint32_t i = addedOff[s]; i < addedOff[s + 1]; ++i)
            current.insert(added[i]);
    }
    return std::vector<T>(current.begin(), current.end());
}
}  // namespace

std::vector<TriangleTriple> replayTriangles(const std::vector<TriangleTriple>& initial,
                                            const DeletionRecords& records, std::uint32_t k) {
    assert(k <= records.steps.size());
    return replay(initial, records.removedTriangleOffset, records.removedTriangles,
                  records.addedTriangleOffset, records.addedTriangles, k);
}

std::vector<RiverEdge> replayRiverEdges(const std::vector<RiverEdge>& initial,
                                        const DeletionRecords& records, std::uint32_t k) {
    assert(k <= records.steps.size());
    return replay(initial, records.removedEdgeOffset, records.removedEdges, records.addedEdgeOffset,
                  records.addedEdges, k);
}

}  // namespace unilod
