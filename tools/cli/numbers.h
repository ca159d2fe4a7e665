// Checks for the numeric options of every command: the value must be the whole text of a finite
// number (nan, inf and out-of-range text such as 1e999 are refused) inside the option's interval.
// Messages print the bounds as a person would write them (CLI11's own PositiveNumber printed
// DBL_MAX with 309 digits and let nan through).
#pragma once

#include <CLI/CLI.hpp>
#include <limits>
#include <string>
#include <vector>

namespace unilod::cli {

// The whole of `text` as a finite double (leading/trailing spaces refused too).
bool parseFinite(const std::string& text, double& value);

// The items of a comma-separated option value with the empty ones kept ("1,,2" gives "1", "",
// "2"; "" one empty item), so that the option's check can refuse them: CLI11's ->delimiter(',')
// drops them silently.
std::vector<std::string> splitList(const std::string& text);

enum class Bound { Closed, Open };

// A finite number in [lo, hi] (or open at either end); `hi` may be +infinity (no upper bound).
CLI::Validator numberIn(double lo, double hi, Bound loBound = Bound::Closed,
                        Bound hiBound = Bound::Closed);
inline CLI::Validator positive() {
    return numberIn(0, std::numeric_limits<double>::infinity(), Bound::Open);
}
inline CLI::Validator nonNegative() {
    return numberIn(0, std::numeric_limits<double>::infinity());
}
inline CLI::Validator finite() {
    return numberIn(-std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity());
}

}  // namespace unilod::cli
