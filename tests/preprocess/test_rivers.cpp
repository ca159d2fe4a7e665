// River ingestion (preprocess/rivers.h): the bundled GRASS network reprojected onto the bundled
// DEM's working CRS, layer choice, where clauses, multi-part and 3D lines, CRS errors.
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>

#include "testutil.h"
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <cpl_conv.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include "dem.h"
#include "rivers.h"

using namespace unilod;
namespace fs = std::filesystem;

namespace {

const std::string kAssets = UNILOD_ASSETS_DIR;

using unilod::test::TempDir;

const DemGrid& bundledDem() {
    static const DemGrid dem = [] {
        DemGrid d;
        std::string error;
        EXPECT_TRUE(loadDem(kAssets + "/jacksboro_dem.tif", {}, d, error)) << error;
        return d;
    }();
    return dem;
}

// The WKT of UTM zone 16N (EPSG:32616), the working CRS of the hand-made layers below.
std::string utm16Wkt() {
    OGRSpatialReference srs;
    srs.importFromEPSG(32616);
    char* wkt = nullptr;
    srs.exportToWkt(&wkt);
    const std::string text = wkt;
    CPLFree(wkt);
    return text;
}

// A GeoJSON FeatureCollection in UTM zone 16N holding `features` (comma-separated Features).
std::string utm16Collection(const std::string& features) {
    return R"({"type": "FeatureCollection",
      "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32616"}},
      "features": [)" +
           features + "]}";
}

}  // namespace

TEST(Rivers, BundledGrassNetworkInsideTheDem) {
    const DemGrid& dem = bundledDem();
    ASSERT_FALSE(dem.wkt.empty());
    RiverLines lines;
    std::string error;
    ASSERT_TRUE(loadRivers(kAssets + "/jacksboro_rivers_grass.geojson", {}, dem.wkt, lines, error))
        << error;
    EXPECT_EQ(lines.size(), 142u);
    const double xMin = dem.originX - 0.5 * std::abs(dem.cellX);
    const double xMax = dem.centreX(dem.width - 1) + 0.5 * std::abs(dem.cellX);
    const double yMax = dem.originY + 0.5 * std::abs(dem.cellY);
    const double yMin = dem.centreY(dem.height - 1) - 0.5 * std::abs(dem.cellY);
    std::size_t vertices = 0;
    for (const RiverLine& line : lines) {
        EXPECT_GE(line.size(), 2u);
        for (const XY& p : line) {
            ++vertices;
            EXPECT_GE(p.x, xMin);
            EXPECT_LE(p.x, xMax);
            EXPECT_GE(p.y, yMin);
            EXPECT_LE(p.y, yMax);
        }
    }
    EXPECT_GT(vertices, 1000u);
    // Metres, not degrees: UTM eastings and northings.
    EXPECT_GT(lines[0][0].x, 100000.0);
    EXPECT_GT(lines[0][0].y, 3000000.0);
}

TEST(Rivers, BundledGshhgNetworkLoads) {
    RiverLines lines;
    std::string error;
    ASSERT_TRUE(
        loadRivers(kAssets + "/jacksboro_rivers_gshhg.geojson", {}, bundledDem().wkt, lines, error))
        << error;
    EXPECT_GT(lines.size(), 0u);
}

