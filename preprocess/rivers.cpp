// River line ingestion through OGR: layer choice, attribute filter, and transformation to the
// DEM's working CRS, so that river vertices and DEM cells share one metric frame (DESIGN.md
// "Coordinates"). Axis order is forced to x = easting / longitude on both ends, whatever the
// CRS definitions say, because that is how vector files store coordinates.
#include "rivers.h"

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "atomicfile.h"
#include "gdal_errors.h"
#include "srs.h"

namespace unilod {

namespace {

// Linear geometry types: line strings and curves (circular arcs, compound curves: GML, GeoPackage
// and FileGDB hydrography), single or multi; curves are read as OGR's linear approximation.
bool isLineType(OGRwkbGeometryType t) {
    const OGRwkbGeometryType flat = wkbFlatten(t);
    return flat == wkbLineString || flat == wkbMultiLineString || flat == wkbCircularString ||
           flat == wkbCompoundCurve || flat == wkbMultiCurve;
}

// A layer type whose features may hold lines although the type does not say so.
bool isMixedType(OGRwkbGeometryType t) {
    const OGRwkbGeometryType flat = wkbFlatten(t);
    return flat == wkbUnknown || flat == wkbGeometryCollection;
}

// Calls `line` for every line string in `g`: curves linearised, multi-geometries and geometry
// collections walked (nested ones too). False when `line` returns false (stops there).
template <typename F>
bool forEachLine(const OGRGeometry& g, F&& line) {
    switch (wkbFlatten(g.getGeometryType())) {
        case wkbLineString:
            return line(*g.toLineString());
        case wkbCircularString:
        case wkbCompoundCurve: {
            const std::unique_ptr<OGRGeometry> linear(g.getLinearGeometry());
            return !linear || forEachLine(*linear, line);
        }
        case wkbMultiLineString:
        case wkbMultiCurve:
        case wkbGeometryCollection:
            for (const OGRGeometry* part : *g.toGeometryCollection()) {
                if (part != nullptr && !forEachLine(*part, line)) return false;
            }
            return true;
        default:
            return true;  // points, polygons, surfaces: not rivers
    }
}

// True when `g` holds a line somewhere.
bool holdsLine(const OGRGeometry& g) {
    bool found = false;
    forEachLine(g, [&](const OGRLineString&) {
        found = true;
        return false;
    });
    return found;
}

// True when some feature of a layer of unknown / mixed geometry type holds a line.
bool hasLineFeature(OGRLayer* layer) {
    layer->ResetReading();
    for (const auto& feature : *layer) {
        const OGRGeometry* g = feature->GetGeometryRef();
        if (g != nullptr && holdsLine(*g)) return true;
    }
    return false;
}

struct TransformDeleter {
    void operator()(OGRCoordinateTransformation* ct) const {
        OGRCoordinateTransformation::DestroyCT(ct);
    }
};

}  // namespace

bool loadRivers(const std::string& path, const RiverLoadOptions& options,
                const std::string& workingWkt, RiverLines& out, std::string& error) {
    QuietGdalErrors quiet;
    out.clear();
    const std::string what = "rivers '" + path + "'";

    VSIStatBufL st;
    if (VSIStatL(path.c_str(), &st) != 0) {
        error = what + ": no such file";
        return false;
    }
    // A FIFO or a device would block OGR's open; a folder can be a data set (Shapefiles).
    if (std::string why; !format::checkInputFile(path, true, why)) {
        error = what + ": " + why;
        return false;
    }
    GDALDatasetUniquePtr ds(GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR));
    if (!ds) {
        error =
            what + ": not a vector file GDAL/OGR can read" + gdalErrorSuffix() + archiveHint(path);
        return false;
    }

