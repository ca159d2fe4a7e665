// Colour key, scale bar and north arrow on rendered images (annotate.h), drawn with Cairo.
#include "annotate.h"

#include <cairo.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "camera.h"
#include "shared.h"

namespace unilod::engine {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

// Panels: white, slightly transparent, dark text and marks.
constexpr double kPanelAlpha = 0.85;
constexpr double kInk = 0.12;

std::uint8_t toByte(float c) {
    return std::uint8_t(std::lround(std::clamp(double(c), 0.0, 1.0) * 255.0));
}

PixelRect inflate(const PixelRect& r, std::int32_t by) {
    return {r.x - by, r.y - by, r.width + 2 * by, r.height + 2 * by};
}

PixelRect clipTo(const PixelRect& r, std::uint32_t width, std::uint32_t height) {
    const std::int32_t x0 = std::max(r.x, 0), y0 = std::max(r.y, 0);
    const std::int32_t x1 = std::min(r.x + r.width, std::int32_t(width));
    const std::int32_t y1 = std::min(r.y + r.height, std::int32_t(height));
    if (x1 <= x0 || y1 <= y0) return {};
    return {x0, y0, x1 - x0, y1 - y0};
}

double textWidth(cairo_t* cr, const std::string& s) {
    cairo_text_extents_t e;
    cairo_text_extents(cr, s.c_str(), &e);
    return e.x_advance;
}

void panel(cairo_t* cr, const PixelRect& r) {
    cairo_rectangle(cr, r.x, r.y, r.width, r.height);
    cairo_set_source_rgba(cr, 1, 1, 1, kPanelAlpha);
    cairo_fill_preserve(cr);
    cairo_set_source_rgba(cr, kInk, kInk, kInk, 0.6);
    cairo_set_line_width(cr, 1);
    cairo_stroke(cr);
}

// Text with its left end at x and its vertical middle at y.
void textAt(cairo_t* cr, double x, double y, const std::string& s) {
    cairo_font_extents_t f;
    cairo_font_extents(cr, &f);
    cairo_move_to(cr, x, y + (f.ascent - f.descent) / 2);
    cairo_show_text(cr, s.c_str());
}

struct Sizes {
    double scale, font, pad;
};

Sizes sizesFor(const PixelRect& area) {
    const double s = std::clamp(std::min(area.width, area.height) / 480.0, 0.7, 4.0);
    return {s, std::max(8.0, 11.0 * s), std::round(6.0 * s)};
}

// Tick step of the colour key: round metres, labels at least `minGap` pixels apart.
double keyStep(double range, double barPixels, double minGap) {
    double step = niceFloor(range / 3.0);
    for (int i = 0; i < 64 && barPixels * step / range < minGap; ++i)
        step = niceFloor(step * 2.5 * 1.0000001);
    return step;
}

std::string formatHeight(double z) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", z);
    return buf;
}

struct KeyLayout {
    PixelRect panel, bar;
    std::vector<double> ticks;
    std::string title;
};

KeyLayout layoutKey(cairo_t* cr, const Annotation& a, const PixelRect& area, const Sizes& z) {
    KeyLayout k;
    k.title = "Height (m)";
    const double range = a.keyMaxZ - a.keyMinZ;
    const std::int32_t barW = std::int32_t(std::lround(12 * z.scale));
    const std::int32_t barH =
        std::int32_t(std::lround(std::max(20.0, std::min(0.45 * area.height, 180.0 * z.scale))));
    if (range > 0) {
        const double step = keyStep(range, barH, z.font * 1.3);
        for (double v = std::ceil(a.keyMinZ / step) * step; v <= a.keyMaxZ + 1e-9 * range;
             v += step)
            k.ticks.push_back(v);
    } else {
        k.ticks.push_back(a.keyMinZ);
    }
    double labelW = 0;
    for (double v : k.ticks)
        labelW = std::max(labelW, textWidth(cr, formatHeight(v)));
    const double tick = std::round(4 * z.scale);
    const double inner =
        std::max(double(barW) + tick + 3 * z.scale + labelW, textWidth(cr, k.title));
    const std::int32_t pw = std::int32_t(std::ceil(inner + 2 * z.pad));
    const std::int32_t titleH = std::int32_t(std::ceil(z.font * 1.4));
    // Half a line above and below the bar: the end labels are centred on its ends.
    const std::int32_t ph =
        std::int32_t(std::ceil(z.pad + titleH + z.font * 0.6 + barH + z.font * 0.6 + z.pad));
    k.panel = {area.x + area.width - std::int32_t(z.pad) - pw, area.y + std::int32_t(z.pad), pw,
               ph};
    k.bar = {k.panel.x + std::int32_t(z.pad),
             k.panel.y + std::int32_t(z.pad) + titleH + std::int32_t(std::ceil(z.font * 0.6)), barW,
             barH};
    return k;
}

