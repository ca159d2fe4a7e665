// A static 3D kd-tree with deletions, for nearest-neighbour queries over a shrinking point set
// (the 3D_DP nearest-neighbour chain, paper §2.1; nearest retained point for the model error,
// paper §3.2 Eq. 3). Built once in O(n log n); each node keeps the number of alive points below
// it, so empty subtrees are skipped and a query stays fast even when most points are gone.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "grid.h"

namespace unilod {

class KdTree {
public:
    static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

    KdTree() = default;
    // Builds over points [0, n) with coordinates (x[i], y[i], z[i]); all alive.
    KdTree(std::span<const double> x, std::span<const double> y, std::span<const double> z);
    // Builds over grid points (coordinates in grid units).
    explicit KdTree(std::span<const GridPoint> points);

    void remove(std::uint32_t i);  // i must be alive
    bool alive(std::uint32_t i) const { return alive_[pos_[i]] != 0; }
    std::uint32_t aliveCount() const { return nodes_.empty() ? 0 : nodes_[0].alive; }

    // Nearest alive point to q in 3D Euclidean distance; ties go to the lowest index.
    // kNone when no point is alive.
    std::uint32_t nearest(double qx, double qy, double qz) const;
    // The same for the position of point i (alive or not), searching bottom-up from i's leaf:
    // much faster when the answer is close, as in a nearest-neighbour chain.
    std::uint32_t nearestTo(std::uint32_t i) const;

    double x(std::uint32_t i) const { return x_[pos_[i]]; }
    double y(std::uint32_t i) const { return y_[pos_[i]]; }
    double z(std::uint32_t i) const { return z_[pos_[i]]; }

    std::size_t memoryBytes() const;

private:
    void build();  // x_, y_, z_ hold the coordinates by point index on entry, leaf order after

    struct Node {
        double lo[3], hi[3];       // bounding box of the node's points
        std::uint32_t begin, end;  // range in the leaf order
        std::uint32_t alive;       // alive points below
        std::uint32_t parent;
        std::uint32_t left, right;  // kNone for leaves
    };
    // Top-down search below `node`, improving (best, bestD2).
    void search(std::uint32_t node, double qx, double qy, double qz, std::uint32_t& best,
                double& bestD2) const;
    void scanLeaf(const Node& leaf, double qx, double qy, double qz, std::uint32_t& best,
                  double& bestD2) const;

    std::vector<Node> nodes_;
    std::vector<double> x_, y_, z_;      // coordinates in leaf order
    std::vector<std::uint32_t> id_;      // leaf order -> point index
    std::vector<std::uint32_t> pos_;     // point index -> leaf order
    std::vector<std::uint32_t> leafOf_;  // leaf order position -> leaf node
    std::vector<std::uint8_t> alive_;    // by leaf order position
};

}  // namespace unilod