    OGRLayer* layer = nullptr;
    if (!options.layer.empty()) {
        layer = ds->GetLayerByName(options.layer.c_str());
        if (layer == nullptr) {
            error = what + ": no layer named '" + options.layer + "' (--layer)";
            return false;
        }
        const OGRwkbGeometryType t = layer->GetGeomType();
        if (!isLineType(t) && !(isMixedType(t) && hasLineFeature(layer))) {
            error = what + ": layer '" + options.layer + "' has no line geometry (--layer)";
            return false;
        }
    } else {
        // Declared line layers first, the first that holds a line (a GPX file's empty `routes`
        // before its `tracks`, an empty GeoPackage layer before a full one: the empty one was
        // taken and the rivers lost), else the first; then layers of undeclared type that hold
        // lines (GeoJSON with mixed geometries).
        for (OGRLayer* l : ds->GetLayers()) {
            if (!isLineType(l->GetGeomType())) continue;
            if (layer == nullptr) layer = l;
            if (hasLineFeature(l)) {
                layer = l;
                break;
            }
        }
        for (int i = 0; layer == nullptr && i < ds->GetLayerCount(); ++i) {
            OGRLayer* l = ds->GetLayer(i);
            if (isMixedType(l->GetGeomType()) && hasLineFeature(l)) layer = l;
        }
        // Other layers that hold lines are not read: say so, so that a second network (canals
        // beside rivers in one GeoPackage) is not lost without a word.
        std::vector<std::string> others;
        for (OGRLayer* l : ds->GetLayers()) {
            const OGRwkbGeometryType t = l->GetGeomType();
            if (l != layer && (isLineType(t) || isMixedType(t)) && hasLineFeature(l))
                others.emplace_back(l->GetName());
        }
        if (layer != nullptr && !others.empty() && options.warn) {
            options.warn(what + ": read its line layer '" + layer->GetName() + "'; " +
                         std::to_string(others.size()) + " other layer" +
                         (others.size() == 1 ? "" : "s") + " with lines not read (" +
                         quotedNames(others) + "): --layer NAME picks one");
        }
        if (layer == nullptr) {
            // No feature anywhere (an empty FeatureCollection declares no geometry type): an
            // empty river network, which the caller may accept as a terrain-only model. A layer
            // holding only points or polygons is a wrong file, not an empty one.
            bool anyFeature = false;
            for (OGRLayer* l : ds->GetLayers())
                anyFeature = anyFeature || l->GetFeatureCount(TRUE) != 0;
            if (!anyFeature) return true;
            error = what + ": no layer with line geometry (LineString / MultiLineString)";
            return false;
        }
    }
    const std::string layerName = layer->GetName();

    if (!options.where.empty() && layer->SetAttributeFilter(options.where.c_str()) != OGRERR_NONE) {
        error = what + ": invalid --where clause '" + options.where + "'" + gdalErrorSuffix();
        return false;
    }

    // Transformation to the working CRS.
    std::unique_ptr<OGRCoordinateTransformation, TransformDeleter> ct;
    if (!workingWkt.empty()) {
        OGRSpatialReference src;
        if (const OGRSpatialReference* declared = layer->GetSpatialRef()) {
            src = *declared;
        } else if (!options.assumeSrs.empty()) {
            if (!parseSrs(options.assumeSrs, src)) {
                error =
                    what + ": cannot parse the assumed CRS '" + options.assumeSrs + "' (--s-srs)";
                return false;
            }
        } else {
            error = what + ": layer '" + layerName +
                    "' has no CRS while the DEM has one; name it with --s-srs";
            return false;
        }
        OGRSpatialReference dst;
        if (dst.importFromWkt(workingWkt.c_str()) != OGRERR_NONE) {
            error = what + ": invalid working CRS" + gdalErrorSuffix();
            return false;
        }
        src.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
        dst.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
        if (!src.IsSame(&dst)) {
            ct.reset(OGRCreateCoordinateTransformation(&src, &dst));
            if (!ct) {
                error = what + ": no transformation from the layer's CRS to the DEM's" +
                        gdalErrorSuffix();
                return false;
            }
        }
    }

