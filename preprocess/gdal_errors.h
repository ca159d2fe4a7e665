// Small helpers shared by the GDAL/OGR loaders: GDAL reports failures through a global error
// handler that prints to stderr by default. The loaders return errors to their caller instead
// (STYLE.md "Errors in three tiers"), so they silence the handler while they run and pick up the
// last message to put into their own error text.
#pragma once

#include <cpl_error.h>
#include <gdal.h>

#include <string>
#include <vector>

namespace unilod {

// RAII: GDAL/OGR errors raised while this lives are recorded but not printed.
class QuietGdalErrors {
public:
    QuietGdalErrors() {
        GDALAllRegister();  // idempotent; the loaders may be the first GDAL users in a program
        CPLPushErrorHandler(CPLQuietErrorHandler);
        CPLErrorReset();
    }
    ~QuietGdalErrors() { CPLPopErrorHandler(); }
    QuietGdalErrors(const QuietGdalErrors&) = delete;
    QuietGdalErrors& operator=(const QuietGdalErrors&) = delete;
};

// The last GDAL error message as ": message", or "" when there is none.
inline std::string gdalErrorSuffix() {
    const char* msg = CPLGetLastErrorMsg();
    if (msg == nullptr || msg[0] == '\0') return "";
    return std::string(": ") + msg;
}

// Names for a message, each quoted: "'a', 'b', 'c'", the first `most` and ", ..." for more
// (the subdatasets of a container, the line layers of a vector file).
inline std::string quotedNames(const std::vector<std::string>& names, std::size_t most = 8) {
    std::string list;
    for (std::size_t i = 0; i < names.size() && i < most; ++i)
        list += (i == 0 ? "'" : ", '") + names[i] + "'";
    if (names.size() > most) list += ", ...";
    return list;
}

}  // namespace unilod