TEST(Rivers, WhereClauseAndLayerName) {
    RiverLines lines;
    std::string error;
    RiverLoadOptions o;
    o.where = "cat = 59";
    ASSERT_TRUE(
        loadRivers(kAssets + "/jacksboro_rivers_grass.geojson", o, bundledDem().wkt, lines, error))
        << error;
    EXPECT_EQ(lines.size(), 1u);
    o.where = "no_such_field = 1";
    EXPECT_FALSE(
        loadRivers(kAssets + "/jacksboro_rivers_grass.geojson", o, bundledDem().wkt, lines, error));
    EXPECT_NE(error.find("where"), std::string::npos) << error;

    // A GeoPackage evaluates the clause in SQLite while reading: a bad clause is still named as
    // such (it was "has no line features matching the --where clause").
    {
        TempDir dir("wheregpkg");
        const std::string gpkg = dir.file("rivers.gpkg");
        GDALAllRegister();
        GDALDatasetH src = GDALOpenEx((kAssets + "/jacksboro_rivers_grass.geojson").c_str(),
                                      GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
        ASSERT_NE(src, nullptr);
        char* args[] = {const_cast<char*>("-f"), const_cast<char*>("GPKG"), nullptr};
        GDALVectorTranslateOptions* vt = GDALVectorTranslateOptionsNew(args, nullptr);
        GDALDatasetH copy = GDALVectorTranslate(gpkg.c_str(), nullptr, 1, &src, vt, nullptr);
        GDALVectorTranslateOptionsFree(vt);
        GDALClose(src);
        ASSERT_NE(copy, nullptr);
        GDALClose(copy);
        o.where = "cat = 59";
        ASSERT_TRUE(loadRivers(gpkg, o, bundledDem().wkt, lines, error)) << error;
        EXPECT_EQ(lines.size(), 1u);
        for (const char* bad : {"no_such_field = 1", "((("}) {
            o.where = bad;
            EXPECT_FALSE(loadRivers(gpkg, o, bundledDem().wkt, lines, error));
            EXPECT_NE(error.find("invalid --where clause"), std::string::npos) << error;
        }
    }

    o.where.clear();
    o.layer = "streams";
    EXPECT_TRUE(
        loadRivers(kAssets + "/jacksboro_rivers_grass.geojson", o, bundledDem().wkt, lines, error))
        << error;
    o.layer = "lakes";
    EXPECT_FALSE(
        loadRivers(kAssets + "/jacksboro_rivers_grass.geojson", o, bundledDem().wkt, lines, error));
    EXPECT_NE(error.find("lakes"), std::string::npos) << error;
}

namespace {

// Adds a layer `name` in EPSG:32616 to the GeoPackage `gpkg` (made when `create`), with one
// 2-vertex line (x0, y0) -> (x1, y1), or none when `line` is false. Closed before returning, so
// that layers are listed in the order they were added.
void addLineLayer(const std::string& gpkg, bool create, const char* name, bool line = true,
                  double y1 = 4051000) {
    GDALAllRegister();
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GPKG");
    ASSERT_NE(driver, nullptr);
    OGRSpatialReference srs;
    srs.importFromEPSG(32616);
    GDALDatasetUniquePtr ds(create
                                ? driver->Create(gpkg.c_str(), 0, 0, 0, GDT_Unknown, nullptr)
                                : GDALDataset::Open(gpkg.c_str(), GDAL_OF_VECTOR | GDAL_OF_UPDATE));
    ASSERT_TRUE(ds);
    OGRLayer* layer = ds->CreateLayer(name, &srs, wkbLineString, nullptr);
    ASSERT_NE(layer, nullptr);
    if (!line) return;
    OGRFeature feature(layer->GetLayerDefn());
    OGRLineString geometry;
    geometry.addPoint(740000, 4050000);
    geometry.addPoint(741000, y1);
    feature.SetGeometry(&geometry);
    ASSERT_EQ(layer->CreateFeature(&feature), OGRERR_NONE);
}

}  // namespace

// Without --layer the first declared line layer that holds a line is taken: an empty one before
// it (a GPX file's `routes` before its `tracks`, an empty GeoPackage layer) was taken and the
// rivers were lost with only a "terrain-only model" warning.
TEST(Rivers, AnEmptyLineLayerBeforeAFullOneIsPassedOver) {
    TempDir dir("emptyfirst");
    const std::string gpkg = dir.file("two.gpkg");
    addLineLayer(gpkg, true, "a_empty", false);
    addLineLayer(gpkg, false, "b_full");
    {
        GDALDatasetUniquePtr ds(GDALDataset::Open(gpkg.c_str(), GDAL_OF_VECTOR));
        ASSERT_TRUE(ds);
        ASSERT_EQ(ds->GetLayerCount(), 2);
        ASSERT_STREQ(ds->GetLayer(0)->GetName(), "a_empty");
    }
    RiverLines lines;
    std::string error;
    ASSERT_TRUE(loadRivers(gpkg, {}, bundledDem().wkt, lines, error)) << error;
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_EQ(lines[0].size(), 2u);
    // Named, the empty layer is still what is read: an empty network.
    RiverLoadOptions o;
    o.layer = "a_empty";
    ASSERT_TRUE(loadRivers(gpkg, o, bundledDem().wkt, lines, error)) << error;
    EXPECT_TRUE(lines.empty());
}

// Two layers with lines (rivers and canals in one GeoPackage): the first is read and the other
// named in a warning (it was dropped without a word); --layer reads the other, with no warning.
TEST(Rivers, OtherLineLayersAreNamed) {
    TempDir dir("twolayers");
    const std::string gpkg = dir.file("two.gpkg");
    addLineLayer(gpkg, true, "rivers");
    addLineLayer(gpkg, false, "canals", true, 4049000);
    std::vector<std::string> warnings;
    RiverLoadOptions o;
    o.warn = [&warnings](const std::string& w) { warnings.push_back(w); };
    RiverLines lines;
    std::string error;
    ASSERT_TRUE(loadRivers(gpkg, o, bundledDem().wkt, lines, error)) << error;
    ASSERT_EQ(lines.size(), 1u);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("read its line layer 'rivers'; 1 other layer with lines not read "
                               "('canals'): --layer NAME picks one"),
              std::string::npos)
        << warnings[0];
    warnings.clear();
    o.layer = "canals";
    ASSERT_TRUE(loadRivers(gpkg, o, bundledDem().wkt, lines, error)) << error;
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_GT(lines[0][0].y, lines[0][1].y);
    EXPECT_TRUE(warnings.empty());
}