    // Appends one line, transformed. False on a transformation failure (`failedAt`: the first
    // vertex that failed, in the layer's coordinates).
    std::vector<double> xs, ys;
    std::vector<int> ok;
    double failedAt[2] = {NAN, NAN};
    auto addLine = [&](const OGRLineString& line) {
        const int n = line.getNumPoints();
        xs.resize(n);
        ys.resize(n);
        for (int i = 0; i < n; ++i) {
            xs[i] = line.getX(i);
            ys[i] = line.getY(i);
        }
        if (ct && n > 0) {
            ok.assign(n, 0);
            const bool all = ct->Transform(n, xs.data(), ys.data(), nullptr, ok.data());
            const int bad = int(std::find(ok.begin(), ok.end(), 0) - ok.begin());
            if (!all || bad < n) {
                const int at = bad < n ? bad : 0;  // the first that failed (else the line's)
                failedAt[0] = line.getX(at);
                failedAt[1] = line.getY(at);
                return false;
            }
        }
        RiverLine& l = out.emplace_back();
        l.reserve(n);
        for (int i = 0; i < n; ++i)
            l.push_back({xs[i], ys[i]});
        return true;
    };

    layer->ResetReading();
    // Drivers that evaluate the --where clause while reading (GeoPackage, SQLite) report a bad one
    // as an error of the read, which then ends like the end of the layer.
    CPLErrorReset();
    bool hasZ = false;
    std::size_t skipped = 0;  // features with a geometry but no line in it
    for (const auto& feature : *layer) {
        const OGRGeometry* g = feature->GetGeometryRef();
        if (g == nullptr) continue;
        bool any = false;
        const bool good = forEachLine(*g, [&](const OGRLineString& line) {
            any = true;
            hasZ = hasZ || line.Is3D();
            return addLine(line);
        });
        if (!any) ++skipped;
        if (!good) {
            const OGRSpatialReference* declared = layer->GetSpatialRef();
            char at[96];
            std::snprintf(at, sizeof at, " (vertex %.10g, %.10g)", failedAt[0], failedAt[1]);
            error = what + ": feature " + std::to_string(feature->GetFID()) + at +
                    " cannot be transformed to the DEM's CRS" + gdalErrorSuffix();
            // Projected numbers in a layer that says degrees (a GeoJSON file without a "crs"
            // member is WGS 84 longitude / latitude by definition).
            if (declared != nullptr && declared->IsGeographic() &&
                (std::fabs(failedAt[0]) > 360 || std::fabs(failedAt[1]) > 90))
                error +=
                    "; the layer's CRS is geographic (degrees) but this vertex is not a "
                    "longitude / latitude: assign the right CRS (ogr2ogr -a_srs EPSG:...), "
                    "a GeoJSON file without a \"crs\" member is WGS 84 by definition";
            out.clear();
            return false;
        }
    }
    if (!options.where.empty() && CPLGetLastErrorType() >= CE_Failure) {
        error = what + ": invalid --where clause '" + options.where + "'" + gdalErrorSuffix();
        out.clear();
        return false;
    }
    if (skipped > 0 && options.warn) {
        options.warn(what + ": " + std::to_string(skipped) + " feature" +
                     (skipped == 1 ? "" : "s") + " of layer '" + layerName +
                     "' without a line (points, polygons) skipped");
    }
    if (hasZ && options.warn) {
        options.warn(what + ": the lines have z coordinates; they are ignored (river altitudes " +
                     "are sampled from the DEM, so rivers lie on the terrain)");
    }
    // A declared line layer without any feature is an empty network as above; a where clause
    // that matches nothing is more likely a typo and stays an error.
    if (out.empty() && options.where.empty() && layer->GetFeatureCount(TRUE) == 0) return true;
    if (out.empty()) {
        error = what + ": layer '" + layerName + "' has no line features" +
                (options.where.empty() ? "" : " matching the --where clause");
        return false;
    }
    return true;
}

}  // namespace unilod