void drawKey(cairo_t* cr, const Annotation& a, const KeyLayout& k, const Sizes& z) {
    panel(cr, k.panel);
    cairo_set_source_rgb(cr, kInk, kInk, kInk);
    textAt(cr, k.panel.x + z.pad, k.panel.y + z.pad + z.font * 0.7, k.title);
    // The bar itself is written pixel-exact after Cairo (annotateImage); here its frame.
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, k.bar.x - 0.5, k.bar.y - 0.5, k.bar.width + 1, k.bar.height + 1);
    cairo_stroke(cr);
    const double range = a.keyMaxZ - a.keyMinZ;
    const double tick = std::round(4 * z.scale);
    for (double v : k.ticks) {
        const double t = range > 0 ? (v - a.keyMinZ) / range : 0.5;
        const double y = k.bar.y + (1 - t) * k.bar.height;
        cairo_move_to(cr, k.bar.x + k.bar.width, y);
        cairo_line_to(cr, k.bar.x + k.bar.width + tick, y);
        cairo_stroke(cr);
        textAt(cr, k.bar.x + k.bar.width + tick + 3 * z.scale, y, formatHeight(v));
    }
}

struct ScaleLayout {
    PixelRect panel;
    double metres = 0;
    std::int32_t pixels = 0;
    std::string label, note;
};

ScaleLayout layoutScale(cairo_t* cr, const Annotation& a, const PixelRect& area, const Sizes& z) {
    ScaleLayout s;
    const double target = 0.22 * area.width;
    s.metres = niceFloor(target * a.metresPerPixel);
    s.pixels = std::int32_t(std::lround(s.metres / a.metresPerPixel));
    s.label = formatMetres(s.metres);
    s.note = a.scaleExact ? "" : "at image centre";
    const double inner = std::max({double(s.pixels) + textWidth(cr, s.label) / 2,
                                   textWidth(cr, s.note), textWidth(cr, "0") + 1});
    const std::int32_t pw = std::int32_t(std::ceil(inner + 2 * z.pad));
    const double lines = s.note.empty() ? 1.0 : 2.0;
    const std::int32_t ph = std::int32_t(std::ceil(2 * z.pad + lines * z.font * 1.3 + 6 * z.scale));
    s.panel = {area.x + std::int32_t(z.pad), area.y + area.height - std::int32_t(z.pad) - ph, pw,
               ph};
    return s;
}

void drawScale(cairo_t* cr, const ScaleLayout& s, const Sizes& z) {
    panel(cr, s.panel);
    const double x0 = s.panel.x + z.pad;
    const double labelY = s.panel.y + z.pad + z.font * 0.65;
    const double barY = labelY + z.font * 0.65 + 1;
    const double barH = std::round(5 * z.scale);
    // Two halves, black and white, framed: readable on any background.
    const double half = s.pixels / 2.0;
    cairo_set_source_rgb(cr, kInk, kInk, kInk);
    cairo_rectangle(cr, x0, barY, half, barH);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_rectangle(cr, x0 + half, barY, half, barH);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, kInk, kInk, kInk);
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, x0, barY, s.pixels, barH);
    cairo_stroke(cr);
    textAt(cr, x0 - textWidth(cr, "0") / 2, labelY, "0");
    textAt(cr, x0 + s.pixels - textWidth(cr, s.label) / 2, labelY, s.label);
    if (!s.note.empty()) textAt(cr, x0, barY + barH + z.font * 0.8, s.note);
}

