// `unilod export --3dtiles DIR`: the whole model as a 3D Tiles 1.1 tileset (issue 20, item 1),
// the standard way to put a multi-resolution terrain on a globe (CesiumJS, QGIS 3D, deck.gl).
//
// Tile tree. Every directory entry of the .ulod file (a leaf block or a node of the block
// hierarchy, issue 18) with stored levels L_0 (finest) .. L_k (coarsest) becomes a CHAIN of tiles:
// a kept level's tile has the next finer kept level's tile as its only child, down to the finest,
// whose children are the chains of the entry's child entries (none for a leaf block). Kept: the
// levels a client can draw at rest, thinned so that going up a chain a tile has at most
// TilesetOptions::tileRatio times the triangles of the one below (tiles3d.cpp planTiles). Levels of
// one node are child tiles of each other (not separate content of one tile) because 3D Tiles
// selects content by exactly the rule the engine uses (engine/lod/cut.h): a tile is drawn when its
// geometric error, projected to the screen, is within the viewer's maximum screen-space error, and
// replaced by its children otherwise (`refine: REPLACE`); a chain lets the client stop at any
// stored level. The price is depth and size: a client that loads ancestors first loads every tile
// of a chain, and every tile holds its level's whole mesh (about twice the finest level's triangles
// in all of a chain's tiles at the default ratio 0.5).
// - geometricError of a tile = its level's stored error (the file's metric or --metric: `max`
//   bounds the vertical error of the level against the full-resolution DEM), strictly falling
//   going down: levels a client would never draw at rest (a tile with its parent's error is
//   refined along with it) are left out (tiles3d.cpp planTiles).
//   Cesium's screen-space error of a tile is geometricError · H / (2 · S · tan(fov / 2)), the
//   paper's Eq. 11 solved for P: Cesium's maximumScreenSpaceError is our P.
// - boundingVolume: an axis-aligned `box` in the tileset frame (east, north, up metres around the
//   model centre), the union of the tile's own vertices and its children's boxes.
// - content: `tiles/<entry>-<level>.glb`, one glTF 2.0 binary per tile (gltfmodel.h: terrain
//   triangles, river edges as LINES with an unlit blue material), positions relative to the
//   tile's centre (glTF node translation in double). --compress: every vertex on one grid,
//   16-bit positions where a tile fits (the leaves), meshopt-compressed buffers (gltfmodel.h;
//   CesiumJS decodes both), a coordinate within half a step of the exact one (the step: the
//   leaves' largest half-side / 32 000 rounded up to a power of two, 6 cm on the demo's 64-cell
//   leaves); tileset extras "compression", "quantization_step_m" and "max_quantization_error_m"
//   say so. The geometricErrors stay the levels' stored errors.
// - Georeference: the root tile's `transform` is the east-north-up frame at the model centre
//   (longitude/latitude of the extent's centre, height 0 on the WGS84 ellipsoid) to Earth-centred
//   Earth-fixed (ECEF) coordinates. Every vertex goes file CRS -> WGS84 longitude/latitude through
//   GDAL/PROJ (datum shifts included), then to ECEF with its z as ellipsoidal height, then into
//   that frame: exact, so Earth curvature and the projection's scale and convergence are honoured
//   over any extent. Heights are taken as ellipsoidal unless --vertical-crs names the vertical
//   CRS of the file's z (e.g. EPSG:5773, EGM96 height: SRTM-based DEMs): then PROJ converts them
//   to ellipsoidal heights with its geoid grid, and a missing grid is an error, not a silent
//   no-op (without it an orthometric DEM sits the local geoid undulation, -107 m to +85 m, off).
// - asset: version "1.1", generator, tilesetVersion; tileset `extras`: source path, CRS WKT,
//   metric, centre longitude/latitude and the layout above in words.
// Entries are exported on worker threads (TilesetOptions::threads), the same bytes for any count.
// The folder appears whole or not at all (format::AtomicFile::openFolder: a missing or empty
// folder; the CLI moves an old one aside for --overwrite).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace unilod::exporter {

inline constexpr double kDefaultTileRatio = 0.5;

struct TilesetOptions {
    std::string path;          // the .ulod file
    std::string outDir;        // the tileset folder to create
    std::string sourceSrs;     // --s-srs: CRS of the file's coordinates (default: the file's own)
    std::string verticalSrs;   // --vertical-crs: the vertical CRS of the file's z (default: none,
                               // z is a WGS84 ellipsoidal height)
    std::uint32_t metric = 0;  // format::kMetricMax / kMetricPaper; 0 = the file's default
    // A stored level becomes a tile where it has at most this share of the triangles of the tile
    // below it in its chain (tiles3d.cpp planTiles); 1: every level a client draws at rest.
    double tileRatio = kDefaultTileRatio;
    bool compress = false;  // --compress: quantized, meshopt-compressed content (gltfmodel.h)
    std::size_t threads = 0;  // --threads: entries exported at once (0: every core, at most 16)
    std::function<void(std::size_t, std::size_t)> progress;  // entries done, total
};

struct TilesetSummary {
    std::size_t tiles = 0, entries = 0;
    std::size_t depth = 0;  // tiles on the longest root-to-leaf path
    std::uint64_t vertices = 0, triangles = 0, riverEdges = 0;  // over all tiles
    std::uint64_t bytes = 0;                                    // tileset.json + content
    double rootError = 0;                                       // the root tile's geometricError
    double longitude = 0, latitude = 0;                         // of the frame's origin, degrees
    double maxQuantizationError = 0;  // --compress: the largest move of a vertex (metres)
    std::size_t floatTiles = 0;       // --compress: tiles too large for 16-bit positions
};

// The asset.generator of every tileset.json exportTileset writes: its mark on the folder.
inline const std::string kTilesetGenerator = "unilod export --3dtiles";

// What `export --3dtiles --overwrite` may replace (cli/outputopts.h ReplacedFolder): for an
// entry of a folder, "" when an earlier export wrote it, else the name to show. A tileset folder
// holds tileset.json (a regular file whose asset.generator is kTilesetGenerator: another tool's
// tileset is not replaced) and tiles/ (a folder, not a link, of regular .glb files only: its
// first other entry is named, as "tiles/NAME").
std::string tilesetForeignPart(const std::filesystem::directory_entry& entry);

// False with a message naming the file on a data error (no CRS and no --s-srs, a CRS GDAL cannot
// transform to WGS84, an unreadable block); no output folder is left then.
bool exportTileset(const TilesetOptions& options, TilesetSummary& summary, std::string& error);

}  // namespace unilod::exporter
