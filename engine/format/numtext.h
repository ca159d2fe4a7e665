// The text of a number as every option and parser of numbers reads it (tools/cli/numbers.h,
// preprocess/stats.h parseDistance): the whole text one finite decimal number. Leading spaces,
// trailing text, nan, inf, values that overflow (1e999) and hexadecimal (strtod reads "0x10"
// and "0x1p3", which no option documents) are refused. One definition, so that no option
// accepts what another refuses.
#pragma once

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <string>

namespace unilod::format {

inline bool parseFiniteNumber(const std::string& text, double& value) {
    if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
    if (text.find_first_of("xX") != std::string::npos) return false;  // hexadecimal
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    // Overflow (1e999) gives HUGE_VAL: not finite. Underflow (1e-999) gives 0 or a denormal.
    if (end == text.c_str() || *end != '\0' || !std::isfinite(v)) return false;
    value = v;
    return true;
}

}  // namespace unilod::format