PixelRect layoutNorth(const PixelRect& area, const Sizes& z) {
    const std::int32_t size = std::int32_t(std::lround(52 * z.scale));
    return {area.x + std::int32_t(z.pad), area.y + std::int32_t(z.pad), size, size};
}

void drawNorth(cairo_t* cr, const Annotation& a, const PixelRect& r, const Sizes& z) {
    panel(cr, r);
    const double cx = r.x + r.width / 2.0, cy = r.y + r.height / 2.0;
    const double radius = 0.25 * r.width;
    cairo_set_source_rgb(cr, kInk, kInk, kInk);
    cairo_set_line_width(cr, std::max(1.0, 1.5 * z.scale));
    const double length = std::hypot(a.northX, a.northY);
    if (a.northAlongView != 0 || !(length > 0)) {
        // North along the view axis: a circled dot (towards the viewer) or cross (away).
        const double c = 0.6 * radius;
        cairo_arc(cr, cx, cy + 0.25 * radius, c, 0, 2 * kPi);
        cairo_stroke(cr);
        if (a.northAlongView > 0) {
            const double d = c * 0.7071;
            cairo_move_to(cr, cx - d, cy + 0.25 * radius - d);
            cairo_line_to(cr, cx + d, cy + 0.25 * radius + d);
            cairo_move_to(cr, cx + d, cy + 0.25 * radius - d);
            cairo_line_to(cr, cx - d, cy + 0.25 * radius + d);
            cairo_stroke(cr);
        } else {
            cairo_arc(cr, cx, cy + 0.25 * radius, 0.2 * c, 0, 2 * kPi);
            cairo_fill(cr);
        }
        textAt(cr, cx - textWidth(cr, "N") / 2, cy - radius, "N");
        return;
    }
    const double ux = a.northX / length, uy = a.northY / length;
    const double tipX = cx + ux * radius, tipY = cy + uy * radius;
    const double tailX = cx - ux * radius, tailY = cy - uy * radius;
    cairo_move_to(cr, tailX, tailY);
    cairo_line_to(cr, tipX - ux * radius * 0.5, tipY - uy * radius * 0.5);
    cairo_stroke(cr);
    // Arrowhead: a filled triangle at the tip.
    const double head = radius * 0.6, wing = radius * 0.35;
    cairo_move_to(cr, tipX, tipY);
    cairo_line_to(cr, tipX - ux * head - uy * wing, tipY - uy * head + ux * wing);
    cairo_line_to(cr, tipX - ux * head + uy * wing, tipY - uy * head - ux * wing);
    cairo_close_path(cr);
    cairo_fill(cr);
    const double lx = cx + ux * (radius + z.font * 0.7), ly = cy + uy * (radius + z.font * 0.7);
    textAt(cr, lx - textWidth(cr, "N") / 2, ly, "N");
}

}  // namespace

double niceFloor(double v) {
    assert(v > 0);
    const double e = std::pow(10.0, std::floor(std::log10(v) + 1e-12));
    const double m = v / e;
    return (m >= 5 ? 5 : m >= 2 ? 2 : 1) * e;
}

std::string formatMetres(double metres) {
    char buf[64];
    if (metres >= 1000)
        std::snprintf(buf, sizeof buf, "%g km", metres / 1000);
    else
        std::snprintf(buf, sizeof buf, "%g m", metres);
    return buf;
}

void setTextStyle(cairo_t* cr, double size, bool bold) {
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL,
                           bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, size);
}

