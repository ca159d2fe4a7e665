// Deletion sequence, records and deferral (paper §3.3 local re-triangulation, §3.2 error):
// see deletion.h for the rules.
#include "deletion.h"

#include <algorithm>
#include <cmath>
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

}  // namespace

std::uint32_t tieRank(PointId v) {
    std::uint32_t h = v;
    h ^= h >> 16;
    h *= 0x7feb352dU;
    h ^= h >> 15;
    h *= 0x846ca68bU;
    h ^= h >> 16;
    return h;
}

namespace {

// Indexed binary min-heap of vertex keys, ties by tieRank (a total order, so the top does not
// depend on the order of updates): at most one entry per vertex, updated in place.
class KeyHeap {
public:
    void reset(std::size_t n) {
        pos_.assign(n, kNil);
        heap_.clear();
    }
    bool empty() const { return heap_.empty(); }
    PointId top() const { return heap_.front().v; }
    double topKey() const { return heap_.front().key; }
    void set(PointId v, double key) {
        std::uint32_t i = pos_[v];
        if (i == kNil) {
            i = std::uint32_t(heap_.size());
            heap_.push_back({key, v, tieRank(v)});
            pos_[v] = i;
        } else {
            heap_[i].key = key;
            i = down(i);
        }
        up(i);
    }
    void erase(PointId v) {
        const std::uint32_t i = pos_[v];
        if (i == kNil) return;
        pos_[v] = kNil;
        const Item last = heap_.back();
        heap_.pop_back();
        if (i == heap_.size()) return;
        heap_[i] = last;
        pos_[last.v] = i;
        up(down(i));
    }
    void pop() { erase(top()); }

private:
    struct Item {
        double key;
        PointId v;
        std::uint32_t rank;  // tieRank(v)
    };
    static bool less(const Item& a, const Item& b) {
        return a.key != b.key ? a.key < b.key : a.rank < b.rank;
    }
    std::uint32_t up(std::uint32_t i) {
        const Item x = heap_[i];
        while (i > 0) {
            const std::uint32_t p = (i - 1) / 2;
            if (!less(x, heap_[p])) break;
            heap_[i] = heap_[p];
            pos_[heap_[i].v] = i;
            i = p;
        }
        heap_[i] = x;
        pos_[x.v] = i;
        return i;
    }
    std::uint32_t down(std::uint32_t i) {
        const Item x = heap_[i];
        const std::uint32_t n = std::uint32_t(heap_.size());
        for (;;) {
            std::uint32_t c = 2 * i + 1;
            if (c >= n) break;
            if (c + 1 < n && less(heap_[c + 1], heap_[c])) ++c;
            if (!less(heap_[c], x)) break;
            heap_[i] = heap_[c];
            pos_[heap_[i].v] = i;
            i = c;
        }
        heap_[i] = x;
        pos_[x.v] = i;
        return i;
    }
    std::vector<Item> heap_;
    std::vector<std::uint32_t> pos_;
};

enum class State : std::uint8_t { Pending = 0, Deleted = 1, Deferred = 2, Kept = 3 };
enum class Outcome : std::uint8_t { Deleted, Deferred, Refused };

class Sequence {
public:
    Sequence(const PointSet& set, Cdt& cdt, const DeletionOptions& options, DeletionRecords& rec)
        : set_(set), cdt_(cdt), options_(options), rec_(rec) {}

    // The given order (3ddp).
    bool run(const std::vector<PointId>& order, std::string& error);
    // The greedy order.
    bool runGreedy(const BaiKeys& keys, std::string& error);

private:
    void start(std::size_t expectedSteps);
    // Whether x may be deleted now: Deleted = yes (a, c: its river neighbours or kNil; link_
    // and tris_ hold its star), Deferred (blockers registered) or Refused (reason).
    Outcome classify(PointId x, KeptReason& reason, PointId& a, PointId& c);
    // The mesh change of deleting x, journaled as step step_ + 1; fills added_.
    void apply(PointId x, PointId a, PointId c);
    // Records and errors of the change apply() made (step_ becomes step_ + 1).
    void record(PointId x, PointId a, PointId c);
    // The deviation of the chain (river or ring) at x: deletion.h.
    double chainDeviation(PointId x) const;
    double builtChainDeviation(std::uint32_t p) const;  // from the chain as built, at position p
    // The deviation bound of the original chain points between positions pa and pc from the
    // segment between their vertices (builtChainDeviation with explicit ends).
    double spanDeviation(std::uint32_t pa, std::uint32_t pc, bool flat) const;
    void reportRiverCover();
    void rollback(PointId x, PointId a, PointId c);
    void setBoundary(PointId x, PointId a, PointId c, bool deleted);
    void block(PointId x, std::initializer_list<PointId> blockers);
    void handle(PointId x);
    void drain();
    void wake(PointId x, std::vector<PointId>& woken);
    // Greedy: evaluates x's key and queues it (or defers / refuses it).
    void evaluate(PointId x);
    double trialError(PointId x, PointId a, PointId c);

