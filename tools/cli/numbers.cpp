#include "numbers.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "numtext.h"
#include "stats.h"

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
    return format::parseFiniteNumber(text, value);
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

namespace {

// A check of a number read by `parse` (false: not `what`) in [lo, hi] (or open at either end),
// the bounds printed with `unit`.
CLI::Validator rangeCheck(bool (*parse)(const std::string&, double&), const std::string& what,
                          const std::string& name, const std::string& unit, double lo, double hi,
                          Bound loBound, Bound hiBound) {
    std::string interval;  // for --help
    if (std::isinf(lo) && std::isinf(hi))
        interval = "";
    else if (std::isinf(hi))
        interval = std::string(loBound == Bound::Open ? "> " : ">= ") + show(lo);
    else
        interval = std::string(loBound == Bound::Open ? "(" : "[") + show(lo) + ", " + show(hi) +
                   (hiBound == Bound::Open ? ")" : "]");
    if (!interval.empty()) interval += unit;
    const std::string requirement =
        interval.empty() || interval[0] == '>' ? interval : "in " + interval;
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            double v = 0;
            if (!parse(text, v)) return "'" + text + "' is not " + what;
            const bool low = loBound == Bound::Open ? !(v > lo) : !(v >= lo);
            const bool high = hiBound == Bound::Open ? !(v < hi) : !(v <= hi);
            if (low || high) return "'" + text + "' must be " + requirement;
            return {};
        },
        interval.empty() ? name : name + " " + interval);
}

}  // namespace

CLI::Validator numberIn(double lo, double hi, Bound loBound, Bound hiBound) {
    return rangeCheck(parseFinite, "a finite number", "NUMBER", "", lo, hi, loBound, hiBound);
}

CLI::Validator integerIn(long long lo, long long hi) {
    const std::string interval = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            std::size_t i = 0;
            const bool negative = !text.empty() && text[0] == '-';
            if (!text.empty() && (text[0] == '-' || text[0] == '+')) i = 1;
            if (i == text.size()) return "'" + text + "' is not a whole number";
            // Digits only; a magnitude past the 64-bit range is out of range, not wrapped.
            unsigned long long magnitude = 0;
            bool overflow = false;
            for (; i < text.size(); ++i) {
                const char ch = text[i];
                if (ch < '0' || ch > '9')
                    return "'" + text + "' is not a whole number (decimal digits)";
                const unsigned digit = unsigned(ch - '0');
                if (magnitude > (std::numeric_limits<unsigned long long>::max() - digit) / 10)
                    overflow = true;
                else
                    magnitude = magnitude * 10 + digit;
            }
            constexpr unsigned long long kLimit = 1ull << 63;  // |LLONG_MIN|
            if (overflow || magnitude > (negative ? kLimit : kLimit - 1))
                return "'" + text + "' must be in " + interval;
            const long long value = !negative             ? static_cast<long long>(magnitude)
                                    : magnitude == kLimit ? std::numeric_limits<long long>::min()
                                                          : -static_cast<long long>(magnitude);
            if (value < lo || value > hi) return "'" + text + "' must be in " + interval;
            text = std::to_string(value);
            return {};
        },
        "INTEGER in " + interval);
}

CLI::Validator lengthIn(double lo, double hi, Bound loBound, Bound hiBound) {
    return rangeCheck(parseDistance, "a finite length (a number, m or km)", "LENGTH", " m", lo, hi,
                      loBound, hiBound);
}

CLI::Validator listOf(const CLI::Validator& item) {
    return CLI::Validator(
        [item](std::string& text) -> std::string {
            if (text.empty()) return "the list is empty";
            for (std::string value : splitList(text)) {
                if (value.empty()) return "'" + text + "' has an empty item";
                if (std::string error = item(value); !error.empty()) return error;
            }
            return {};
        },
        item.get_description() + ",...");
}

std::vector<std::string> listItems(const std::vector<std::string>& values) {
    std::vector<std::string> items;
    for (const std::string& v : values)
        for (std::string& item : splitList(v))
            items.push_back(std::move(item));
    return items;
}

std::vector<double> listNumbers(const std::vector<std::string>& values) {
    std::vector<double> numbers;
    for (const std::string& item : listItems(values)) {
        double v = 0;
        parseFinite(item, v);  // checked while parsing (listOf)
        numbers.push_back(v);
    }
    return numbers;
}

std::vector<double> listLengths(const std::vector<std::string>& values) {
    std::vector<double> lengths;
    for (const std::string& item : listItems(values)) {
        double v = 0;
        parseDistance(item, v);  // checked while parsing (listOf)
        lengths.push_back(v);
    }
    return lengths;
}

}  // namespace unilod::cli