Annotation annotationFor(const FrameView& view) {
    Annotation a;
    a.northArrow = true;
    if (view.grid) {
        // gridViewProjection: orthographic, north up, halfHeight metres to the top edge.
        a.scaleBar = view.gridHalfHeight > 0 && view.height > 0;
        a.metresPerPixel = 2 * view.gridHalfHeight / view.height;
        a.scaleExact = true;
        a.northX = 0;
        a.northY = -1;
        return a;
    }
    a.colourKey = true;
    a.keyMinZ = view.minZ;
    a.keyMaxZ = view.maxZ;
    const Camera& c = view.camera;
    const CameraBasis b = cameraBasis(c);
    a.northX = b.right[1];
    a.northY = -b.up[1];  // image y points down
    if (std::hypot(a.northX, a.northY) < 0.02) a.northAlongView = b.forward[1] > 0 ? 1 : -1;
    // The centre ray meets the ground plane at depth d (the ray is the view axis).
    double plane = 0.5 * (view.minZ + view.maxZ);
    if (!(c.eye[2] > plane)) plane = view.minZ;
    if (b.forward[2] < 0 && c.eye[2] > plane && view.height > 0) {
        const double d = (c.eye[2] - plane) / -b.forward[2];
        a.scaleBar = true;
        a.metresPerPixel = 2 * d * std::tan(c.fovDegrees * kDegree / 2) / view.height;
        a.scaleExact = false;
    }
    return a;
}

void drawWithCairo(std::vector<std::uint8_t>& rgba, std::uint32_t width, std::uint32_t height,
                   const std::function<void(cairo_t*)>& draw) {
    assert(rgba.size() == std::size_t(width) * height * 4);
    const int stride = cairo_format_stride_for_width(CAIRO_FORMAT_ARGB32, int(width));
    // Cairo's ARGB32: native-endian 32-bit words, premultiplied alpha.
    std::vector<std::uint32_t> before(std::size_t(stride / 4) * height);
    for (std::uint32_t y = 0; y < height; ++y) {
        for (std::uint32_t x = 0; x < width; ++x) {
            const std::uint8_t* p = &rgba[(std::size_t(y) * width + x) * 4];
            const std::uint32_t al = p[3];
            auto pre = [&](std::uint32_t c) { return (c * al + 127) / 255; };
            before[std::size_t(y) * (stride / 4) + x] =
                (al << 24) | (pre(p[0]) << 16) | (pre(p[1]) << 8) | pre(p[2]);
        }
    }
    std::vector<std::uint32_t> pixels = before;
    cairo_surface_t* surface =
        cairo_image_surface_create_for_data(reinterpret_cast<unsigned char*>(pixels.data()),
                                            CAIRO_FORMAT_ARGB32, int(width), int(height), stride);
    cairo_t* cr = cairo_create(surface);
    draw(cr);
    cairo_destroy(cr);
    cairo_surface_flush(surface);
    cairo_surface_destroy(surface);
    for (std::uint32_t y = 0; y < height; ++y) {
        for (std::uint32_t x = 0; x < width; ++x) {
            const std::size_t i = std::size_t(y) * (stride / 4) + x;
            if (pixels[i] == before[i]) continue;
            const std::uint32_t v = pixels[i], al = v >> 24;
            auto un = [&](std::uint32_t c) {
                return al == 0 ? 0u : std::min(255u, (c * 255 + al / 2) / al);
            };
            std::uint8_t* p = &rgba[(std::size_t(y) * width + x) * 4];
            p[0] = std::uint8_t(un((v >> 16) & 255));
            p[1] = std::uint8_t(un((v >> 8) & 255));
            p[2] = std::uint8_t(un(v & 255));
            p[3] = std::uint8_t(al);
        }
    }
}

