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

// The whole of `text` as a finite double (leading/trailing spaces and hexadecimal refused too;
// engine/format/numtext.h).
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

// A whole number in [lo, hi], written in decimal digits with an optional sign: hexadecimal,
// octal (a leading 0 read as base 8 by CLI11's conversion: `--block-size 010` built 8-cell
// blocks), exponents, fractions and spaces are refused with a message naming the value. The
// accepted text is rewritten in canonical decimal ("+010" -> "10") before CLI11 converts it,
// so attach it with ->transform(integerIn(...)): ->check() would work on a copy.
CLI::Validator integerIn(long long lo, long long hi);

// A length with an optional unit, in metres (stats and report --distance, --error): "100km",
// "750m", "1500" (preprocess/stats.h parseDistance), the number read as parseFinite does; a
// value that overflows once converted (1e308km) is refused. In [lo, hi] metres.
CLI::Validator lengthIn(double lo, double hi, Bound loBound = Bound::Closed,
                        Bound hiBound = Bound::Closed);

// The largest view distance (stats and report --distance), metres: a million kilometres, far
// beyond any view of a terrain (every block is at its coarsest long before); it keeps Eq. 11 and
// the squared distances of the engine's cut finite (--distance 1e300 printed h_lim = inf).
inline constexpr double kMaxViewDistance = 1e9;

// Comma-separated list options (stats and report --distance, --pixels, --error, --budget):
// the option keeps its values as text (one per occurrence, no CLI11 delimiter, which drops empty
// items: "1,,2" was read as 1,2 and "1," as 1) and listOf(item) checks every item with `item`,
// refusing an empty one ("'1,,2' has an empty item"). listItems gives the items,
// listNumbers / listLengths their values (for lists checked with numberIn / lengthIn items).
CLI::Validator listOf(const CLI::Validator& item);
std::vector<std::string> listItems(const std::vector<std::string>& values);
std::vector<double> listNumbers(const std::vector<std::string>& values);
std::vector<double> listLengths(const std::vector<std::string>& values);

}  // namespace unilod::cli
