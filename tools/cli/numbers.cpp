#include "numbers.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace unilod::cli {

namespace {

std::string show(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char text[32];
    std::snprintf(text, sizeof text, "%.6g", v);
    return text;
}

}  // namespace

bool parseFinite(const std::string& text, double& value) {
    if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    // Overflow (1e999) gives HUGE_VAL: not finite. Underflow (1e-999) gives 0 or a denormal.
    if (end == text.c_str() || *end != '\0' || !std::isfinite(v)) return false;
    value = v;
    return true;
}

std::vector<std::string> splitList(const std::string& text) {
    std::vector<std::string> items(1);
    for (const char ch : text) {
        if (ch == ',')
            items.emplace_back();
        else
            items.back() += ch;
    }
    return items;
}

CLI::Validator numberIn(double lo, double hi, Bound loBound, Bound hiBound) {
    std::string interval;  // for --help
    if (std::isinf(lo) && std::isinf(hi))
        interval = "";
    else if (std::isinf(hi))
        interval = std::string(loBound == Bound::Open ? "> " : ">= ") + show(lo);
    else
        interval = std::string(loBound == Bound::Open ? "(" : "[") + show(lo) + ", " + show(hi) +
                   (hiBound == Bound::Open ? ")" : "]");
    const std::string requirement =
        interval.empty() || interval[0] == '>' ? interval : "in " + interval;
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            double v = 0;
            if (!parseFinite(text, v)) return "'" + text + "' is not a finite number";
            const bool low = loBound == Bound::Open ? !(v > lo) : !(v >= lo);
            const bool high = hiBound == Bound::Open ? !(v < hi) : !(v <= hi);
            if (low || high) return "'" + text + "' must be " + requirement;
            return {};
        },
        interval.empty() ? "NUMBER" : "NUMBER " + interval);
}

}  // namespace unilod::cli
