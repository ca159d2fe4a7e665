#include "campath.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "atomicfile.h"
#include "jsontext.h"

namespace unilod::engine {

namespace {

bool finiteJson(const nlohmann::json& j) {
    return j.is_number() && std::isfinite(j.get<double>());
}

}  // namespace

bool validCamera(const Camera& c) {
    for (double v : c.eye)
        if (!std::isfinite(v)) return false;
    return std::isfinite(c.yawDegrees) && std::isfinite(c.pitchDegrees) && c.pitchDegrees >= -90 &&
           c.pitchDegrees <= 90 && c.fovDegrees > 0 && c.fovDegrees < 180;
}

bool loadCameraPath(const std::string& path, CameraPath& out, std::string& error) {
    if (std::string why; !format::checkInputFile(path, false, why)) {
        error = path + ": " + why;
        return false;
    }
    errno = 0;
    std::ifstream in(path, std::ios::binary);
    const int openErrno = errno;  // why the open failed (no such file, permission denied)
    std::stringstream text;
    if (in) text << in.rdbuf();
    if (!in || in.bad()) {
        error = path + ": cannot read the camera path";
        if (!in.is_open() && openErrno != 0) error += std::string(": ") + std::strerror(openErrno);
        return false;
    }
    nlohmann::json j;
    if (!parseJson(text.str(), j, error)) {
        error = path + ": " + error;
        return false;
    }
    if (!j.is_object()) {
        error = path + ": not a JSON object";
        return false;
    }
    double fov = 60;
    if (j.contains("fov")) {
        if (!finiteJson(j["fov"])) {
            error = path + ": \"fov\" is not a number";
            return false;
        }
        fov = j["fov"].get<double>();
    }
    if (!j.contains("keyframes") || !j["keyframes"].is_array() || j["keyframes"].empty()) {
        error = path + ": needs a non-empty \"keyframes\" array";
        return false;
    }
    out.keyframes.clear();
    for (std::size_t i = 0; i < j["keyframes"].size(); ++i) {
        const nlohmann::json& k = j["keyframes"][i];
        const std::string where = path + ": keyframe " + std::to_string(i);
        if (!k.is_object() || !k.contains("eye") || !k["eye"].is_array() || k["eye"].size() != 3 ||
            !k.contains("yaw") || !k.contains("pitch")) {
            error = where + ": needs \"eye\": [x, y, z], \"yaw\" and \"pitch\"";
            return false;
        }
        Camera c;
        c.fovDegrees = fov;
        bool finite = finiteJson(k["yaw"]) && finiteJson(k["pitch"]);
        for (int e = 0; e < 3; ++e)
            finite = finite && finiteJson(k["eye"][std::size_t(e)]);
        if (!finite) {
            error = where + ": a value is not a finite number";
            return false;
        }
        for (int e = 0; e < 3; ++e)
            c.eye[e] = k["eye"][std::size_t(e)].get<double>();
        c.yawDegrees = k["yaw"].get<double>();
        c.pitchDegrees = k["pitch"].get<double>();
        if (!validCamera(c)) {
            error = where + ": pitch must be in [-90, 90] and fov in (0, 180)";
            return false;
        }
        out.keyframes.push_back(c);
    }
    return true;
}

std::vector<Camera> sampleCameraPath(const CameraPath& path, std::uint32_t frames) {
    std::vector<Camera> out;
    const std::size_t k = path.keyframes.size();
    for (std::uint32_t i = 0; i < frames; ++i) {
        if (k == 1 || frames == 1) {
            out.push_back(path.keyframes[0]);
            continue;
        }
        const double t = double(i) * double(k - 1) / double(frames - 1);
        const std::size_t a = std::min(std::size_t(t), k - 2);
        const double u = t - double(a);
        const Camera& p = path.keyframes[a];
        const Camera& q = path.keyframes[a + 1];
        Camera c = p;
        for (int e = 0; e < 3; ++e)
            c.eye[e] = p.eye[e] + u * (q.eye[e] - p.eye[e]);
        const double dyaw = std::remainder(q.yawDegrees - p.yawDegrees, 360.0);
        c.yawDegrees = p.yawDegrees + u * dyaw;
        c.pitchDegrees = p.pitchDegrees + u * (q.pitchDegrees - p.pitchDegrees);
        out.push_back(c);
    }
    return out;
}

CameraPath defaultFlyOver(const format::Header& h) {
    const double w = std::max(h.maxX - h.minX, h.maxY - h.minY);
    CameraPath p;
    Camera a, b;
    a.eye[0] = h.minX + 0.1 * (h.maxX - h.minX);
    a.eye[1] = h.minY + 0.1 * (h.maxY - h.minY);
    b.eye[0] = h.minX + 0.9 * (h.maxX - h.minX);
    b.eye[1] = h.minY + 0.9 * (h.maxY - h.minY);
    a.eye[2] = b.eye[2] = h.maxZ + 0.2 * w;
    a.yawDegrees = b.yawDegrees = 45;
    a.pitchDegrees = b.pitchDegrees = -25;
    p.keyframes = {a, b};
    return p;
}

Camera defaultOverview(const format::Header& h) {
    const double cx = (h.minX + h.maxX) / 2, cy = (h.minY + h.maxY) / 2, cz = (h.minZ + h.maxZ) / 2;
    const double dx = h.maxX - h.minX, dy = h.maxY - h.minY, dz = h.maxZ - h.minZ;
    const double radius = 0.5 * std::sqrt(dx * dx + dy * dy + dz * dz);
    Camera c;
    c.fovDegrees = 60;
    // The bounding sphere would fit the vertical field of view at 1 / sin(fov / 2); a flat model
    // seen from 35 degrees fills less, so 0.8 of that still leaves a margin (tests/engine
    // test_capture: every image corner is background).
    const double distance =
        0.8 * std::max(radius, 1.0) / std::sin(c.fovDegrees * std::numbers::pi / 360);
    const double elevation = 35 * std::numbers::pi / 180;
    c.eye[0] = cx;
    c.eye[1] = cy - distance * std::cos(elevation);
    c.eye[2] = cz + distance * std::sin(elevation);
    c.yawDegrees = 0;
    c.pitchDegrees = -35;
    return c;
}

}  // namespace unilod::engine
