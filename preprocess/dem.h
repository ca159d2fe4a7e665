// DEM ingestion (DESIGN.md "Coordinates", "Point set"): any single-band raster GDAL reads, brought
// into a planar metric working CRS so that every later stage computes in metres. A geographic DEM
// is warped to the UTM zone of its centre (or to a CRS the user names); a projected DEM is kept.
#pragma once

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <functional>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace unilod {

// Memory backed by a temporary file in `dir` (unlinked at once, so nothing is left behind even
// if the process is killed; its whole size reserved on disk first): the kernel writes its pages
// to that file instead of keeping them in memory. Throws std::runtime_error naming `dir` and
// the reason (no space, not writable). unmapTemporaryFile unmaps it.
void* mapTemporaryFile(const std::string& dir, std::size_t bytes);
void unmapTemporaryFile(void* p, std::size_t bytes);
// Free bytes for an unprivileged user on the file system of `dir` (-1: unknown).
double freeDiskBytes(const std::string& dir);

// The allocator of a raster's cells: the heap, or (given a directory) a temporary file there, so
// that a raster larger than the memory can be read at --stride > 1, its lattice alone kept in
// memory (DemLoadOptions::spillDir, README "Large DEMs"). Copies of a container go to the heap;
// moves and swaps take the file along.
template <class T>
struct CellAllocator {
    using value_type = T;
    using propagate_on_container_move_assignment = std::true_type;
    using propagate_on_container_copy_assignment = std::true_type;
    using propagate_on_container_swap = std::true_type;
    using is_always_equal = std::false_type;

    std::shared_ptr<const std::string> fileDir;  // null: the heap

    CellAllocator() = default;
    explicit CellAllocator(std::string dir)
        : fileDir(std::make_shared<const std::string>(std::move(dir))) {}
    template <class U>
    CellAllocator(const CellAllocator<U>& o) : fileDir(o.fileDir) {}

    T* allocate(std::size_t n) {
        if (fileDir) return static_cast<T*>(mapTemporaryFile(*fileDir, n * sizeof(T)));
        return std::allocator<T>().allocate(n);
    }
    void deallocate(T* p, std::size_t n) {
        if (fileDir)
            unmapTemporaryFile(p, n * sizeof(T));
        else
            std::allocator<T>().deallocate(p, n);
    }
    // resize() leaves cells uninitialised: whoever reads a raster writes every cell, so no
    // pass over the memory (or the file) comes before the read.
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
    CellAllocator select_on_container_copy_construction() const { return {}; }
    template <class U>
    bool operator==(const CellAllocator<U>& o) const {
        return fileDir == o.fileDir;
    }
};
using CellVector = std::vector<float, CellAllocator<float>>;

// A north-up grid of altitudes in the working CRS.
//
// Nodata: cells equal to the band's nodata value, NaN cells and +-infinite cells are all stored
// as NaN; nothing downstream has to know the file's nodata convention.
struct DemGrid {
    int width = 0, height = 0;
    // Centre of cell (column 0, row 0) — the first row of the file, the northern one for north-up
    // rasters — and the step between cell centres (cellY < 0 for north-up rasters).
    double originX = 0, originY = 0;
    double cellX = 1, cellY = -1;
    // Row-major, NaN = nodata: width * height cells, or after keepLattice(s) only the cells of
    // the stride's lattice (columns and rows 0, s, 2s, ...), heldWidth() * heldHeight() of them.
    CellVector z;
    int heldStride = 1;    // 1: z holds every cell; s > 1: only the lattice (keepLattice)
    std::string wkt;       // working CRS as WKT; empty when the source had no CRS
    // What loadDem changed to reach metres, for the user (empty: nothing): a projected CRS in
    // feet reprojected, elevations scaled (the band's scale / offset) or converted from feet.
    std::vector<std::string> conversions;

    double centreX(int col) const { return originX + col * cellX; }
    double centreY(int row) const { return originY + row * cellY; }
    int heldWidth() const { return (width - 1) / heldStride + 1; }
    int heldHeight() const { return (height - 1) / heldStride + 1; }
    // The place of cell (col, row) in z: any cell while every cell is held, else a cell of the
    // lattice (col and row multiples of heldStride).
    std::size_t index(int col, int row) const {
        if (heldStride == 1)
            return static_cast<std::size_t>(row) * static_cast<std::size_t>(width) +
                   static_cast<std::size_t>(col);
        assert(col % heldStride == 0 && row % heldStride == 0);
        return static_cast<std::size_t>(row / heldStride) * static_cast<std::size_t>(heldWidth()) +
               static_cast<std::size_t>(col / heldStride);
    }
    float at(int col, int row) const { return z[index(col, row)]; }

    // Bilinear interpolation between the four surrounding cell centres. NaN when (x, y) lies
    // outside the hull of the cell centres or when a cell with non-zero weight is nodata (a point
    // exactly on a row or column of centres only uses that row or column). Needs every cell
    // (before keepLattice).
    double sample(double x, double y) const;

    // Frees every cell but those of the `stride` lattice (a build at --stride > 1 once its river
    // heights are sampled: README "Large DEMs"); at() and index() then take lattice cells only.
    // The lattice is held on the heap, also when the cells were in a temporary file.
    void keepLattice(int stride);
    // Whether the cells are held in a temporary file (DemLoadOptions::spillDir).
    bool cellsOnDisk() const { return z.get_allocator().fileDir != nullptr; }
};

struct DemLoadOptions {
    int band = 0;           // 1-based band; 0 = "the only band" (multi-band rasters need one)
    std::string targetSrs;  // any SRS GDAL understands (EPSG:32616, WKT, PROJ); empty = automatic
    std::string assumeSrs;  // the CRS of a raster that declares none (--s-srs); ignored otherwise
    // Accepted-but-odd input (an unknown elevation unit, a working CRS that distorts distances).
    std::function<void(const std::string&)> warn;
    // The memory the raster's copies may take (bytes; 0: no check) and what bound that is ("the
    // available memory", "--memory-limit"): loadDem refuses, before it reads a cell, a raster
    // whose grid in memory (4 bytes a cell, a reprojected one's as GDAL's warp makes it:
    // demReadBytes) would exceed it, instead of being killed for lack of memory half-way (a
    // 70 000 x 70 000 raster on a 23 GB machine).
    // `memorySkippable`: the command has --no-memory-check (the error says so).
    double memoryBytes = 0;
    std::string memoryWhat;
    bool memorySkippable = true;
    // What a cell of the grid costs the caller, at least: 4 bytes (demReadBytes), `build` its
    // estimate's bytes per raster cell (the grid and the river clearance mask, held until the
    // blocks are cut; at --stride > 1 only the lattice after that), so that a raster its
    // build cannot hold is refused before it is read, not minutes later by the build's estimate.
    double bytesPerCell = 4;
    double baseBytes = 0;  // what the caller holds besides (build: kBuildBaseBytes)
    int threads = 0;  // threads of the reprojection (GDAL's warp kernel); 0: all cores
    // A raster whose cells exceed memoryBytes may be held in a temporary file in `spillDir`
    // (empty: never) when the caller keeps only the `spillStride` lattice once it has read
    // what it needs of every cell (build --stride > 1): then the memory holds bytesPerCell - 4
    // bytes a cell while reading and bytesPerCell a lattice cell, and the disk 4 bytes a cell.
    // `spillAlways`: whenever spillDir is given (tests).
    std::string spillDir;
    int spillStride = 1;
    bool spillAlways = false;
};

// The memory loadDem's grid of a raster takes: 4 bytes a cell of the grid it reads (`cells`; a
// reprojected raster is warped straight into it, GDAL's block cache emptied as it reads).
inline double demReadBytes(double cells, double bytesPerCell = 4) {
    return cells * std::max(4.0, bytesPerCell);
}

// Metres per unit of an elevation or length unit name as GDAL reports it (band unit type, CRS
// unit): metre, foot, US survey foot and their usual spellings, cm, mm, km. 0 when unknown; 1 for
// an empty name.
double metresPerUnit(const std::string& unit);

// Loads `path` into `dem`, in metres (DESIGN.md "Coordinates"). Working CRS: `targetSrs` when
// given (it must be projected in metres; the raster is warped to it unless it is already in it);
// otherwise a geographic raster, or a projected one whose unit is not the metre (State Plane in
// feet), is warped (bilinear) to the UTM zone of its centre (EPSG:326xx north, 327xx south) and a
// projected raster in metres, or one without a CRS, keeps its grid (a rotated or sheared grid is
// resampled north-up). Elevations: the band's scale
// and offset applied (scaled integers), then converted to metres from the band's unit (or, when
// it has none, from the unit of a vertical CRS it declares). Returns false with `error` naming the
// file and the problem (missing file, not a raster, no bands, multi-band without a band, band out
// of range, singular geotransform, all cells nodata, coordinates without a CRS that look like
// degrees (relief over 100x the extent), GDAL failures).
bool loadDem(const std::string& path, const DemLoadOptions& options, DemGrid& dem,
             std::string& error);

// A short display name of a CRS given as WKT: "name (AUTH:CODE)", "none" for an empty WKT.
std::string crsDisplayName(const std::string& wkt);

// EPSG code of the WGS 84 UTM zone containing (lon, lat) in degrees; beyond UTM's latitudes
// (84 N, 80 S) the polar stereographic UPS North (32661) or South (32761).
int utmEpsgFor(double lon, double lat);

}  // namespace unilod
