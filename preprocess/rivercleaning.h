// River network cleaning (paper §3, DESIGN.md "Point set"; issue 4 §2): turns the river lines as
// read (rivers.h) into a planar network that the river-constrained Delaunay triangulation (cdt.h)
// accepts — rivers meet only at shared vertices, nothing crosses or overlaps, every line lies on
// the valid DEM area, tiny rivers are gone (paper: "eliminated scattered and tiny rivers").
#pragma once

#include <cstddef>
#include <string>

#include "dem.h"
#include "rivers.h"

namespace unilod {

struct RiverCleaningOptions {
    // Metres. A line endpoint closer than this (horizontally) to a vertex or segment of another
    // line is moved onto it (a junction the digitiser missed). The caller usually derives it from
    // the DEM cell size (e.g. 1 %); 0 disables snapping.
    double snapTolerance = 0.5;
    // Metres. Lines whose total horizontal length after cleaning is shorter are dropped.
    double minRiverLength = 0;
};

// What cleanRivers changed, for logs and the CLI.
struct RiverCleaningStats {
    std::size_t inputLines = 0, inputVertices = 0;
    std::size_t verticesOutsideDem = 0;  // dropped (lines split there): not finite DemGrid::sample
    std::size_t segmentsCut = 0;         // segments cut where they leave / enter the valid DEM
    std::size_t duplicateVertices = 0;   // consecutive vertices with identical input (x, y)
    std::size_t zeroLengthSegments = 0;  // segments shorter than the 1 mm grid, collapsed
    std::size_t degenerateLines = 0;     // pieces with fewer than 2 distinct vertices, dropped
    std::size_t snappedToVertex = 0;     // endpoints moved onto another line's vertex
    std::size_t snappedToSegment = 0;    // endpoints moved onto another line's segment (T)
    std::size_t crossingsSplit = 0;      // proper crossings: a shared vertex inserted in both
    std::size_t selfCrossings = 0;       // ... of those, a line crossing itself
    std::size_t touchesSplit = 0;        // a vertex on / within 1 mm of another segment: inserted
    std::size_t verticesMerged = 0;      // distinct vertices within 1 mm of each other: merged
    std::size_t overlapsDropped = 0;     // collinear overlapping segments: the later copy dropped
    std::size_t unresolvedDropped = 0;   // segments dropped because passes did not converge
    std::size_t selfLoopSplits = 0;      // lines cut where they pass a vertex twice
    std::size_t shortLinesDropped = 0;   // shorter than minRiverLength
    std::size_t passes = 0;              // intersection passes run
    std::size_t outputLines = 0, outputVertices = 0;
    // Set by ingest (densifyRivers), not by cleanRivers: vertices inserted into long segments
    // before cleaning (not counted in inputVertices).
    std::size_t densifiedVertices = 0;
};

// Returns the cleaned network. Guarantees:
//   - every vertex has a finite DemGrid::sample and lies on the 1 mm grid (x = round(x * 1000) /
//     1000 in metres, so equal grid points are identical doubles);
//   - every line has >= 2 vertices, no zero-length segment and no vertex twice (a line that
//     passed a vertex twice is cut there; only first == last, a closed ring, remains possible);
//   - any two segments of the output either do not meet or meet exactly at a shared vertex
//     (identical x and y) that is an endpoint of both, and no vertex lies within 1 mm of the
//     interior of a segment it is not an endpoint of (the exact CDT sees no near-degeneracy).
// Lines are not split at junctions: two crossing lines stay two lines, each with the identical
// crossing vertex inserted. A line is split only where a vertex is off the DEM, where its
// segment duplicated an earlier line's (a collinear overlap is kept once, in the earlier line)
// and where it passes a vertex twice (after crossing itself).
// Deterministic: the same input gives bit-identical output. Output lines keep the order of the
// input lines (a split line becomes consecutive pieces). Steps and policies: rivercleaning.cpp.
RiverLines cleanRivers(const RiverLines& in, const DemGrid& dem, const RiverCleaningOptions& opt,
                       RiverCleaningStats& stats);

// One-paragraph human summary of the stats (for the CLI).
std::string describe(const RiverCleaningStats& stats);

}  // namespace unilod