void annotateImage(std::vector<std::uint8_t>& rgba, std::uint32_t width, std::uint32_t height,
                   const Annotation& a, AnnotationLayout* layoutOut) {
    AnnotationLayout layout;
    const PixelRect area =
        a.area.width > 0 ? a.area : PixelRect{0, 0, std::int32_t(width), std::int32_t(height)};
    const Sizes z = sizesFor(area);
    KeyLayout key;
    drawWithCairo(rgba, width, height, [&](cairo_t* cr) {
        setTextStyle(cr, z.font);
        ScaleLayout scale;
        PixelRect north;
        const bool drawScaleBar =
            a.scaleBar && a.metresPerPixel > 0 && std::isfinite(a.metresPerPixel);
        if (a.colourKey) {
            key = layoutKey(cr, a, area, z);
            layout.regions.push_back(key.panel);
        }
        if (drawScaleBar) {
            scale = layoutScale(cr, a, area, z);
            layout.regions.push_back(scale.panel);
            layout.scaleMetres = scale.metres;
            layout.scalePixels = scale.pixels;
        }
        if (a.northArrow) {
            north = layoutNorth(area, z);
            layout.regions.push_back(north);
            layout.northDegrees =
                a.northAlongView != 0 ? 0.0 : std::atan2(a.northX, -a.northY) / kDegree;
        }
        // Antialiased edges reach half a pixel beyond a panel: one pixel of slack, and nothing
        // outside the regions.
        for (PixelRect& r : layout.regions)
            r = clipTo(inflate(r, 1), width, height);
        for (const PixelRect& r : layout.regions)
            cairo_rectangle(cr, r.x, r.y, r.width, r.height);
        cairo_clip(cr);
        if (a.colourKey) drawKey(cr, a, key, z);
        if (drawScaleBar) drawScale(cr, scale, z);
        if (a.northArrow) drawNorth(cr, a, north, z);
    });
    if (a.colourKey) {
        // The ramp, pixel-exact: row j shows t = 1 - (j + 0.5) / height of the bar.
        const PixelRect bar = clipTo(key.bar, width, height);
        for (std::int32_t y = bar.y; y < bar.y + bar.height; ++y) {
            const double t = 1.0 - (double(y - key.bar.y) + 0.5) / key.bar.height;
            const shader::vec3 c = shader::hypsometricTint(float(t));
            for (std::int32_t x = bar.x; x < bar.x + bar.width; ++x) {
                std::uint8_t* p = &rgba[(std::size_t(y) * width + std::size_t(x)) * 4];
                p[0] = toByte(c.r);
                p[1] = toByte(c.g);
                p[2] = toByte(c.b);
                p[3] = 255;
            }
        }
        layout.keyBar = key.bar;
    }
    if (layoutOut) *layoutOut = std::move(layout);
}

std::uint32_t titleBandHeight(std::uint32_t width, std::size_t lineCount) {
    const double font = std::max(8.0, width / 48.0);
    return std::uint32_t(std::ceil(font * 0.8 + double(lineCount) * font * 1.35));
}

void drawTitleBand(std::vector<std::uint8_t>& rgba, std::uint32_t width, std::uint32_t height,
                   std::uint32_t bandHeight, const std::vector<std::string>& lines) {
    const double font = std::max(8.0, width / 48.0);
    drawWithCairo(rgba, width, height, [&](cairo_t* cr) {
        cairo_rectangle(cr, 0, 0, width, std::min(bandHeight, height));
        cairo_set_source_rgb(cr, 1, 1, 1);
        cairo_fill(cr);
        cairo_set_source_rgb(cr, kInk, kInk, kInk);
        const double margin = font * 0.5;
        for (std::size_t i = 0; i < lines.size(); ++i) {
            setTextStyle(cr, font, i == 0);
            // A line too long for the image is set smaller rather than cut off.
            const double w = textWidth(cr, lines[i]);
            if (w > width - 2 * margin) setTextStyle(cr, font * (width - 2 * margin) / w, i == 0);
            textAt(cr, margin, font * 0.4 + (double(i) + 0.5) * font * 1.35, lines[i]);
        }
    });
}

}  // namespace unilod::engine
