// kd-tree with deletions (see kdtree.h). Median splits on the widest axis of each node's box,
// leaves of at most kLeafSize points. Coordinates are copied in leaf order so that a leaf scan is
// a linear walk over memory.
#include "kdtree.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace unilod {

namespace {
constexpr std::uint32_t kLeafSize = 12;

double boxDistance2(const double lo[3], const double hi[3], double qx, double qy, double qz) {
    const double q[3] = {qx, qy, qz};
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
        const double d = q[a] < lo[a] ? lo[a] - q[a] : (q[a] > hi[a] ? q[a] - hi[a] : 0.0);
        d2 += d * d;
    }
    return d2;
}
}  // namespace

KdTree::KdTree(std::span<const double> x, std::span<const double> y, std::span<const double> z)
    : x_(x.begin(), x.end()), y_(y.begin(), y.end()), z_(z.begin(), z.end()) {
    assert(x.size() == y.size() && y.size() == z.size());
    build();
}

KdTree::KdTree(std::span<const GridPoint> points) {
    x_.resize(points.size());
    y_.resize(points.size());
    z_.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        x_[i] = double(points[i].x);
        y_[i] = double(points[i].y);
        z_[i] = double(points[i].z);
    }
    build();
}

void KdTree::build() {
    const auto n = static_cast<std::uint32_t>(x_.size());
    id_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i)
        id_[i] = i;
    if (n == 0) return;
    nodes_.reserve(2 * (n / kLeafSize + 1));
    const double* coord[3] = {x_.data(), y_.data(), z_.data()};

    // Iterative build: (node index, begin, end) work list; children are appended.
    struct Work {
        std::uint32_t node, begin, end;
    };
    std::vector<Work> work;
    nodes_.push_back(Node{{0, 0, 0}, {0, 0, 0}, 0, n, n, kNone, kNone, kNone});
    work.push_back({0, 0, n});
    while (!work.empty()) {
        const Work w = work.back();
        work.pop_back();
        Node& node = nodes_[w.node];
        for (int a = 0; a < 3; ++a) {
            node.lo[a] = HUGE_VAL;
            node.hi[a] = -HUGE_VAL;
        }
        for (std::uint32_t k = w.begin; k < w.end; ++k) {
            for (int a = 0; a < 3; ++a) {
                node.lo[a] = std::min(node.lo[a], coord[a][id_[k]]);
                node.hi[a] = std::max(node.hi[a], coord[a][id_[k]]);
            }
        }
        if (w.end - w.begin <= kLeafSize) continue;
        int axis = 0;
        for (int a = 1; a < 3; ++a) {
            if (node.hi[a] - node.lo[a] > node.hi[axis] - node.lo[axis]) axis = a;
        }
        const std::uint32_t mid = w.begin + (w.end - w.begin) / 2;
        const double* c = coord[axis];
        // Ties by id keep the build deterministic across standard libraries.
        std::nth_element(id_.begin() + w.begin, id_.begin() + mid, id_.begin() + w.end,
                         [c](std::uint32_t a, std::uint32_t b) {
                             return c[a] < c[b] || (c[a] == c[b] && a < b);
                         });
        const auto left = static_cast<std::uint32_t>(nodes_.size());
        const std::uint32_t parent = w.node;
        nodes_[parent].left = left;
        nodes_[parent].right = left + 1;
        nodes_.push_back(
            Node{{0, 0, 0}, {0, 0, 0}, w.begin, mid, mid - w.begin, parent, kNone, kNone});
        nodes_.push_back(Node{{0, 0, 0}, {0, 0, 0}, mid, w.end, w.end - mid, parent, kNone, kNone});
        work.push_back({left + 1, mid, w.end});
        work.push_back({left, w.begin, mid});
    }

    // Coordinates into leaf order, one axis at a time (one temporary array).
    std::vector<double> tmp(n);
    for (std::vector<double>* axis : {&x_, &y_, &z_}) {
        for (std::uint32_t k = 0; k < n; ++k)
            tmp[k] = (*axis)[id_[k]];
        axis->swap(tmp);
    }
    pos_.resize(n);
    leafOf_.resize(n);
    alive_.assign(n, 1);
    for (std::uint32_t k = 0; k < n; ++k)
        pos_[id_[k]] = k;
    for (std::uint32_t v = 0; v < nodes_.size(); ++v) {
        if (nodes_[v].left != kNone) continue;
        for (std::uint32_t k = nodes_[v].begin; k < nodes_[v].end; ++k)
            leafOf_[k] = v;
    }
}

