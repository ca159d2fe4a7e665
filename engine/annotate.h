// Annotation of rendered images (issue 20, item 5): a hypsometric colour key in metres, a scale
// bar and a north arrow drawn with Cairo onto an RGBA8 image before it is written as PNG
// (`capture --annotate`, the `view` screenshot with --annotate, `report`'s grid diagrams). The
// one place that draws text and vector marks onto images; the report's plots use drawWithCairo.
//
// What each mark means:
// - Colour key: shaders/shared.h hypsometricTint (the terrain's tint before shading) over the z
//   range the shader maps (FrameView minZ..maxZ: the file's z range), maxZ at the top of the bar,
//   ticks at round metre values. Not drawn in grid mode (one flat line colour there).
// - Scale bar: metres per image pixel along the image's x axis. Grid mode (orthographic, top
//   down): 2 * gridHalfHeight / height, exact everywhere. Perspective: exact only at one depth;
//   the ray through the image centre is intersected with the horizontal plane z = (minZ +
//   maxZ) / 2 (z = minZ when the eye is not above that plane); at that point, at depth d along
//   the view axis, a pixel spans 2 d tan(fov / 2) / height metres across the image (the camera
//   has no roll, so the image's x axis is horizontal in the world). Labelled "at image centre".
//   No bar when the centre ray meets neither plane (looking up or level).
// - North arrow: +y of the file's CRS at the image centre, projected: (right . y, up . y) of the
//   camera basis (lod/camera.h cameraBasis), the derivative of the projection at the centre
//   ray; grid mode is north up. When the projection is (almost) a point (looking level along
//   north), a circled dot or cross says whether north is behind the viewer or ahead.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "renderer.h"

typedef struct _cairo cairo_t;  // <cairo.h>: only annotate.cpp and the plots include it

namespace unilod::engine {

struct PixelRect {
    std::int32_t x = 0, y = 0, width = 0, height = 0;
};

struct Annotation {
    bool colourKey = false;
    double keyMinZ = 0, keyMaxZ = 0;  // the z range the shader maps (metres)
    bool scaleBar = false;
    double metresPerPixel = 0;  // along the image's x axis
    bool scaleExact = true;     // false: perspective, exact at the image centre only
    bool northArrow = false;
    double northX = 0, northY = -1;  // image direction of +y (x right, y down); need not be unit
    int northAlongView =
        0;  // projection ~ a point: +1 north lies ahead (into the image), -1 behind
    // Where the marks go (width 0: the whole image): north arrow top left, colour key top right,
    // scale bar bottom left.
    PixelRect area;
};

// What annotateImage drew, in image pixels (the capture's JSON records it).
struct AnnotationLayout {
    std::vector<PixelRect> regions;  // every pixel annotateImage may change lies in one of these
    PixelRect keyBar;                // the ramp: top row maxZ, bottom row minZ; empty: no key
    double scaleMetres = 0;          // the bar's length in metres (0: no bar)
    std::int32_t scalePixels = 0;    // ... and in pixels
    double northDegrees = 0;         // the arrow, clockwise from image up
};

// The annotation of a rendered view (definitions above).
Annotation annotationFor(const FrameView& view);

// Draws `a` onto `rgba` (width x height, RGBA8, rows top to bottom). Pixels outside
// layout.regions are left untouched, byte for byte.
void annotateImage(std::vector<std::uint8_t>& rgba, std::uint32_t width, std::uint32_t height,
                   const Annotation& a, AnnotationLayout* layout = nullptr);

// The shared text style: Cairo's toy API, face "sans-serif" (fontconfig picks the font), `size`
// pixels.
void setTextStyle(cairo_t* cr, double size, bool bold = false);

// Runs `draw` on a Cairo context over the image (RGBA8, rows top to bottom) and writes the
// result back. Only pixels whose value changed are written back, so untouched pixels keep their
// bytes exactly (alpha included).
void drawWithCairo(std::vector<std::uint8_t>& rgba, std::uint32_t width, std::uint32_t height,
                   const std::function<void(cairo_t*)>& draw);

// A title band across the top `bandHeight` rows: white, `lines` left-aligned, the first bold.
void drawTitleBand(std::vector<std::uint8_t>& rgba, std::uint32_t width, std::uint32_t height,
                   std::uint32_t bandHeight, const std::vector<std::string>& lines);
// The band height and font size drawTitleBand uses for `lineCount` lines on an image `width`
// wide.
std::uint32_t titleBandHeight(std::uint32_t width, std::size_t lineCount);

// Round values for axes and bars: the largest 1, 2 or 5 x 10^k <= v (v > 0).
double niceFloor(double v);
// "850 m", "2 km", "1.5 km".
std::string formatMetres(double metres);

}  // namespace unilod::engine
