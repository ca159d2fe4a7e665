// River network ingestion (DESIGN.md "Coordinates"): the line features of any OGR vector source,
// reprojected to the DEM's working CRS. Cleaning (snapping, splitting at crossings, minimum length)
// is a later stage; this only reads geometry.
#pragma once

#include <functional>

#include <string>
#include <vector>

namespace unilod {

struct XY {
    double x = 0, y = 0;
    bool operator==(const XY&) const = default;
};
using RiverLine = std::vector<XY>;
using RiverLines = std::vector<RiverLine>;

struct RiverLoadOptions {
    std::string layer;      // layer name; empty = the first layer with line geometry
    std::string where;      // OGR SQL attribute filter; empty = all features
    std::string assumeSrs;  // CRS of the data when the layer declares none (e.g. EPSG:4326)
    // Accepted-but-odd input (z coordinates that are ignored); may be empty.
    std::function<void(const std::string&)> warn;
};

// Reads every LineString / MultiLineString, and every curve (CircularString, CompoundCurve,
// MultiCurve: OGR's linear approximation), also inside geometry collections (each part one line;
// z and m are ignored; features without a line are skipped, counted in one warning) of the
// chosen layer in feature order and transforms it to
// `workingWkt` (traditional GIS axis order: x = easting / longitude). An empty `workingWkt` means
// the DEM has no CRS: coordinates are taken as they are. Returns false with `error` naming the
// file and the problem: missing or unreadable file, no such layer, no line layer (a layer of points
// or polygons only), bad where clause, a layer without CRS while the DEM has one (and no
// assumeSrs), transformation failure. A source without any feature (an empty FeatureCollection,
// an empty line layer) is an empty network: true with `out` empty.
bool loadRivers(const std::string& path, const RiverLoadOptions& options,
                const std::string& workingWkt, RiverLines& out, std::string& error);

}  // namespace unilod
