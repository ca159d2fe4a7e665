// The report's frame-time plot (report.h "Frame times"): `unilod bench`'s four runs along a
// camera path, frame time per frame, drawn with Cairo.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "annotate.h"
#include "bench.h"
#include "capture.h"
#include "report.h"
#include "ulod.h"

namespace unilod::report {

namespace {

struct RunStyle {
    const char* name;
    double r, g, b;
    const char* label;
};
// Colours the tests look for: keep them saturated and distinct from the grey axes.
constexpr RunStyle kRuns[] = {
    {"lod", 0.80, 0.15, 0.15, "lod: streamed, per-block LOD (coarse fallback until loaded)"},
    {"resident", 0.90, 0.55, 0.10, "resident: the same LOD choice, every block preloaded"},
    {"bare", 0.15, 0.60, 0.25, "bare: the same draws, no selection or streaming"},
    {"full", 0.12, 0.30, 0.80, "full: visible blocks at full resolution"},
};

const RunStyle& styleOf(const std::string& name) {
    for (const RunStyle& s : kRuns)
        if (name == s.name) return s;
    return kRuns[0];
}

}  // namespace

std::vector<engine::Camera> flyOverCameras(const format::Header& h, std::uint32_t frames) {
    const double cx = 0.5 * (h.minX + h.maxX), cy = 0.5 * (h.minY + h.maxY);
    const double spanY = h.maxY - h.minY, span = std::max(h.maxX - h.minX, spanY);
    engine::CameraPath path;
    engine::Camera a;
    a.eye[0] = cx;
    a.eye[1] = h.minY - 0.6 * spanY;
    a.eye[2] = h.maxZ + 0.4 * span;
    a.yawDegrees = 0;
    a.pitchDegrees = -30;
    engine::Camera b = a;
    b.eye[1] = cy - 0.2 * spanY;
    b.eye[2] = h.maxZ + 0.15 * span;
    path.keyframes = {a, b};
    return engine::sampleCameraPath(path, frames);
}

bool measureFrameTimes(const ReportOptions& o, FrameTimes& out, std::string& error) {
    out = {};
    engine::BenchOptions b;
    b.path = o.path;
    if (o.benchPath.empty()) {
        format::Reader reader;
        if (!reader.open(o.path, error)) return false;
        b.cameras = flyOverCameras(reader.header(), o.benchFrames);
        out.cameras = "generated fly-over";
    } else {
        engine::CameraPath path;
        if (!engine::loadCameraPath(o.benchPath, path, error)) return false;
        b.cameras = engine::sampleCameraPath(path, o.benchFrames);
        out.cameras = o.benchPath;
    }
    b.width = o.benchWidth;
    b.height = o.benchHeight;
    b.scene.pixels = o.stats.pixels.empty() ? 1.0 : o.stats.pixels.front();
    b.scene.metric = o.stats.metric == 0 ? "" : format::metricName(o.stats.metric);
    b.device = o.device;
    b.spirvDir = o.spirvDir;
    b.perFrame = true;
    b.runs = {"lod", "resident", "bare", "full"};
    nlohmann::json j;
    if (!engine::runBench(b, j, error)) return false;  // progress: the report's stage line
    // runBench's typed numbers exist only as its JSON (README "unilod bench").
    out.device = j.value("device", "");
    out.width = b.width;
    out.height = b.height;
    for (const std::string& name : b.runs) {
        if (!j["runs"].contains(name)) continue;
        const nlohmann::json& run = j["runs"][name];
        std::vector<double> ms;
        for (const nlohmann::json& f : run["per_frame"])
            ms.push_back(f["frame_ms"].get<double>());
        out.runs.push_back(name);
        out.ms.push_back(std::move(ms));
        out.medianMs.push_back(run["frame_ms"]["median"].get<double>());
        out.triangles.push_back(run["per_frame"].empty()
                                    ? 0
                                    : run["per_frame"].back()["triangles"].get<std::uint64_t>());
    }
    return true;
}

void plotFrameTimes(const FrameTimes& t, std::uint32_t width, std::uint32_t height,
                    std::vector<std::uint8_t>& rgba) {
    rgba.assign(std::size_t(width) * height * 4, 255);
    std::size_t frames = 0;
    double top = 0;
    for (const std::vector<double>& ms : t.ms) {
        frames = std::max(frames, ms.size());
        for (double v : ms)
            top = std::max(top, v);
    }
    if (!(top > 0)) top = 1;
    const double step = engine::niceFloor(top / 4);
    top = std::ceil(top * 1.05 / step) * step;
    const double left = 70, right = 20, upper = 60, bottom = 50 + 18.0 * double(t.runs.size());
    const double pw = width - left - right, ph = height - upper - bottom;
    auto X = [&](double i) { return left + (frames > 1 ? i / double(frames - 1) : 0.5) * pw; };
    auto Y = [&](double v) { return upper + ph - v / top * ph; };
    engine::drawWithCairo(rgba, width, height, [&](cairo_t* cr) {
        cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
        engine::setTextStyle(cr, 15, true);
        cairo_move_to(cr, left, 22);
        cairo_show_text(cr, "Frame time along the camera path");
        engine::setTextStyle(cr, 11);
        char sub[256];
        std::snprintf(sub, sizeof sub, "%s, %ux%u, %zu frames (%s)", t.device.c_str(), t.width,
                      t.height, frames, t.cameras.c_str());
        cairo_move_to(cr, left, 40);
        cairo_show_text(cr, sub);
        // Grid lines and tick labels.
        cairo_set_line_width(cr, 1);
        char label[64];
        for (double v = 0; v <= top + 1e-9 * top; v += step) {
            cairo_set_source_rgb(cr, 0.87, 0.87, 0.87);
            cairo_move_to(cr, left, std::round(Y(v)) + 0.5);
            cairo_line_to(cr, left + pw, std::round(Y(v)) + 0.5);
            cairo_stroke(cr);
            cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
            std::snprintf(label, sizeof label, "%g", v);
            cairo_text_extents_t e;
            cairo_text_extents(cr, label, &e);
            cairo_move_to(cr, left - 6 - e.x_advance, Y(v) + 4);
            cairo_show_text(cr, label);
        }
        const double xStep =
            frames > 1 ? std::max(1.0, engine::niceFloor(double(frames - 1) / 5)) : 1;
        for (double i = 0; i < double(frames); i += xStep) {
            std::snprintf(label, sizeof label, "%g", i);
            cairo_text_extents_t e;
            cairo_text_extents(cr, label, &e);
            cairo_move_to(cr, X(i) - e.x_advance / 2, upper + ph + 16);
            cairo_show_text(cr, label);
        }
        cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
        cairo_rectangle(cr, left + 0.5, upper + 0.5, pw, ph);
        cairo_stroke(cr);
        cairo_move_to(cr, left + pw / 2 - 40, upper + ph + 34);
        cairo_show_text(cr, "frame index");
        cairo_save(cr);
        cairo_move_to(cr, 18, upper + ph / 2 + 40);
        cairo_rotate(cr, -M_PI / 2);
        cairo_show_text(cr, "frame time (ms)");
        cairo_restore(cr);
        // One line per run, and the legend below the axes.
        cairo_set_line_width(cr, 2);
        for (std::size_t r = 0; r < t.runs.size(); ++r) {
            const RunStyle& s = styleOf(t.runs[r]);
            cairo_set_source_rgb(cr, s.r, s.g, s.b);
            const std::vector<double>& ms = t.ms[r];
            for (std::size_t i = 0; i < ms.size(); ++i) {
                if (i == 0)
                    cairo_move_to(cr, X(double(i)), Y(ms[i]));
                else
                    cairo_line_to(cr, X(double(i)), Y(ms[i]));
            }
            if (ms.size() == 1) cairo_arc(cr, X(0), Y(ms[0]), 2, 0, 2 * M_PI);
            cairo_stroke(cr);
            const double ly = upper + ph + 50 + 18.0 * double(r);
            cairo_move_to(cr, left, ly - 4);
            cairo_line_to(cr, left + 30, ly - 4);
            cairo_stroke(cr);
            cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
            char text[256];
            std::snprintf(text, sizeof text,
                          "%s (median %.2f ms, %llu triangles in the last frame)", s.label,
                          t.medianMs[r], static_cast<unsigned long long>(t.triangles[r]));
            cairo_move_to(cr, left + 38, ly);
            cairo_show_text(cr, text);
        }
    });
}

}  // namespace unilod::report