TEST(Rivers, MultiLineStringsAnd3dLines) {
    TempDir dir("multi");
    const std::string path = dir.write("multi.geojson", utm16Collection(R"(
        {"type": "Feature", "properties": {}, "geometry": {"type": "MultiLineString",
          "coordinates": [[[500000, 4000000, 10], [500100, 4000050, 11]],
                          [[500200, 4000000, 12], [500300, 4000000, 13], [500400, 4000010, 14]]]}},
        {"type": "Feature", "properties": {}, "geometry": {"type": "Point",
          "coordinates": [500000, 4000000]}},
        {"type": "Feature", "properties": {}, "geometry": {"type": "LineString",
          "coordinates": [[500000, 4001000], [500010, 4001010]]}})"));
    RiverLines lines;
    std::string error;
    // Same CRS as the data: coordinates unchanged (x = easting first).
    const std::string working = utm16Wkt();
    ASSERT_TRUE(loadRivers(path, {}, working, lines, error)) << error;
    ASSERT_EQ(lines.size(), 3u);  // two parts + one line; the point is skipped
    EXPECT_EQ(lines[0].size(), 2u);
    EXPECT_EQ(lines[1].size(), 3u);
    EXPECT_EQ(lines[1][2], (XY{500400, 4000010}));
    EXPECT_EQ(lines[2][0], (XY{500000, 4001000}));
}

// Lines inside geometry collections are rivers too, and curves (circular arcs, compound curves,
// as GML, GeoPackage and FileGDB hydrography store them) are read as their linear approximation;
// features without any line are skipped with a warning that counts them.
TEST(Rivers, CollectionsAndCurves) {
    TempDir dir("curves");
    const std::string collection = dir.write("collection.geojson", utm16Collection(R"(
        {"type": "Feature", "properties": {}, "geometry": {"type": "GeometryCollection",
          "geometries": [{"type": "Point", "coordinates": [500000, 4000000]},
                         {"type": "LineString", "coordinates": [[500000, 4000000], [500100, 4000050]]}]}},
        {"type": "Feature", "properties": {}, "geometry": {"type": "Point",
          "coordinates": [500000, 4000000]}},
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon",
          "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]]]}},
        {"type": "Feature", "properties": {}, "geometry": {"type": "LineString",
          "coordinates": [[500000, 4001000], [500010, 4001010]]}})"));
    const std::string working = utm16Wkt();
    std::vector<std::string> warnings;
    RiverLoadOptions options;
    options.warn = [&](const std::string& w) { warnings.push_back(w); };
    RiverLines lines;
    std::string error;
    ASSERT_TRUE(loadRivers(collection, options, working, lines, error)) << error;
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_EQ(lines[0], (RiverLine{{500000, 4000000}, {500100, 4000050}}));
    EXPECT_EQ(lines[1][0], (XY{500000, 4001000}));
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("2 features"), std::string::npos) << warnings[0];

    // A half circle of radius 100 m around (500100, 4000000) and a compound curve (a straight
    // piece, then an arc) in a CSV of WKT: every vertex on its arc or segment, ends exact.
    const std::string curves =
        dir.write("curves.csv",
                  "WKT,id\n"
                  "\"CIRCULARSTRING(500000 4000000,500100 4000100,500200 4000000)\",1\n"
                  "\"COMPOUNDCURVE((500000 4001000,500100 4001000),"
                  "CIRCULARSTRING(500100 4001000,500150 4001050,500200 4001000))\",2\n");
    warnings.clear();
    RiverLoadOptions assumed = options;
    assumed.assumeSrs = "EPSG:32616";
    ASSERT_TRUE(loadRivers(curves, assumed, working, lines, error)) << error;
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_TRUE(warnings.empty());
    EXPECT_GT(lines[0].size(), 10u);  // linearised
    EXPECT_EQ(lines[0].front(), (XY{500000, 4000000}));
    EXPECT_EQ(lines[0].back(), (XY{500200, 4000000}));
    for (const XY& p : lines[0])
        EXPECT_NEAR(std::hypot(p.x - 500100, p.y - 4000000), 100.0, 1e-6);
    EXPECT_EQ(lines[1].front(), (XY{500000, 4001000}));
    EXPECT_EQ(lines[1].back(), (XY{500200, 4001000}));
    for (const XY& p : lines[1]) {
        if (p.x > 500100)
            EXPECT_NEAR(std::hypot(p.x - 500150, p.y - 4001000), 50.0, 1e-6);
        else
            EXPECT_EQ(p.y, 4001000);
    }
}

TEST(Rivers, PointLayerIsAnError) {
    TempDir dir("points");
    const std::string path = dir.write("points.geojson", R"({"type": "FeatureCollection",
      "features": [{"type": "Feature", "properties": {}, "geometry": {"type": "Point",
      "coordinates": [-84.2, 36.5]}}]})");
    RiverLines lines;
    std::string error;
    EXPECT_FALSE(loadRivers(path, {}, bundledDem().wkt, lines, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("no layer with line geometry"), std::string::npos) << error;
    EXPECT_TRUE(lines.empty());
}

TEST(Rivers, EmptyCollectionIsAnEmptyNetwork) {
    TempDir dir("empty");
    const std::string path =
        dir.write("empty.geojson", R"({"type": "FeatureCollection", "features": []})");
    RiverLines lines{{{1, 2}, {3, 4}}};
    std::string error;
    EXPECT_TRUE(loadRivers(path, {}, bundledDem().wkt, lines, error)) << error;
    EXPECT_TRUE(lines.empty());
}

TEST(Rivers, MissingAndUnreadableFiles) {
    TempDir dir("missing");
    RiverLines lines;
    std::string error;
    const std::string missing = (dir.path / "nothing.geojson").string();
    EXPECT_FALSE(loadRivers(missing, {}, bundledDem().wkt, lines, error));
    EXPECT_NE(error.find(missing), std::string::npos) << error;
    EXPECT_NE(error.find("no such file"), std::string::npos) << error;

    const std::string garbage = dir.write("broken.geojson", "{ \"type\": \"FeatureCollection\", ");
    EXPECT_FALSE(loadRivers(garbage, {}, bundledDem().wkt, lines, error));
    EXPECT_NE(error.find(garbage), std::string::npos) << error;

    // A raster is not a vector file.
    EXPECT_FALSE(loadRivers(kAssets + "/jacksboro_dem.tif", {}, bundledDem().wkt, lines, error));
    EXPECT_NE(error.find("jacksboro_dem.tif"), std::string::npos) << error;
}

TEST(Rivers, LayerWithoutCrs) {
    TempDir dir("nocrs");
    // CSV with a WKT column: OGR reads the lines but knows no CRS.
    const std::string path =
        dir.write("lines.csv", "WKT,id\n\"LINESTRING (-84.2 36.5,-84.1 36.6)\",1\n");
    RiverLines lines;
    std::string error;
    EXPECT_FALSE(loadRivers(path, {}, bundledDem().wkt, lines, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("no CRS"), std::string::npos) << error;

    RiverLoadOptions o;
    o.assumeSrs = "EPSG:4326";
    ASSERT_TRUE(loadRivers(path, o, bundledDem().wkt, lines, error)) << error;
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_GT(lines[0][0].x, 100000.0);  // now in UTM metres

    // Without a working CRS coordinates are taken as they are.
    ASSERT_TRUE(loadRivers(path, {}, "", lines, error)) << error;
    EXPECT_EQ(lines[0][0], (XY{-84.2, 36.5}));
}