void KdTree::remove(std::uint32_t i) {
    const std::uint32_t k = pos_[i];
    assert(alive_[k]);
    alive_[k] = 0;
    for (std::uint32_t v = leafOf_[k]; v != kNone; v = nodes_[v].parent)
        --nodes_[v].alive;
}

void KdTree::scanLeaf(const Node& leaf, double qx, double qy, double qz, std::uint32_t& best,
                      double& bestD2) const {
    for (std::uint32_t k = leaf.begin; k < leaf.end; ++k) {
        if (!alive_[k]) continue;
        const double dx = x_[k] - qx, dy = y_[k] - qy, dz = z_[k] - qz;
        const double d2 = dx * dx + dy * dy + dz * dz;
        if (d2 < bestD2 || (d2 == bestD2 && id_[k] < best)) {
            bestD2 = d2;
            best = id_[k];
        }
    }
}

void KdTree::search(std::uint32_t root, double qx, double qy, double qz, std::uint32_t& best,
                    double& bestD2) const {
    // Depth-first, nearer child first. A node is skipped when it is empty or strictly farther than
    // the best so far (not when equal: an equally near point with a lower index may be there).
    struct Item {
        std::uint32_t node;
        double d2;
    };
    Item stack[128];
    int top = 0;
    stack[top++] = {root, 0.0};
    while (top > 0) {
        const Item it = stack[--top];
        if (it.d2 > bestD2) continue;
        const Node& node = nodes_[it.node];
        if (node.alive == 0) continue;
        if (node.left == kNone) {
            scanLeaf(node, qx, qy, qz, best, bestD2);
            continue;
        }
        const Node& l = nodes_[node.left];
        const Node& r = nodes_[node.right];
        const double dl = l.alive ? boxDistance2(l.lo, l.hi, qx, qy, qz) : HUGE_VAL;
        const double dr = r.alive ? boxDistance2(r.lo, r.hi, qx, qy, qz) : HUGE_VAL;
        // Push the farther first so the nearer is explored first.
        if (dl <= dr) {
            if (r.alive && dr <= bestD2) stack[top++] = {node.right, dr};
            if (l.alive && dl <= bestD2) stack[top++] = {node.left, dl};
        } else {
            if (l.alive && dl <= bestD2) stack[top++] = {node.left, dl};
            if (r.alive && dr <= bestD2) stack[top++] = {node.right, dr};
        }
        assert(top < 126);
    }
}

std::uint32_t KdTree::nearest(double qx, double qy, double qz) const {
    std::uint32_t best = kNone;
    double bestD2 = HUGE_VAL;
    if (aliveCount() > 0) search(0, qx, qy, qz, best, bestD2);
    return best;
}

std::uint32_t KdTree::nearestTo(std::uint32_t i) const {
    if (aliveCount() == 0) return kNone;
    const std::uint32_t k = pos_[i];
    const double qx = x_[k], qy = y_[k], qz = z_[k];
    std::uint32_t best = kNone;
    double bestD2 = HUGE_VAL;
    std::uint32_t node = leafOf_[k];
    if (nodes_[node].alive) scanLeaf(nodes_[node], qx, qy, qz, best, bestD2);
    // Walk up; at each level search the sibling subtree if it can hold something as near. Stop
    // once the ball of radius sqrt(bestD2) around q lies strictly inside the current node's box:
    // every point outside it then has a computed distance > bestD2 (coordinates are integers, so
    // the per-axis differences are exact and rounding is monotone).
    while (node != 0) {
        const Node& cur = nodes_[node];
        if (best != kNone) {
            bool inside = true;
            const double q[3] = {qx, qy, qz};
            for (int a = 0; a < 3 && inside; ++a) {
                const double lo = q[a] - cur.lo[a], hi = cur.hi[a] - q[a];
                inside = lo * lo > bestD2 && hi * hi > bestD2;
            }
            if (inside) return best;
        }
        const std::uint32_t parent = cur.parent;
        const std::uint32_t sibling =
            nodes_[parent].left == node ? nodes_[parent].right : nodes_[parent].left;
        const Node& sib = nodes_[sibling];
        if (sib.alive && boxDistance2(sib.lo, sib.hi, qx, qy, qz) <= bestD2) {
            search(sibling, qx, qy, qz, best, bestD2);
        }
        node = parent;
    }
    return best;
}

std::size_t KdTree::memoryBytes() const {
    return nodes_.capacity() * sizeof(Node) +
           (x_.capacity() + y_.capacity() + z_.capacity()) * sizeof(double) +
           (id_.capacity() + pos_.capacity() + leafOf_.capacity()) * sizeof(std::uint32_t) +
           alive_.capacity();
}

}  // namespace unilod