    const PointSet& set_;
    Cdt& cdt_;
    const DeletionOptions& options_;
    DeletionRecords& rec_;
    ModelError error_;
    double runningMax_ = 0, runningRiver_ = 0;
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
    // Chains as built: rivers (Cdt::rivers) and boundary rings (Cdt::boundaryRings). Every river
    // vertex of degree 2 and every ring vertex has a position in the flattened chains;
    // riverPrev_ / riverNext_ link each position to the previous / next alive vertex's position,
    // riverSucc_ to the original next position (rings wrap around), ring_ marks ring positions.
    std::vector<std::uint32_t> riverPos_;  // per vertex id; kNil: none
    std::vector<PointId> riverVertex_;     // per position
    std::vector<std::uint32_t> riverPrev_, riverNext_, riverSucc_;
    std::vector<std::uint8_t> ring_;
    // Per position, for the built edge to riverSucc_: the original points it stands for (nodes:
    // DeletionOptions::riverCover; null: none listed) and the slack for any not listed.
    std::vector<const RiverCover*> cover_;
    std::vector<double> slack_;
    std::vector<std::uint32_t> riverFirst_;  // first position of each river line
    bool greedy_ = false;        // ring vertices are candidates (the greedy order only)
    bool boundaryStep_ = false;  // classify() accepted a ring vertex (a, c: its ring neighbours)
    std::uint32_t domainTriangles_ = 0, riverEdges_ = 0;  // alive, for the records
    // Greedy.
    const BaiKeys* keys_ = nullptr;
    KeyHeap heap_;
    bool straightHull_ = false;  // delete straight-hull vertices (greedy)
    bool hullStar_ = false;      // the vertex classify() accepted is such a hull vertex
    std::vector<std::uint8_t> local_;  // the key was evaluated on a change confined to the star
    // Scratch.
    std::vector<PointId> link_;
    std::vector<std::uint32_t> tris_, added_, plan_, starSlots_;
    std::vector<std::uint32_t> errorRemoved_, errorAdded_;  // apply(): the model error's change
    std::vector<PointId> corners_;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> planOrder_;
    std::vector<PointId> path_, touched_, woken_;
    std::vector<std::uint32_t> sideSlots_;
    Cdt::Trace trace_;
    std::vector<TriangleTriple> removedT_, addedT_;
};

void Sequence::start(std::size_t expectedSteps) {
    const std::size_t n = set_.points.size();
    state_.assign(n, State::Pending);
    waitHead_.assign(n, kNil);
    rec_ = DeletionRecords();
    rec_.removedTriangleOffset = rec_.addedTriangleOffset = {0};
    rec_.removedEdgeOffset = rec_.addedEdgeOffset = {0};
    // Records: about 6.1 removed and 4.1 added triangles per step (net -2); reserved up front and
    // grown by a quarter when exceeded, so that the slack stays small at 10^6 steps.
    rec_.steps.reserve(expectedSteps);
    for (auto* v : {&rec_.removedTriangleOffset, &rec_.addedTriangleOffset, &rec_.removedEdgeOffset,
                    &rec_.addedEdgeOffset})
        v->reserve(expectedSteps + 1);
    rec_.removedTriangles.reserve(expectedSteps * 25 / 4);
    rec_.addedTriangles.reserve(expectedSteps * 17 / 4);
    if (options_.maxError || options_.paperError) {
        error_.init(set_, cdt_, options_.maxError, options_.paperError, options_.extraSamples,
                    options_.releaseExtraSamples);
        rec_.initialErrorMax =
            options_.maxError ? std::max(error_.runningMax(), options_.errorFloor) : 0.0;
        rec_.initialErrorPaper = error_.runningPaper();
        runningMax_ = rec_.initialErrorMax;
        rec_.initialErrorRiver =
            options_.maxError ? std::min(options_.riverFloor, rec_.initialErrorMax) : 0.0;
        runningRiver_ = rec_.initialErrorRiver;
        if (options_.maxError) {
            rec_.errorMax.reserve(expectedSteps);
            rec_.errorRiver.reserve(expectedSteps);
            rec_.stepErrorMax.reserve(expectedSteps);
        }
        if (options_.paperError) rec_.errorPaper.reserve(expectedSteps);
    }
    // River positions (the CDT's polylines: split at vertices on segments, representatives).
    riverPos_.assign(n, kNil);
    riverVertex_.clear();
    riverPrev_.clear();
    riverNext_.clear();
    riverSucc_.clear();
    ring_.clear();
    slack_.clear();
    cover_.clear();
    riverFirst_.clear();
    auto coverOf = [&](PointId u, PointId w) -> const RiverCover* {
        if (options_.riverCover == nullptr) return nullptr;
        const auto it = options_.riverCover->find(Cdt::edgeKey(std::min(u, w), std::max(u, w)));
        return it != options_.riverCover->end() ? &it->second : nullptr;
    };
    for (const Polyline& line : cdt_.rivers) {
        const std::uint32_t base = std::uint32_t(riverVertex_.size());
        riverFirst_.push_back(base);
        for (std::size_t i = 0; i < line.size(); ++i) {
            const RiverCover* c = i + 1 == line.size() ? nullptr : coverOf(line[i], line[i + 1]);
            cover_.push_back(c);
            slack_.push_back(c != nullptr ? c->slack : options_.chainSlack);
            const std::uint32_t p = base + std::uint32_t(i);
            riverVertex_.push_back(line[i]);
            riverPrev_.push_back(i == 0 ? kNil : p - 1);
            riverNext_.push_back(i + 1 == line.size() ? kNil : p + 1);
            riverSucc_.push_back(riverNext_.back());
            ring_.push_back(0);
            if (i > 0 && i + 1 < line.size() && riverPos_[line[i]] == kNil)
                riverPos_[line[i]] = p;
        }
    }
    for (const Polyline& ring : cdt_.boundaryRings) {
        const std::uint32_t base = std::uint32_t(riverVertex_.size());
        const std::uint32_t len = std::uint32_t(ring.size());
        for (std::uint32_t i = 0; i < len; ++i) {
            const std::uint32_t p = base + i;
            riverVertex_.push_back(ring[i]);
            riverPrev_.push_back(base + (i + len - 1) % len);
            riverNext_.push_back(base + (i + 1) % len);
            riverSucc_.push_back(riverNext_.back());
            ring_.push_back(1);
            slack_.push_back(options_.chainSlack);
            cover_.push_back(nullptr);
            if (ring[i] < n && riverPos_[ring[i]] == kNil) riverPos_[ring[i]] = p;
        }
    }
    domainTriangles_ = std::uint32_t(collectTriangles(cdt_).size());
    riverEdges_ = std::uint32_t(collectRiverEdges(cdt_).size());
}

bool Sequence::run(const std::vector<PointId>& order, std::string& error) {
    const std::size_t n = set_.points.size();
    assert(cdt_.vertexTriangle.size() >= n);  // frame vertices after the points
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
    start(order.size());
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

void Sequence::wake(PointId x, std::vector<PointId>& woken) {
    for (std::uint32_t w = waitHead_[x]; w != kNil; w = waits_[w].next) {
        const PointId v = waits_[w].vertex;
        if (state_[v] == State::Deferred) woken.push_back(v);
    }
    waitHead_[x] = kNil;
}

void Sequence::handle(PointId x) {
    KeptReason reason = KeptReason::Locked;
    PointId a = kNil, c = kNil;
    const Outcome o = classify(x, reason, a, c);
    if (o == Outcome::Deleted) {
        apply(x, a, c);
        record(x, a, c);
        state_[x] = State::Deleted;
        woken_.clear();
        wake(x, woken_);
        for (PointId v : woken_)
            retry_.push({orderPos_[v], v});
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

Outcome Sequence::classify(PointId x, KeptReason& reason, PointId& a, PointId& c) {
    a = c = kNil;
    if (cdt_.locked[x]) {
        reason = KeptReason::Locked;
        return Outcome::Refused;
    }
    hullStar_ = false;
    boundaryStep_ = false;
    if (!cdt_.star(x, link_, tris_)) {
        // The greedy order also deletes a hull vertex on a straight stretch of the hull.
        if (straightHull_ && cdt_.straightHullStar(x, link_, tris_)) {
            hullStar_ = true;
            return Outcome::Deleted;
        }
        reason = KeptReason::Hull;
        return Outcome::Refused;
    }
    // River edges at x: in triangle (x, link[k], link[k+1]) the edge x -> link[k] is the
    // half-edge opposite link[k+1].
    PointId river[2] = {kNil, kNil};
    std::uint32_t degree = 0, boundaryIn = 0, boundaryOut = 0;
    PointId ringA = kNil, ringC = kNil;
    for (std::size_t k = 0; k < tris_.size(); ++k) {
        const std::uint32_t h = tris_[k], t = h / 3, i = h % 3;
        if (cdt_.isConstrained(3 * t + (i + 2) % 3)) {
            if (cdt_.boundaryDirected(link_[k], x)) {
                ++boundaryIn, ringA = link_[k];
            } else if (cdt_.boundaryDirected(x, link_[k])) {
                ++boundaryOut, ringC = link_[k];
            } else {
                if (degree < 2) river[degree] = link_[k];
                ++degree;
            }
        }
    }
    if (boundaryIn + boundaryOut > 0) {
        // A ring vertex: a candidate of the greedy order when it joins exactly two ring edges
        // and no river (a pinch point of the outline, or a river reaching the outline, stays).
        if (!greedy_ || degree != 0 || boundaryIn != 1 || boundaryOut != 1) {
            reason = KeptReason::Hull;
            return Outcome::Refused;
        }
        // A corner moves the outline to A-C: the triangle (A, x, C) changes sides. Every
        // triangle in it must be one this step re-creates (their sides are then set anew), which
        // holds exactly when no vertex lies strictly inside it; and one would, if any did, among
        // x's neighbours (a vertex inside, not adjacent to x, would lie in a triangle of x's
        // star). So a neighbour strictly inside defers x until it (or A or C) is gone.
        const std::int64_t turn = cdt_.orient(ringA, x, ringC);
        if (turn != 0) {
            const int sign = turn > 0 ? 1 : -1;
            auto sgn = [](std::int64_t v) { return v > 0 ? 1 : (v < 0 ? -1 : 0); };
            for (PointId l : link_) {
                if (l == ringA || l == ringC) continue;
                if (sgn(cdt_.orient(ringA, x, l)) == sign && sgn(cdt_.orient(x, ringC, l)) == sign &&
                    sgn(cdt_.orient(ringC, ringA, l)) == sign) {
                    block(x, {ringA, ringC, l});
                    return Outcome::Deferred;
                }
            }
        }
        boundaryStep_ = true;
        a = ringA, c = ringC;
    } else if (degree == 0) {
        return Outcome::Deleted;
    } else if (degree != 2) {
        reason = KeptReason::RiverEnd;
        return Outcome::Refused;
    } else {
        a = river[0], c = river[1];
    }
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
    return Outcome::Deleted;
}

void Sequence::apply(PointId x, PointId a, PointId c) {
    // x's star lies on one side of the outline unless a ring edge meets x (a ring step) or x is
    // on the hull: every triangle the step creates is then on that side.
    const bool oneSide = !boundaryStep_ && !hullStar_;
    const bool side = oneSide && cdt_.exterior(tris_.front() / 3);
    cdt_.beginJournal(step_ + 1);
    // Where a-c is a diagonal or an edge of x's hole (a ring step: classify deferred x for any
    // neighbour inside the triangle (a, x, c) or on a-c; a river step: x on the straight segment
    // a-c), the new edge is made with the removal (Cdt::removeVertexWithDiagonal, counted);
    // elsewhere it is inserted after it.
    const bool diagonal =
        !hullStar_ && a != kNil && (boundaryStep_ || cdt_.strictlyBetween(a, x, c));
    if (diagonal) {
        const auto ia = std::find(link_.begin(), link_.end(), a) - link_.begin();
        const auto ic = std::find(link_.begin(), link_.end(), c) - link_.begin();
        cdt_.removeVertexWithDiagonal(x, link_, tris_, std::uint32_t(ia), std::uint32_t(ic));
    } else if (hullStar_) {
        cdt_.removeHullVertex(x, link_, tris_);
    } else {
        cdt_.removeVertex(x, link_, tris_);
    }
    if (a != kNil) {
        cdt_.constraintEdgeCount -= 2;  // x's two edges
        if (diagonal) {
            path_.assign({a, c});
        } else {
            std::string why;
            const bool ok = cdt_.insertSegment(a, c, path_, why);
            assert(ok && path_.size() == 2);
            (void)ok;
        }
        if (boundaryStep_) setBoundary(x, a, c, true);
    }
    if (cdt_.frameFirst != Cdt::kGhost) {
        // The side of every new triangle (a ring step moves the outline to A-C).
        sideSlots_.clear();
        for (std::uint32_t t : cdt_.journalCreated)
            if (cdt_.triangleAlive(t) && cdt_.stamp[t] == step_ + 1) sideSlots_.push_back(t);
        if (oneSide) {
            cdt_.setSides(sideSlots_, side);
#ifndef NDEBUG
            std::vector<std::uint8_t> set;
            for (std::uint32_t t : sideSlots_)
                set.push_back(cdt_.exterior(t));
            cdt_.assignSides(sideSlots_);
            for (std::size_t i = 0; i < sideSlots_.size(); ++i)
                assert(set[i] == cdt_.exterior(sideSlots_[i]) && "one-sided step");
#endif
        } else {
            cdt_.assignSides(sideSlots_);
        }
    }
    cdt_.endJournal();
    // Created slots still alive, once each.
    added_.clear();
    std::vector<std::uint32_t>& created = cdt_.journalCreated;
    std::sort(created.begin(), created.end());
    created.erase(std::unique(created.begin(), created.end()), created.end());
    for (std::uint32_t t : created) {
        if (cdt_.triangleAlive(t) && cdt_.stamp[t] == step_ + 1 && !cdt_.isGhost(t))
            added_.push_back(t);
    }
    // The change as the model error sees it: the destroyed and created slots, and for a ring step
    // whose new outline edge A-C was an edge already (the triangle (A, x, C) was in x's star),
    // the old triangle across A-C as destroyed and re-created. A point ON A-C is in the domain
    // now (closed; modelerror.h) and must sit in the domain triangle beside A-C, so that its
    // error counts now and whenever that triangle changes; it may be in the old triangle's
    // bucket, which the step did not touch: an exterior one (the outline moved out over the
    // point, whose error was 0 outside) or the domain one (the outline moved in to A-C and the
    // point would go to the exterior side). Re-located with both sides at hand, it goes to the
    // domain side (its value, |z - the heights interpolated along A-C|, depends on A, C and the
    // point only, so the greedy key stays local to x's star).
    errorRemoved_ = cdt_.journalRemovedSlots;
    errorAdded_ = added_;
    if (boundaryStep_) {
        const std::uint32_t h = cdt_.findEdge(a, c);
        assert(h != Cdt::kNone);
        for (const std::uint32_t e : {h, cdt_.tn[h]}) {
            const std::uint32_t t = e / 3;
            if (cdt_.isGhost(t) || std::find(added_.begin(), added_.end(), t) != added_.end())
                continue;
            errorRemoved_.push_back(t);
            errorAdded_.push_back(t);
        }
    }
}

void Sequence::setBoundary(PointId x, PointId a, PointId c, bool deleted) {
    auto& b = cdt_.boundary;
    if (deleted) {
        b.erase(Cdt::edgeKey(a, x));
        b.erase(Cdt::edgeKey(x, c));
        b.insert(Cdt::edgeKey(a, c));
    } else {
        b.erase(Cdt::edgeKey(a, c));
        b.insert(Cdt::edgeKey(a, x));
        b.insert(Cdt::edgeKey(x, c));
    }
}

void Sequence::rollback(PointId x, PointId a, PointId c) {
    cdt_.rollbackTrial();
    if (boundaryStep_) setBoundary(x, a, c, false);
}

double Sequence::chainDeviation(PointId x) const {
    const std::uint32_t p = riverPos_[x];
    if (p == kNil) return 0;
    return builtChainDeviation(p);
}

double Sequence::builtChainDeviation(std::uint32_t p) const {
    assert(riverPrev_[p] != kNil && riverNext_[p] != kNil);
    // Rings: the planimetric deviation (the outline is drawn on the surface); rivers: 3D.
    return spanDeviation(riverPrev_[p], riverNext_[p], ring_[p] != 0);
}

void Sequence::reportRiverCover() {
    rec_.riverCover.clear();
    for (const std::uint32_t first : riverFirst_) {
        for (std::uint32_t p = first; riverNext_[p] != kNil; p = riverNext_[p]) {
            const std::uint32_t q = riverNext_[p];
            const PointId a = riverVertex_[p], b = riverVertex_[q];
            // (A line end of degree 2 may have gone, joining two lines: its position is not
            // updated, and the edges it left are not reported.)
            if (!cdt_.isVertex(a) || !cdt_.isVertex(b)) continue;
            const std::uint32_t h = cdt_.findEdge(a, b);
            if (h == Cdt::kNone || !cdt_.isConstrained(h)) continue;
            RiverCover c;
            for (std::uint32_t r = p;;) {
                c.slack = std::max(c.slack, slack_[r]);
                if (cover_[r] != nullptr)
                    c.points.insert(c.points.end(), cover_[r]->points.begin(),
                                    cover_[r]->points.end());
                r = riverSucc_[r];
                if (r == q || r == kNil) break;
                const Point& m = set_.points[riverVertex_[r]];
                c.points.push_back({m.x, m.y, m.z});
            }
            rec_.riverCover.push_back({{std::min(a, b), std::max(a, b)}, std::move(c)});
            if (q == first) break;  // a closed loop
        }
    }
    std::sort(rec_.riverCover.begin(), rec_.riverCover.end(),
              [](const auto& l, const auto& r) { return l.first < r.first; });
}

double Sequence::spanDeviation(std::uint32_t pa, std::uint32_t pc, bool flat) const {
    const PointId a = riverVertex_[pa], c = riverVertex_[pc];
    const double u = cdt_.gridUnit;
    const double ax = double(cdt_.gx[a]) * u, ay = double(cdt_.gy[a]) * u,
                 az = flat ? 0.0 : set_.points[a].z;
    const double dx = double(cdt_.gx[c]) * u - ax, dy = double(cdt_.gy[c]) * u - ay,
                 dz = flat ? 0.0 : set_.points[c].z - az;
    const double len2 = dx * dx + dy * dy + dz * dz;
    double worst = 0, slack = 0;
    auto distance = [&](double mx, double my, double mz) {
        double t = len2 > 0 ? (mx * dx + my * dy + mz * dz) / len2 : 0.0;
        t = std::clamp(t, 0.0, 1.0);
        const double ex = mx - t * dx, ey = my - t * dy, ez = mz - t * dz;
        worst = std::max(worst, std::sqrt(ex * ex + ey * ey + ez * ez));
    };
    for (std::uint32_t q = pa;;) {
        slack = std::max(slack, slack_[q]);
        if (cover_[q] != nullptr) {
            for (const auto& o : cover_[q]->points)
                distance(o[0] - cdt_.originX - ax, o[1] - cdt_.originY - ay, flat ? 0.0 : o[2] - az);
        }
        q = riverSucc_[q];
        if (q == pc) break;
        const PointId m = riverVertex_[q];
        distance(double(cdt_.gx[m]) * u - ax, double(cdt_.gy[m]) * u - ay,
                 flat ? 0.0 : set_.points[m].z - az);
    }
    return worst + slack;
}

void Sequence::record(PointId x, PointId a, PointId c) {
    ++step_;
    if (a != kNil && !boundaryStep_) {
        --riverEdges_;
        rec_.removedEdges.push_back(makeRiverEdge(a, x));
        rec_.removedEdges.push_back(makeRiverEdge(x, c));
        rec_.addedEdges.push_back(makeRiverEdge(a, c));
    }
    // Records: removed minus re-created identical triangles.
    removedT_ = cdt_.journalRemoved;
    addedT_.clear();
    for (std::uint32_t t : added_) {
        if (cdt_.exterior(t)) continue;  // outside the domain: in no level
        addedT_.push_back(
            canonicalTriangle(cdt_.tv[3 * t], cdt_.tv[3 * t + 1], cdt_.tv[3 * t + 2]));
    }
    domainTriangles_ = std::uint32_t(domainTriangles_ + addedT_.size() - removedT_.size());
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
    rec_.steps.push_back({x, domainTriangles_, riverEdges_});
    rec_.removedTriangleOffset.push_back(std::uint32_t(rec_.removedTriangles.size()));
    rec_.addedTriangleOffset.push_back(std::uint32_t(rec_.addedTriangles.size()));
    rec_.removedEdgeOffset.push_back(std::uint32_t(rec_.removedEdges.size()));
    rec_.addedEdgeOffset.push_back(std::uint32_t(rec_.addedEdges.size()));
    if (options_.maxError) {
        const double vertical = error_.updateMax(cdt_, errorRemoved_, errorAdded_);
        const double river = chainDeviation(x);
        const double stepError = std::max(vertical, river);
        runningMax_ = std::max(runningMax_, stepError);
        runningRiver_ = std::max(runningRiver_, river);
        rec_.stepErrorMax.push_back(stepError);
        rec_.errorMax.push_back(runningMax_);
        rec_.errorRiver.push_back(runningRiver_);
    }
    if (options_.paperError) {
        error_.removeVertex(x);
        rec_.errorPaper.push_back(error_.runningPaper());
    }
    // Unlink x from its river (after the deviation, which reads its neighbours).
    if (const std::uint32_t p = riverPos_[x]; p != kNil) {
        riverNext_[riverPrev_[p]] = riverNext_[p];
        riverPrev_[riverNext_[p]] = riverPrev_[p];
    }
    if (options_.afterStep) options_.afterStep(step_);
}

// --- Greedy order -----------------------------------------------------------------------------

double Sequence::trialError(PointId x, PointId a, PointId c) {
    cdt_.beginTrial();
    apply(x, a, c);
    const double vertical = error_.evaluateMax(cdt_, errorRemoved_, errorAdded_);
    // Only x's star changed (no flip outside it for A-C): the key depends on nothing else, and
    // every change to the star evaluates x again.
    local_[x] = cdt_.journalRemovedSlots.size() == tris_.size() ? 1 : 0;
    rollback(x, a, c);
    return std::max(vertical, chainDeviation(x));
}

void Sequence::evaluate(PointId x) {
    KeptReason reason = KeptReason::Locked;
    PointId a = kNil, c = kNil;
    const Outcome o = classify(x, reason, a, c);
    if (o != Outcome::Deleted) heap_.erase(x);
    if (o == Outcome::Refused) {
        state_[x] = State::Kept;
        rec_.kept.push_back({x, reason});
        return;
    }
    if (o == Outcome::Deferred) {
        if (state_[x] != State::Deferred) ++rec_.deferredVertices;
        state_[x] = State::Deferred;
        ++rec_.deferrals;
        return;
    }
    state_[x] = State::Pending;
    if (a == kNil) {
        // No river edge: the change is the hole of x's star, planned without touching the mesh
        // (the same plan removeVertex then carries out). The ring's heights and the star's
        // point ranges are fetched while the plan is made (the model error reads them next; on
        // a large block they are cache misses).
        for (const PointId v : link_) {
            if (v < set_.points.size()) __builtin_prefetch(&set_.points[v].z);  // not a frame vertex
        }
        for (const std::uint32_t h : tris_)
            error_.prefetchRange(h / 3);
        cdt_.planHole(link_, plan_);
        starSlots_.clear();
        for (std::uint32_t h : tris_)
            starSlots_.push_back(h / 3);
        // In the order the deletion will evaluate them (by slot: removeVertex frees the star's
        // slots in star order and the plan's triangles take them back last-in first-out), so
        // that a point on an edge between two new triangles gets the same rounding: the key
        // is then exactly the realised error.
        const std::size_t count = plan_.size() / 3, k = starSlots_.size();
        planOrder_.resize(count);
        for (std::size_t j = 0; j < count; ++j) {
            // Insertion by slot (a handful of triangles; the slots are distinct).
            const std::pair<std::uint32_t, std::uint32_t> entry{starSlots_[k - 1 - j], std::uint32_t(j)};
            std::size_t at = j;
            for (; at > 0 && planOrder_[at - 1].first > entry.first; --at)
                planOrder_[at] = planOrder_[at - 1];
            planOrder_[at] = entry;
        }
        corners_.clear();
        for (const auto& [slot, j] : planOrder_) {
            for (int i = 0; i < 3; ++i)
                corners_.push_back(link_[plan_[3 * j + std::size_t(i)]]);
        }
        local_[x] = 1;
        // No ring edge at x: its whole star lies on one side of the outline.
        heap_.set(x, error_.evaluatePlannedMax(cdt_, starSlots_, corners_,
                                               cdt_.exterior(tris_.front() / 3)));
        return;
    }
    const double e = trialError(x, a, c);
    heap_.set(x, keys_ != nullptr && !boundaryStep_ ? keys_->key(x, e) : e);
}

bool Sequence::runGreedy(const BaiKeys& keys, std::string& error) {
    const std::size_t n = set_.points.size();
    assert(cdt_.vertexTriangle.size() >= n);  // frame vertices after the points
    if (!options_.maxError) {
        error = "the greedy order needs the max metric";
        return false;
    }
    if (!keys.empty() && keys.size() != n) {
        error = "greedy order: BAI keys of " + std::to_string(keys.size()) + " points for " +
                std::to_string(n) + " points";
        return false;
    }
    keys_ = keys.empty() ? nullptr : &keys;
    straightHull_ = true;
    greedy_ = true;
    start(cdt_.vertexCount);
    heap_.reset(n);
    local_.assign(n, 0);
    for (PointId v = 0; v < n; ++v) {
        // Locked points take no part (as in the 3ddp order); a vertex that merged a locked
        // point is refused as Locked by evaluate().
        if (cdt_.representative[v] != v) continue;
        if (set_.points[v].locked) {
            state_[v] = State::Kept;  // never evaluated, never listed (as in 3ddp)
            continue;
        }
        evaluate(v);
    }
    auto stopped = [&] {
        return step_ >= options_.maxSteps ||
               (options_.stopTriangles > 0 && domainTriangles_ <= options_.stopTriangles);
    };
    bool handedOver = !options_.onHandover;
    auto handOver = [&] {
        reportRiverCover();
        options_.onHandover();
        handedOver = true;
    };
    while (!heap_.empty() && !stopped()) {
        const PointId x = heap_.top();
        const double key = heap_.topKey();
        if (!handedOver &&
            ((options_.handoverTriangles > 0 && domainTriangles_ <= options_.handoverTriangles) ||
             (key > options_.handoverKey && domainTriangles_ <= options_.handoverKeyTriangles)))
            handOver();
        if (key > options_.stopKey) break;
        heap_.pop();
        assert(state_[x] == State::Pending);
        KeptReason reason = KeptReason::Locked;
        PointId a = kNil, c = kNil;
        const Outcome o = classify(x, reason, a, c);
        if (o != Outcome::Deleted) {  // newly blocked by a river edge inserted elsewhere
            if (o == Outcome::Deferred) {
                if (state_[x] != State::Deferred) ++rec_.deferredVertices;
                state_[x] = State::Deferred;
                ++rec_.deferrals;
            } else {
                state_[x] = State::Kept;
                rec_.kept.push_back({x, reason});
            }
            continue;
        }
        if (local_[x]) {
            apply(x, a, c);
        } else {
            // The key also depended on triangles outside the star, which may have changed since:
            // delete for real on a trial and keep it only when it causes exactly the key.
            cdt_.beginTrial();
            apply(x, a, c);
            const double realised =
                std::max(error_.evaluateMax(cdt_, errorRemoved_, errorAdded_), chainDeviation(x));
            const double now =
                a != kNil && !boundaryStep_ && keys_ != nullptr ? keys_->key(x, realised) : realised;
            if (now != key) {
                rollback(x, a, c);
                local_[x] = cdt_.journalRemovedSlots.size() == tris_.size() ? 1 : 0;
                heap_.set(x, now);
                continue;
            }
            cdt_.commitTrial();
        }
        // The vertices whose star changed: every corner of a created triangle.
        touched_.clear();
        for (std::uint32_t t : added_) {
            for (int i = 0; i < 3; ++i)
                touched_.push_back(cdt_.tv[3 * t + i]);
        }
        record(x, a, c);
        state_[x] = State::Deleted;
        woken_.clear();
        wake(x, woken_);
        std::sort(woken_.begin(), woken_.end());
        touched_.insert(touched_.end(), woken_.begin(), woken_.end());
        std::sort(touched_.begin(), touched_.end());
        touched_.erase(std::unique(touched_.begin(), touched_.end()), touched_.end());
        for (PointId v : touched_) {
            if (v >= n) continue;  // a frame vertex (cdt.h "Domain")
            if (v == x || state_[v] == State::Deleted || state_[v] == State::Kept) continue;
            // A deferred vertex stays blocked until one of its blockers goes (then it is woken).
            if (state_[v] == State::Deferred &&
                !std::binary_search(woken_.begin(), woken_.end(), v))
                continue;
            evaluate(v);
        }
    }
    if (!stopped()) {
        for (PointId v = 0; v < n; ++v) {
            if (state_[v] == State::Deferred) rec_.kept.push_back({v, KeptReason::Deferred});
        }
    }
    if (!handedOver) handOver();
    reportRiverCover();
    return true;
}

}  // namespace

std::size_t DeletionRecords::memoryBytes() const {
    return steps.capacity() * sizeof(DeletionStep) +
           (removedTriangleOffset.capacity() + addedTriangleOffset.capacity() +
            removedEdgeOffset.capacity() + addedEdgeOffset.capacity()) *
               4 +
           (removedTriangles.capacity() + addedTriangles.capacity()) * sizeof(TriangleTriple) +
           (removedEdges.capacity() + addedEdges.capacity()) * sizeof(RiverEdge) +
           (errorMax.capacity() + errorPaper.capacity() + errorRiver.capacity() +
            stepErrorMax.capacity()) * 8 +
           kept.capacity() * sizeof(KeptVertex);
}

bool runDeletion(const PointSet& set, Cdt& cdt, const std::vector<PointId>& order,
                 const DeletionOptions& options, DeletionRecords& records, std::string& error) {
    Sequence sequence(set, cdt, options, records);
    return sequence.run(order, error);
}

bool runGreedyDeletion(const PointSet& set, Cdt& cdt, const BaiKeys& keys,
                       const DeletionOptions& options, DeletionRecords& records,
                       std::string& error) {
    Sequence sequence(set, cdt, options, records);
    return sequence.runGreedy(keys, error);
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
