// DEM ingestion: GDAL open, band choice, reprojection of geographic rasters to UTM (GDALWarp
// straight into the grid), nodata normalisation to NaN, and bilinear sampling between cell centres
// (DESIGN.md "Coordinates": everything downstream works in metres in one planar CRS).
#include "dem.h"

#include <cpl_conv.h>
#include <cpl_string.h>
#include <gdal_alg.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>

#include "atomicfile.h"
#include "gdal_errors.h"
#include "srs.h"

// Bilinear samples must be bit-identical on every platform (the synthetic data's river altitudes
// are compared exactly): no fused multiply-add contraction. GCC does not contract in ISO mode.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

namespace unilod {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// A working CRS whose scale at the DEM's centre is further than this from 1 gets a warning.
constexpr double kGridScaleWarning = 0.02;
// The UTM zone `build` chooses is refused where its scale is further than this from 1.
constexpr double kGridScaleRefusal = 0.10;

// GDAL's C option lists want a NULL-terminated char* array.
struct ArgList {
    std::vector<std::string> args;
    std::vector<char*> pointers() {
        std::vector<char*> p;
        for (std::string& a : args)
            p.push_back(a.data());
        p.push_back(nullptr);
        return p;
    }
};

// A dataset holding only band `band` of `src` (a virtual VRT copy, no pixels are read), so that
// GDALWarp of GDAL 3.6 (which has no -srcband) warps just that band.
// Band `band` of `src` alone (a VRT), with the dataset's mask: its per-dataset mask as GDAL
// copies it, or band `alphaBand` (not 0) as the mask, so that the warper leaves those cells
// nodata.
GDALDatasetUniquePtr extractBand(GDALDataset* src, int band, int alphaBand) {
    std::vector<std::string> args{"-of", "VRT", "-b", std::to_string(band)};
    if (alphaBand > 0) args.insert(args.end(), {"-mask", std::to_string(alphaBand)});
    ArgList list{args};
    std::vector<char*> argv = list.pointers();
    GDALTranslateOptions* opts = GDALTranslateOptionsNew(argv.data(), nullptr);
    if (opts == nullptr) return nullptr;
    GDALDatasetH out = GDALTranslate("", GDALDataset::ToHandle(src), opts, nullptr);
    GDALTranslateOptionsFree(opts);
    return GDALDatasetUniquePtr(GDALDataset::FromHandle(out));
}

// The gdalwarp arguments of the reprojection: bilinear, Float32 with NaN as nodata, so that cells
// outside the source footprint (the skewed corners of a reprojected grid) are nodata, not 0.
// `srcWkt`: the source CRS when the raster declares none (--s-srs); empty: the raster's own.
std::vector<std::string> warpArgs(const std::string& srcWkt) {
    std::vector<std::string> args{"-r", "bilinear", "-ot", "Float32", "-dstnodata", "nan"};
    if (!srcWkt.empty()) args.insert(args.end(), {"-s_srs", srcWkt});
    return args;
}

GDALDatasetH runWarp(GDALDatasetH dst, GDALDataset* src, std::vector<std::string> args) {
    ArgList list{std::move(args)};
    std::vector<char*> argv = list.pointers();
    GDALWarpAppOptions* opts = GDALWarpAppOptionsNew(argv.data(), nullptr);
    if (opts == nullptr) return nullptr;
    GDALDatasetH srcHandle = GDALDataset::ToHandle(src);
    int usageError = 0;
    GDALDatasetH out =
        GDALWarp(dst != nullptr ? nullptr : "", dst, 1, &srcHandle, opts, &usageError);
    GDALWarpAppOptionsFree(opts);
    return out;
}

// The grid the reprojection of the single-band `src` to `dstWkt` makes (no target: a raster
// without a CRS resampled north-up in its own coordinates): gdalwarp's own output, as a virtual
// (VRT) dataset whose size, geotransform and CRS are read before a cell is warped.
GDALDatasetUniquePtr planWarp(GDALDataset* src, const std::string& dstWkt,
                              const std::string& srcWkt) {
    std::vector<std::string> args = warpArgs(srcWkt);
    args.insert(args.end(), {"-of", "VRT"});
    if (!dstWkt.empty()) args.insert(args.end(), {"-t_srs", dstWkt});
    return GDALDatasetUniquePtr(GDALDataset::FromHandle(runWarp(nullptr, src, args)));
}

// Warps `src` onto the grid of `plan` straight into `cells` (plan's width x height Float32
// values, row by row, NaN before): a MEM dataset over the caller's buffer, so that the raster is
// held once (until 2026-12-02 GDAL's warped copy and then the grid: 8 bytes a cell, and GDAL's
// block cache of the source on top), on `threads` threads (0: all cores). The cells are the
// ones gdalwarp's own MEM output had (same options, same chunks; a thread count splits a chunk's
// rows only).
bool warpInto(GDALDataset* src, GDALDataset* plan, const std::string& srcWkt, int threads,
              float* cells) {
    GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
    if (mem == nullptr) return false;
    const int w = plan->GetRasterXSize(), h = plan->GetRasterYSize();
    GDALDatasetUniquePtr dst(mem->Create("", w, h, 0, GDT_Float32, nullptr));
    if (!dst) return false;
    char pointer[64] = {};
    pointer[CPLPrintPointer(pointer, cells, sizeof pointer - 1)] = '\0';
    const std::string at = std::string("DATAPOINTER=") + pointer;
    CPLStringList bandOptions;
    bandOptions.AddString(at.c_str());
    if (dst->AddBand(GDT_Float32, bandOptions.List()) != CE_None) return false;
    double gt[6];
    if (plan->GetGeoTransform(gt) != CE_None || dst->SetGeoTransform(gt) != CE_None) return false;
    if (const OGRSpatialReference* srs = plan->GetSpatialRef()) dst->SetSpatialRef(srs);
    dst->GetRasterBand(1)->SetNoDataValue(std::numeric_limits<double>::quiet_NaN());
    std::vector<std::string> args = warpArgs(srcWkt);
    // GDAL's block cache (default 5 % of the memory) kept the source's blocks as the warp read
    // them: the whole source raster again on top of the grid (a 12 000^2 Float32 one: 1.25 GB
    // read where the grid is 0.61). Capped to a warp chunk's worth while warping (its -wm);
    // blocks shared by neighbouring chunks may be read twice.
    struct CacheCap {
        GIntBig before = GDALGetCacheMax64();
        explicit CacheCap(GIntBig cap) {
            if (before > cap) GDALSetCacheMax64(cap);
        }
        ~CacheCap() { GDALSetCacheMax64(before); }
    } cap(GIntBig(64) << 20);
    // As gdalwarp initialises an output it creates; the threads split the warp kernel's rows.
    args.insert(args.end(), {"-wo", "INIT_DEST=NO_DATA", "-wo",
                             "NUM_THREADS=" + (threads > 0 ? std::to_string(threads)
                                                           : std::string("ALL_CPUS"))});
    if (runWarp(GDALDataset::ToHandle(dst.get()), src, args) == nullptr) return false;
    dst->FlushCache(false);
    return true;
}

std::string toWkt(const OGRSpatialReference& srs) {
    char* text = nullptr;
    srs.exportToWkt(&text);
    std::string wkt = text != nullptr ? text : "";
    CPLFree(text);
    return wkt;
}

// Lower case without spaces, '_', '-', '.' and brackets: "US survey foot" -> "ussurveyfoot".
std::string unitKey(const std::string& unit) {
    std::string key;
    for (char ch : unit) {
        if (std::isspace(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-' || ch == '.' ||
            ch == '(' || ch == ')')
            continue;
        key += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    }
    return key;
}

// From `srs` to WGS 84 longitude, latitude (null when PROJ has no transformation).
std::unique_ptr<OGRCoordinateTransformation> toLonLat(const OGRSpatialReference& srs) {
    OGRSpatialReference wgs84;
    wgs84.SetWellKnownGeogCS("WGS84");
    wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    return std::unique_ptr<OGRCoordinateTransformation>(
        OGRCreateCoordinateTransformation(&srs, &wgs84));
}

// The CRS coordinates of grid position (col, row) (0, 0: the upper-left corner of the first
// cell) under GDAL's affine geotransform, rotation terms included.
void gridToCrs(const double gt[6], double col, double row, double& x, double& y) {
    x = gt[0] + col * gt[1] + row * gt[2];
    y = gt[3] + col * gt[4] + row * gt[5];
}

// The centre of the raster (geotransform `gt`, w x h cells) in WGS 84 longitude, latitude.
bool centreLonLat(const OGRSpatialReference& srs, const double gt[6], int w, int h, double& lon,
                  double& lat) {
    const std::unique_ptr<OGRCoordinateTransformation> ct = toLonLat(srs);
    gridToCrs(gt, 0.5 * w, 0.5 * h, lon, lat);
    return ct && ct->Transform(1, &lon, &lat) && std::isfinite(lon) && std::isfinite(lat);
}

// Ground metres per CRS metre at (x, y) of a projected CRS in metres, the worse of the two axis
// directions (1 on a true-scale grid, 1.24 for Web Mercator at 36 degrees): a 1 km step along
// each axis measured on the sphere. 0 when it cannot be computed.
double gridScale(const OGRSpatialReference& srs, double x, double y) {
    const std::unique_ptr<OGRCoordinateTransformation> ct = toLonLat(srs);
    if (!ct) return 0;
    constexpr double kStep = 1000.0, kEarthRadius = 6371008.8, kRad = 3.14159265358979323846 / 180;
    double xs[3] = {x, x + kStep, x}, ys[3] = {y, y, y + kStep};
    if (!ct->Transform(3, xs, ys)) return 0;
    auto ground = [&](int i) {  // haversine from point 0 to point i
        const double dLat = (ys[i] - ys[0]) * kRad, dLon = (xs[i] - xs[0]) * kRad;
        const double a = std::sin(dLat / 2) * std::sin(dLat / 2) +
                         std::cos(ys[0] * kRad) * std::cos(ys[i] * kRad) * std::sin(dLon / 2) *
                             std::sin(dLon / 2);
        return 2 * kEarthRadius * std::asin(std::min(1.0, std::sqrt(a)));
    };
    const double kx = kStep / ground(1), ky = kStep / ground(2);
    if (!std::isfinite(kx) || !std::isfinite(ky)) return 0;
    return std::fabs(kx - 1) > std::fabs(ky - 1) ? kx : ky;
}

// The raster's four corners in its CRS (longitude, latitude for a geographic one).
std::array<std::array<double, 2>, 4> rasterCorners(const double gt[6], int w, int h) {
    std::array<std::array<double, 2>, 4> corners{};
    for (int corner = 0; corner < 4; ++corner)
        gridToCrs(gt, corner % 2 == 0 ? 0 : w, corner < 2 ? 0 : h, corners[corner][0],
                  corners[corner][1]);
    return corners;
}

// The scale of `target` (gridScale) furthest from 1 over nine points of the raster's extent (its
// corners, edge middles and centre, given in `src`); 0 when one of them does not transform (off
// the target's area of use) or has no scale.
double extentGridScale(const OGRSpatialReference& src, const OGRSpatialReference& target,
                       const double gt[6], int w, int h) {
    OGRSpatialReference from = src, to = target;
    from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    to.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    const std::unique_ptr<OGRCoordinateTransformation> ct(
        OGRCreateCoordinateTransformation(&from, &to));
    if (!ct) return 0;
    double worst = 1;
    for (int i = 0; i < 9; ++i) {
        double x = 0, y = 0;
        gridToCrs(gt, 0.5 * (i % 3) * w, 0.5 * (i / 3) * h, x, y);
        if (!ct->Transform(1, &x, &y) || !std::isfinite(x) || !std::isfinite(y)) return 0;
        const double k = gridScale(target, x, y);
        if (!(k > 0)) return 0;
        if (std::fabs(k - 1) > std::fabs(worst - 1)) worst = k;
    }
    return worst;
}

}  // namespace

double metresPerUnit(const std::string& unit) {
    const std::string key = unitKey(unit);
    if (key.empty()) return 1;
    for (const char* m : {"m", "metre", "meter", "metres", "meters"})
        if (key == m) return 1;
    for (const char* f : {"ft", "foot", "feet", "internationalfoot", "footinternational", "ftintl",
                          "intlfoot", "intft"})
        if (key == f) return 0.3048;
    for (const char* f : {"ussurveyfoot", "ussurveyfeet", "usft", "ftus", "surveyfoot", "footus",
                          "usfoot", "usfeet", "footussurvey"})
        if (key == f) return 1200.0 / 3937.0;
    for (const char* c : {"cm", "centimetre", "centimeter", "centimetres", "centimeters"})
        if (key == c) return 0.01;
    for (const char* c : {"mm", "millimetre", "millimeter", "millimetres", "millimeters"})
        if (key == c) return 0.001;
    for (const char* c : {"dm", "decimetre", "decimeter", "decimetres", "decimeters"})
        if (key == c) return 0.1;
    for (const char* c : {"km", "kilometre", "kilometer", "kilometres", "kilometers"})
        if (key == c) return 1000;
    return 0;
}

int utmEpsgFor(double lon, double lat) {
    // Beyond UTM's latitudes (84 N, 80 S) the polar stereographic UPS grids.
    if (lat > 84) return 32661;
    if (lat < -80) return 32761;
    // Normalise 0..360 longitudes; zones are 6 degrees wide starting at -180.
    double l = std::fmod(lon + 180.0, 360.0);
    if (l < 0) l += 360.0;
    int zone = static_cast<int>(std::floor(l / 6.0)) + 1;
    zone = zone < 1 ? 1 : (zone > 60 ? 60 : zone);
    return (lat >= 0 ? 32600 : 32700) + zone;
}

void* mapTemporaryFile(const std::string& dir, std::size_t bytes) {
    const std::string where = "a temporary file in '" + dir + "'";
    std::string name = (dir.empty() ? std::string(".") : dir) + "/.unilod-cells-XXXXXX";
    const int fd = mkstemp(name.data());
    if (fd < 0) throw std::runtime_error("cannot create " + where + ": " + std::strerror(errno));
    unlink(name.c_str());  // gone with the last reference: the mapping
    // Reserved first, so that a full disk is an error here and not a SIGBUS on a later write.
    const int reserved = bytes > 0 ? posix_fallocate(fd, 0, off_t(bytes)) : 0;
    if (reserved != 0) {
        close(fd);
        throw std::runtime_error("cannot reserve " + std::to_string(bytes) + " bytes for " + where +
                                 ": " + std::strerror(reserved));
    }
    void* p =
        mmap(nullptr, std::max<std::size_t>(bytes, 1), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    const int mapError = errno;
    close(fd);
    if (p == MAP_FAILED)
        throw std::runtime_error("cannot map " + where + ": " + std::strerror(mapError));
    return p;
}

void unmapTemporaryFile(void* p, std::size_t bytes) {
    if (p != nullptr) munmap(p, std::max<std::size_t>(bytes, 1));
}

double freeDiskBytes(const std::string& dir) {
    struct statvfs fs {};
    if (statvfs(dir.empty() ? "." : dir.c_str(), &fs) != 0) return -1;
    return double(fs.f_bavail) * double(fs.f_frsize);
}

void DemGrid::keepLattice(int stride) {
    if (stride <= 1 || heldStride != 1 || z.empty()) return;
    heldStride = stride;
    const int w = heldWidth(), h = heldHeight();
    CellVector lattice(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            lattice[static_cast<std::size_t>(j) * w + i] =
                z[static_cast<std::size_t>(j) * stride * width +
                  static_cast<std::size_t>(i) * stride];
    z = std::move(lattice);  // on the heap; a temporary file is unmapped (and so deleted)
}

double DemGrid::sample(double x, double y) const {
    constexpr double kNaNd = std::numeric_limits<double>::quiet_NaN();
    assert(heldStride == 1 && "DemGrid::sample needs every cell (before keepLattice)");
    if (width <= 0 || height <= 0) return kNaNd;
    // Coordinates computed as origin + i * cell come back as i +- 1 ulp: snap them, so that a
    // point on a row or column of centres does not pick up a zero-weight nodata neighbour.
    const auto snap = [](double f) {
        const double r = std::round(f);
        return std::abs(f - r) < 1e-9 ? r : f;
    };
    const double fx = snap((x - originX) / cellX);
    const double fy = snap((y - originY) / cellY);
    // The negated comparisons also reject NaN coordinates.
    if (!(fx >= 0 && fx <= width - 1 && fy >= 0 && fy <= height - 1)) return kNaNd;
    const int c0 = std::min(static_cast<int>(fx), width - 1);
    const int r0 = std::min(static_cast<int>(fy), height - 1);
    const double tx = fx - c0, ty = fy - r0;
    const int c1 = tx > 0 ? c0 + 1 : c0;  // tx > 0 implies c0 < width - 1
    const int r1 = ty > 0 ? r0 + 1 : r0;
    const double z00 = at(c0, r0), z10 = at(c1, r0), z01 = at(c0, r1), z11 = at(c1, r1);
    // A NaN corner with weight > 0 propagates; c1 == c0 (r1 == r0) makes the zero-weight corner a
    // copy of a used one, so only cells that really contribute can poison the result.
    const double top = tx > 0 ? z00 + (z10 - z00) * tx : z00;
    const double bottom = tx > 0 ? z01 + (z11 - z01) * tx : z01;
    return ty > 0 ? top + (bottom - top) * ty : top;
}

namespace {

// A DEM without a CRS is read in metres. Geographic coordinates read that way (an ASCII grid
// without its .prj) make a terrain a fraction of a metre wide with hundreds of metres of relief,
// and every metric tolerance of the build (river cleaning, the 1 m clearance) spans the whole
// DEM: refused when the relief exceeds 100x the horizontal extent and the coordinates are valid
// longitudes and latitudes; a warning when only the small cells and the coordinates suggest it.
bool checkUndeclaredUnits(const std::string& path, const DemGrid& dem,
                          const DemLoadOptions& options, std::string& error) {
    const double x0 = dem.originX - 0.5 * dem.cellX, y0 = dem.originY - 0.5 * dem.cellY;
    const double x1 = x0 + dem.width * dem.cellX, y1 = y0 + dem.height * dem.cellY;
    const bool lonLat = std::min(x0, x1) >= -180 && std::max(x0, x1) <= 360 &&
                        std::min(y0, y1) >= -90 && std::max(y0, y1) <= 90;
    if (!lonLat) return true;
    float zMin = INFINITY, zMax = -INFINITY;
    for (const float z : dem.z) {
        if (std::isnan(z)) continue;
        zMin = std::min(zMin, z);
        zMax = std::max(zMax, z);
    }
    const double extent = std::max(std::fabs(x1 - x0), std::fabs(y1 - y0));
    const double relief = static_cast<double>(zMax) - zMin;
    char text[400];
    if (relief > 100 * extent) {
        std::snprintf(text, sizeof text,
                      "': it declares no CRS, so its coordinates are read as metres, but the grid "
                      "spans %.6g x %.6g of them with %.6g m of relief: they look like degrees; "
                      "give its CRS with --s-srs (e.g. EPSG:4326)",
                      std::fabs(x1 - x0), std::fabs(y1 - y0), relief);
        error = "DEM '" + path + text;
        return false;
    }
    if (options.warn && std::max(std::fabs(dem.cellX), std::fabs(dem.cellY)) <= 0.01) {
        std::snprintf(text, sizeof text,
                      "': it declares no CRS, so its coordinates are read as metres (cells of "
                      "%.6g x %.6g m); if they are degrees, give its CRS with --s-srs (e.g. "
                      "EPSG:4326)",
                      std::fabs(dem.cellX), std::fabs(dem.cellY));
        options.warn("DEM '" + path + text);
    }
    return true;
}

}  // namespace

bool loadDem(const std::string& path, const DemLoadOptions& options, DemGrid& dem,
             std::string& error) {
    QuietGdalErrors quiet;
    dem = DemGrid{};

    // A path, or a subdataset of a container file (checked as that file).
    std::string file = path;
    VSIStatBufL st;
    if (VSIStatL(path.c_str(), &st) != 0) {
        file = format::fileInside(path);
        if (file.empty()) {
            error = "DEM '" + path + "': no such file";
            return false;
        }
    }
    // A FIFO or a device would block GDAL's open; folders are GDAL's to judge (AIG grids).
    if (std::string why; !format::checkInputFile(file, true, why)) {
        error = "DEM '" + path + "': " + why;
        return false;
    }
    GDALDatasetUniquePtr ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER));
    if (!ds) {
        error = "DEM '" + path + "': not a raster GDAL can read" + gdalErrorSuffix() +
                archiveHint(path);
        return false;
    }
    const int bands = ds->GetRasterCount();
    if (bands == 0) {
        // A container (netCDF, HDF5, GeoPackage with several tables): name what it holds.
        std::vector<std::string> names;
        for (int i = 1;; ++i) {
            const char* name = ds->GetMetadataItem(
                ("SUBDATASET_" + std::to_string(i) + "_NAME").c_str(), "SUBDATASETS");
            if (name == nullptr) break;
            names.emplace_back(name);
        }
        error = "DEM '" + path + "': the file has no raster bands";
        if (!names.empty()) {
            error = "DEM '" + path + "': the file holds " + std::to_string(names.size()) +
                    " rasters (subdatasets); give one as the DEM: " + quotedNames(names);
        }
        return false;
    }
    int band = options.band;
    if (band < 0 || band > bands) {
        error = "DEM '" + path + "': --band " + std::to_string(band) +
                " out of range (the file has " + std::to_string(bands) + " band" +
                (bands == 1 ? "" : "s") + ")";
        return false;
    }
    // An alpha band is the mask of the others (gdalwarp -dstalpha): not an altitude band, and
    // with one other band that one is the altitude.
    int alphaBand = 0, dataBands = 0, onlyDataBand = 0;
    for (int b = 1; b <= bands; ++b) {
        if (ds->GetRasterBand(b)->GetColorInterpretation() == GCI_AlphaBand) {
            if (alphaBand == 0) alphaBand = b;
        } else {
            ++dataBands;
            onlyDataBand = b;
        }
    }
    if (band == 0) {
        if (dataBands != 1) {
            error = "DEM '" + path + "': the file has " + std::to_string(bands) +
                    " bands; choose the altitude band (--band N)";
            return false;
        }
        band = onlyDataBand;
    }

    double gt[6] = {0, 1, 0, 0, 0, 1};
    if (ds->GetGeoTransform(gt) != CE_None) {
        // Without a geotransform GDAL leaves the identity: pixel coordinates. Ground control
        // points place the raster, but not on a grid this reads: refused with the fix, not
        // built as a model of pixels (a 4.6 km DEM became 155 m wide with 2 km of relief).
        if (ds->GetGCPCount() > 0) {
            error = "DEM '" + path + "': it is georeferenced by " +
                    std::to_string(ds->GetGCPCount()) +
                    " ground control points, not a grid (geotransform); resample it onto one "
                    "first, e.g. gdalwarp -r bilinear -t_srs EPSG:<code> '" +
                    path + "' gridded.tif";
            return false;
        }
        if (options.warn)
            options.warn("DEM '" + path +
                         "': it has no georeferencing (no geotransform): x and y are its pixel "
                         "indices, cells 1 m wide; give it one with gdal_edit.py -a_ullr and "
                         "-a_srs for a true model");
    }
    // A rotated or sheared grid (rotation terms in the geotransform) is resampled to a north-up
    // grid like a reprojected one; a singular geotransform places no cell anywhere.
    const bool rotated = gt[2] != 0 || gt[4] != 0;
    if (!std::isfinite(gt[0]) || !std::isfinite(gt[1]) || !std::isfinite(gt[2]) ||
        !std::isfinite(gt[3]) || !std::isfinite(gt[4]) || !std::isfinite(gt[5]) ||
        gt[1] * gt[5] - gt[2] * gt[4] == 0) {
        error = "DEM '" + path + "': its geotransform is degenerate (zero-area cells)";
        return false;
    }

    // Choose the working CRS.
    const OGRSpatialReference* srcSrs = ds->GetSpatialRef();
    // --s-srs: the CRS of a raster that declares none (gdalwarp -s_srs); a declared one wins.
    OGRSpatialReference assumed;
    std::string assumedWkt;
    if (srcSrs == nullptr && !options.assumeSrs.empty()) {
        if (!parseSrs(options.assumeSrs, assumed)) {
            error = "DEM '" + path + "': cannot parse the assumed source CRS '" +
                    options.assumeSrs + "' (--s-srs)";
            return false;
        }
        assumed.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
        srcSrs = &assumed;
        assumedWkt = toWkt(assumed);
    }
    if (srcSrs != nullptr && srcSrs->IsGeographic()) {
        // Degrees: latitudes beyond the poles are a georeferencing mistake (a projected grid
        // labelled as geographic, swapped axes), which would otherwise surface later as "no
        // valid data" or rivers that "cannot be transformed".
        double lat0 = INFINITY, lat1 = -INFINITY, lon0 = INFINITY, lon1 = -INFINITY;
        for (const auto& [lon, lat] :
             rasterCorners(gt, ds->GetRasterXSize(), ds->GetRasterYSize())) {
            lat0 = std::min(lat0, lat);
            lat1 = std::max(lat1, lat);
            lon0 = std::min(lon0, lon);
            lon1 = std::max(lon1, lon);
        }
        const double eps = 1e-9;
        if (std::max(std::fabs(lat0), std::fabs(lat1)) > 90 + eps ||
            std::max(std::fabs(lon0), std::fabs(lon1)) > 540 + eps) {
            char buf[200];
            std::snprintf(buf, sizeof buf,
                          "': a geographic raster (degrees) spanning latitudes %.6g to %.6g and "
                          "longitudes %.6g to %.6g, beyond the poles: its georeferencing is wrong",
                          lat0, lat1, lon0, lon1);
            error = "DEM '" + path + buf +
                    " (a projected grid labelled as geographic? give its CRS with --s-srs)";
            return false;
        }
    }
    OGRSpatialReference target;
    bool warp = false;
    if (!options.targetSrs.empty()) {
        if (!parseSrs(options.targetSrs, target)) {
            error = "DEM '" + path + "': cannot parse the target CRS '" + options.targetSrs +
                    "' (--t-srs)";
            return false;
        }
        if (!target.IsProjected()) {
            error = "DEM '" + path + "': the target CRS '" + options.targetSrs +
                    "' is not a projected (metric) CRS (--t-srs)";
            return false;
        }
        const char* unit = nullptr;
        if (std::fabs(target.GetLinearUnits(&unit) - 1.0) > 1e-9) {
            error = "DEM '" + path + "': the target CRS '" + options.targetSrs + "' is in " +
                    (unit != nullptr ? unit : "an unknown unit") +
                    ", not metres (--t-srs: choose a projected CRS in metres, e.g. a UTM zone)";
            return false;
        }
        if (srcSrs == nullptr) {
            error = "DEM '" + path + "': the raster has no CRS, cannot reproject it to '" +
                    options.targetSrs + "' (give its CRS with --s-srs, or leave out --t-srs)";
            return false;
        }
        warp = !srcSrs->IsSame(&target);
    } else if (srcSrs != nullptr && srcSrs->IsGeographic()) {
        // GDAL's geotransform of a geographic raster is in longitude, latitude order whatever the
        // CRS's official axis order is; the zone only needs the centre to a few kilometres, so
        // the source datum does not matter.
        double lon = 0, lat = 0;
        gridToCrs(gt, 0.5 * ds->GetRasterXSize(), 0.5 * ds->GetRasterYSize(), lon, lat);
        if (target.importFromEPSG(utmEpsgFor(lon, lat)) != OGRERR_NONE) {
            error = "DEM '" + path + "': cannot create the UTM CRS" + gdalErrorSuffix();
            return false;
        }
        warp = true;
    } else if (const char* unit = nullptr;
               srcSrs != nullptr && srcSrs->IsProjected() &&
               std::fabs(srcSrs->GetLinearUnits(&unit) - 1.0) > 1e-9) {
        // A projected CRS in feet (State Plane, some national grids): to metres through the UTM
        // zone of the centre, as a geographic raster (DESIGN.md "Coordinates": metres in x, y, z).
        double lon = 0, lat = 0;
        if (!centreLonLat(*srcSrs, gt, ds->GetRasterXSize(), ds->GetRasterYSize(), lon, lat) ||
            target.importFromEPSG(utmEpsgFor(lon, lat)) != OGRERR_NONE) {
            error = "DEM '" + path + "': its CRS is in " + (unit != nullptr ? unit : "a unit") +
                    ", not metres, and its centre cannot be placed in a UTM zone (give a metric "
                    "CRS with --t-srs)" + gdalErrorSuffix();
            return false;
        }
        warp = true;
        dem.conversions.push_back("CRS '" + crsDisplayName(toWkt(*srcSrs)) + "' is in " +
                                  (unit != nullptr ? unit : "a unit") +
                                  ", not metres: reprojected to '" +
                                  crsDisplayName(toWkt(target)) + "' (--t-srs to choose)");
    } else if (srcSrs != nullptr) {
        target = *srcSrs;
        // A metric grid far from true scale (Web Mercator away from the equator, a UTM zone far
        // from the data) stretches the terrain against its heights: say so.
        double lon = 0, lat = 0;
        if (target.IsProjected() && options.warn &&
            centreLonLat(target, gt, ds->GetRasterXSize(), ds->GetRasterYSize(), lon, lat)) {
            double x = 0, y = 0;
            gridToCrs(gt, 0.5 * ds->GetRasterXSize(), 0.5 * ds->GetRasterYSize(), x, y);
            const double k = gridScale(target, x, y);
            if (k > 0 && std::fabs(k - 1) > kGridScaleWarning) {
                char text[64];
                std::snprintf(text, sizeof text, "%.3f", k);
                options.warn("DEM '" + path + "': its CRS '" + crsDisplayName(toWkt(target)) +
                             "' has a scale of " + text +
                             " at the DEM's centre: horizontal distances are off by that factor "
                             "against the heights (slopes, errors, the rendered shape); for true "
                             "metres reproject with --t-srs EPSG:" +
                             std::to_string(utmEpsgFor(lon, lat)));
            }
        }
    }

    // A reprojection must not stretch the terrain: the UTM zone chosen for a geographic or
    // non-metre DEM is refused where its scale is more than 10 % off anywhere on the DEM (a
    // continent or the world in one zone: 1.6e7 m tall models and cut block sizes before), and
    // any target, --t-srs too, gets the scale warning beyond 2 %.
    if (warp && srcSrs != nullptr && target.IsProjected() && !srcSrs->IsSame(&target)) {
        double k = extentGridScale(*srcSrs, target, gt, ds->GetRasterXSize(), ds->GetRasterYSize());
        const bool chosen = options.targetSrs.empty();
        if (chosen && k > 0 && srcSrs->IsGeographic()) {
            // The UTM zone's scale on the sphere, 1 / sqrt(1 - (cos(lat) sin(dlon))^2), at the
            // DEM's point furthest from the zone's central meridian and nearest the equator: the
            // nine points above miss a DEM reaching around the globe, where the transverse
            // Mercator folds over (dlon beyond 90 degrees) yet gives finite numbers.
            const double meridian = target.GetProjParm(SRS_PP_CENTRAL_MERIDIAN, 0.0);
            double lat0 = INFINITY, lat1 = -INFINITY, far = 0;
            for (const auto& [lon, lat] :
                 rasterCorners(gt, ds->GetRasterXSize(), ds->GetRasterYSize())) {
                lat0 = std::min(lat0, lat);
                lat1 = std::max(lat1, lat);
                double d = std::fabs(std::remainder(lon - meridian, 360.0));
                far = std::max(far, d);
            }
            const double rad = 3.14159265358979323846 / 180;
            const double nearest =
                lat0 <= 0 && lat1 >= 0 ? 0 : std::min(std::fabs(lat0), std::fabs(lat1));
            const double b = std::cos(nearest * rad) * std::sin(std::min(far, 90.0) * rad);
            const double sphere = b < 1 ? 1 / std::sqrt(1 - b * b) : 0;
            k = sphere > 0 && std::fabs(sphere - 1) > std::fabs(k - 1) ? sphere
                                                                       : (sphere > 0 ? k : 0);
        }
        char text[64];
        std::snprintf(text, sizeof text, "%.3f", k);
        if (chosen && !(k > 0 && std::fabs(k - 1) <= kGridScaleRefusal)) {
            double lon = 0, lat = 0;
            const bool centre =
                centreLonLat(*srcSrs, gt, ds->GetRasterXSize(), ds->GetRasterYSize(), lon, lat);
            char centreText[128] = "";
            if (centre)
                std::snprintf(centreText, sizeof centreText,
                              " (e.g. '+proj=aeqd +lat_0=%.4f +lon_0=%.4f +datum=WGS84', "
                              "centred on it)",
                              lat, lon);
            error = "DEM '" + path + "': too large for one UTM zone: '" +
                    crsDisplayName(toWkt(target)) + "' " +
                    (k > 0 ? std::string("has a scale of ") + text + " at its edges"
                           : std::string("cannot hold its extent")) +
                    "; give a projected CRS in metres that fits its whole extent with --t-srs" +
                    centreText;
            return false;
        }
        if (options.warn && k > 0 && std::fabs(k - 1) > kGridScaleWarning) {
            options.warn(
                "DEM '" + path + "': the CRS it is reprojected to, '" +
                crsDisplayName(toWkt(target)) + "', has a scale of " + text +
                " on the DEM: horizontal distances are off by up to that factor "
                "against the heights (slopes, errors, the rendered shape)" +
                (chosen ? "; a CRS that fits its extent better can be given with --t-srs" : ""));
        }
    }

    if (rotated) {
        // GDAL's warper resamples the rotated cells onto a north-up grid of about the same cell
        // size (in the chosen CRS, else in the raster's own coordinates).
        warp = true;
        char text[160];
        std::snprintf(text, sizeof text,
                      "a rotated or sheared grid (geotransform terms %.6g, %.6g): resampled to a "
                      "north-up grid (bilinear)",
                      gt[2], gt[4]);
        dem.conversions.push_back(text);
    }

    // Elevations: raw * scale + offset (the band's, read before any warp, which keeps raw
    // values), in the band's unit, else a declared vertical CRS's unit; then metres.
    GDALRasterBand* original = ds->GetRasterBand(band);
    int hasScale = 0, hasOffset = 0;
    double scale = original->GetScale(&hasScale), offset = original->GetOffset(&hasOffset);
    if (!hasScale) scale = 1;
    if (!hasOffset) offset = 0;
    if (!std::isfinite(scale) || scale == 0 || !std::isfinite(offset)) {
        error = "DEM '" + path + "': band " + std::to_string(band) +
                " has an unusable scale or offset (" + std::to_string(scale) + ", " +
                std::to_string(offset) + ")";
        return false;
    }
    std::string zUnit = original->GetUnitType() != nullptr ? original->GetUnitType() : "";
    double zMetres = metresPerUnit(zUnit);
    if (zUnit.empty() && srcSrs != nullptr && (srcSrs->IsCompound() || srcSrs->IsVertical())) {
        const char* name = nullptr;
        const double f = srcSrs->GetTargetLinearUnits("VERT_CS", &name);
        if (f > 0 && std::isfinite(f)) {
            zMetres = f;
            zUnit = name != nullptr ? name : "";
        }
    }
    if (zMetres == 0) {
        if (options.warn)
            options.warn("DEM '" + path + "': unknown elevation unit '" + zUnit + "' of band " +
                         std::to_string(band) + ": read as metres");
        zMetres = 1;
    }
    // No unit anywhere for the heights of a DEM whose CRS is in feet: they are read as metres,
    // which is wrong by 3.28x if they are feet like the cells; say so.
    if (zUnit.empty() && options.warn && srcSrs != nullptr && srcSrs->IsProjected()) {
        const char* name = nullptr;
        const double f = srcSrs->GetLinearUnits(&name);
        if (std::fabs(f - 1.0) > 1e-9)
            options.warn(
                "DEM '" + path + "': its CRS is in " +
                (name != nullptr ? name : "a unit that is not metres") +
                " but its heights declare no unit (band unit or vertical CRS): they are "
                "read as metres; if they are in the CRS's unit, give the band that unit "
                "or a vertical CRS (e.g. gdal_edit.py -a_srs EPSG:<horizontal>+<vertical>)");
    }
    auto number = [](double v) {
        char text[32];
        std::snprintf(text, sizeof text, "%.10g", v);
        return std::string(text);
    };
    if (scale != 1 || offset != 0) {
        dem.conversions.push_back("elevations = stored value x " + number(scale) +
                                  (offset != 0 ? " + " + number(offset) : std::string()) +
                                  " (the band's scale and offset)");
    }
    if (zMetres != 1) {
        dem.conversions.push_back("elevations in " + zUnit + ", converted to metres (x " +
                                  number(zMetres) + ")");
    }

    // The grid must fit the memory (DemLoadOptions::memoryBytes), checked before reading; one
    // that does not may be held in a temporary file (spillDir) when only its lattice stays.
    bool spill = false;
    auto fitsMemory = [&](double cols, double rows, bool reprojected) {
        const double cells = cols * rows;
        const double perCell = std::max(4.0, options.bytesPerCell);
        const double need = options.baseBytes + demReadBytes(cells, perCell);
        const bool limited = options.memoryBytes > 0;
        std::string onDisk;
        if (!options.spillDir.empty() &&
            (options.spillAlways || (limited && need > options.memoryBytes))) {
            const double s = std::max(1, options.spillStride);
            const double lattice =
                (std::floor((cols - 1) / s) + 1) * (std::floor((rows - 1) / s) + 1);
            const double memory = options.baseBytes + cells * (perCell - 4) + lattice * perCell;
            const double disk = cells * 4, free = freeDiskBytes(options.spillDir);
            if ((!limited || memory <= options.memoryBytes) && (free < 0 || disk <= free)) {
                spill = true;
                return true;
            }
            char text[200];
            std::snprintf(text, sizeof text,
                          " (a temporary file of them needs %.2f GB of disk, '%s' has %.2f GB "
                          "free, and %.2f GB of memory)",
                          disk / 1e9, options.spillDir.c_str(), std::max(0.0, free) / 1e9,
                          memory / 1e9);
            onDisk = text;
        }
        if (!limited || need <= options.memoryBytes) return true;
        char text[320];
        std::snprintf(
            text, sizeof text,
            "%d x %d cells%s need at least %.2f GB of memory (%.0f bytes a cell to "
            "read and hold them), more than %s allows (%.2f GB)",
            ds->GetRasterXSize(), ds->GetRasterYSize(), reprojected ? " (reprojected)" : "",
            need / 1e9, perCell,
            options.memoryWhat.empty() ? "the available memory" : options.memoryWhat.c_str(),
            options.memoryBytes / 1e9);
        error = "DEM '" + path + "': " + text + onDisk +
                ": clip it to the area needed or resample it to larger cells first (e.g. "
                "gdalwarp -tr)" +
                (options.memorySkippable ? "; --no-memory-check tries anyway" : "");
        return false;
    };

    GDALDataset* source = ds.get();
    GDALDatasetUniquePtr single, plan;
    std::string sourceWkt;
    int readBand = band;
    if (warp) {
        if (bands > 1) {
            single = extractBand(ds.get(), band, band != alphaBand ? alphaBand : 0);
            if (!single) {
                error = "DEM '" + path + "': cannot select band " + std::to_string(band) +
                        gdalErrorSuffix();
                return false;
            }
            source = single.get();
        }
        // Horizontal CRSs only: the heights are converted here, once (below: the band's or the
        // vertical CRS's unit). Given a compound source (EPSG:2274+6360, heights in US feet),
        // GDAL's warper converted them to metres itself, and they were scaled twice.
        auto horizontalWkt = [](const OGRSpatialReference& srs) {
            if (!srs.IsCompound()) return toWkt(srs);
            OGRSpatialReference horizontal(srs);
            horizontal.StripVertical();
            return toWkt(horizontal);
        };
        sourceWkt = assumedWkt;
        if (srcSrs != nullptr && srcSrs->IsCompound()) sourceWkt = horizontalWkt(*srcSrs);
        const std::string targetWkt = srcSrs != nullptr ? horizontalWkt(target) : std::string();
        plan = planWarp(source, targetWkt, sourceWkt);
        if (!plan) {
            error = "DEM '" + path + "': reprojection failed" + gdalErrorSuffix();
            return false;
        }
        if (!fitsMemory(plan->GetRasterXSize(), plan->GetRasterYSize(), true)) return false;
        plan->GetGeoTransform(gt);
        readBand = 1;
    }

    const int w = warp ? plan->GetRasterXSize() : source->GetRasterXSize();
    const int h = warp ? plan->GetRasterYSize() : source->GetRasterYSize();
    if (!warp && !fitsMemory(w, h, false)) return false;
    dem.width = w;
    dem.height = h;
    dem.cellX = gt[1];
    dem.cellY = gt[5];
    dem.originX = gt[0] + 0.5 * gt[1];
    dem.originY = gt[3] + 0.5 * gt[5];
    if (spill) {
        dem.z = CellVector(CellAllocator<float>(options.spillDir));
        if (options.warn) {
            char text[300];
            std::snprintf(text, sizeof text,
                          "': its %d x %d cells (%.2f GB) are held in a temporary file in '%s' "
                          "while it is read (%s); the --stride %d lattice stays in memory",
                          w, h, 4.0 * double(w) * double(h) / 1e9, options.spillDir.c_str(),
                          options.spillAlways ? "asked for" : "the memory cannot hold them",
                          options.spillStride);
            options.warn("DEM '" + path + text);
        }
    }
    try {
        // A warp leaves NaN where no source cell reaches; a plain read writes every cell.
        if (warp)
            dem.z.assign(static_cast<std::size_t>(w) * h, kNaN);
        else
            dem.z.resize(static_cast<std::size_t>(w) * h);
    } catch (const std::runtime_error& e) {  // the temporary file (mapTemporaryFile)
        error = "DEM '" + path + "': its cells: " + e.what();
        dem = DemGrid{};
        return false;
    }
    if (srcSrs != nullptr) dem.wkt = toWkt(target);

    std::size_t valid = 0;
    // Raw value -> metres; false where it is not a finite altitude.
    auto convert = [&](double v, float& out) {
        if (!std::isfinite(v)) return false;
        const double z = (v * scale + offset) * zMetres;
        if (!std::isfinite(z)) return false;
        out = static_cast<float>(z);
        return true;
    };
    if (warp) {
        // Warped into the grid itself, NaN where no source cell reaches (the warper applied the
        // source's nodata and mask, extractBand handing it the alpha band); converted in place.
        if (!warpInto(source, plan.get(), sourceWkt, options.threads, dem.z.data())) {
            error = "DEM '" + path + "': reprojection failed" + gdalErrorSuffix();
            dem = DemGrid{};
            return false;
        }
        plan.reset();
        single.reset();
        ds->FlushCache(false);
        for (float& z : dem.z) {
            if (!convert(z, z)) {
                z = kNaN;
                continue;
            }
            ++valid;
        }
    } else {
        GDALRasterBand* rb = source->GetRasterBand(readBand);
        assert(rb != nullptr);
        int hasNoData = 0;
        const double noData = rb->GetNoDataValue(&hasNoData);
        // The band's mask beyond its nodata value: an alpha band (read as bytes: 0 stays 0, any
        // other value of an Int16 or UInt16 alpha is clamped above 0; GDAL takes only a Byte or
        // UInt16 alpha as the mask), a per-dataset mask (internal or .msk) or a band mask; a cell
        // it marks 0 is nodata.
        GDALRasterBand* mask = nullptr;
        if (alphaBand > 0 && band != alphaBand) {
            mask = ds->GetRasterBand(alphaBand);
        } else if (const int flags = rb->GetMaskFlags();
                   (flags & GMF_ALL_VALID) == 0 && flags != GMF_NODATA) {
            mask = rb->GetMaskBand();
        }
        std::vector<std::uint8_t> maskRow(mask != nullptr ? static_cast<std::size_t>(w) : 0);
        // GDAL's block cache is emptied after each row of blocks: it held the whole raster again
        // (a Float32 GeoTIFF: 8 bytes a cell read instead of 4) until 2026-12-02.
        int blockWidth = 0, blockHeight = 0;
        rb->GetBlockSize(&blockWidth, &blockHeight);
        blockHeight = std::max(1, blockHeight);

        // Row by row in double, so that the nodata comparison is exact for every band type.
        std::vector<double> row(static_cast<std::size_t>(w));
        for (int r = 0; r < h; ++r) {
            if (rb->RasterIO(GF_Read, 0, r, w, 1, row.data(), w, 1, GDT_Float64, 0, 0, nullptr) !=
                    CE_None ||
                (mask != nullptr && mask->RasterIO(GF_Read, 0, r, w, 1, maskRow.data(), w, 1,
                                                   GDT_Byte, 0, 0, nullptr) != CE_None)) {
                error = "DEM '" + path + "': read error at row " + std::to_string(r) +
                        gdalErrorSuffix();
                dem = DemGrid{};
                return false;
            }
            float* out = dem.z.data() + static_cast<std::size_t>(r) * w;
            for (int c = 0; c < w; ++c) {
                const double v = row[c];
                out[c] = kNaN;
                if (hasNoData && v == noData) continue;
                if (mask != nullptr && maskRow[static_cast<std::size_t>(c)] == 0) continue;
                if (convert(v, out[c])) ++valid;
            }
            if ((r + 1) % blockHeight == 0) ds->FlushCache(false);
        }
        ds->FlushCache(false);
    }
    if (valid == 0) {
        error = "DEM '" + path + "': every cell is nodata";
        dem = DemGrid{};
        return false;
    }
    if (srcSrs == nullptr && !checkUndeclaredUnits(path, dem, options, error)) {
        dem = DemGrid{};
        return false;
    }
    return true;
}

std::string crsDisplayName(const std::string& wkt) {
    if (wkt.empty()) return "none";
    OGRSpatialReference srs;
    if (srs.importFromWkt(wkt.c_str()) != OGRERR_NONE) return "unknown";
    std::string name = srs.GetName() != nullptr ? srs.GetName() : "unnamed";
    const char* auth = srs.GetAuthorityName(nullptr);
    const char* code = srs.GetAuthorityCode(nullptr);
    if (auth != nullptr && code != nullptr) name += std::string(" (") + auth + ":" + code + ")";
    return name;
}

}  // namespace unilod
