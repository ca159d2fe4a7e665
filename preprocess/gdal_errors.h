// Small helpers shared by the GDAL/OGR loaders: GDAL reports failures through a global error
// handler that prints to stderr by default. The loaders return errors to their caller instead
// (STYLE.md "Errors in three tiers"), so they silence the handler while they run and pick up the
// last message to put into their own error text.
#pragma once

#include <cpl_error.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal.h>

#include <cctype>
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

// For a path GDAL could not open that is an archive (.zip, .tar, .tgz, .tar.gz): how to name
// what is inside it, "; it is an archive: give ... '/vsizip/a.zip/member' (its files: ...)";
// "" for any other path. GDAL reads archive members through /vsizip/ and /vsitar/ names only.
inline std::string archiveHint(const std::string& path) {
    const auto lower = [](std::string text) {
        for (char& ch : text)
            ch = char(std::tolower(static_cast<unsigned char>(ch)));
        return text;
    };
    const auto endsWith = [&](const std::string& tail) {
        return path.size() >= tail.size() && lower(path.substr(path.size() - tail.size())) == tail;
    };
    std::string prefix;
    if (endsWith(".zip")) {
        prefix = "/vsizip/";
    } else if (endsWith(".tar") || endsWith(".tgz") || endsWith(".tar.gz")) {
        prefix = "/vsitar/";
    } else {
        return "";
    }
    const std::string archive = prefix + path;
    std::vector<std::string> members;
    if (char** list = VSIReadDirRecursive(archive.c_str())) {
        for (char** item = list; *item != nullptr; ++item) {
            const std::string name = *item;
            if (!name.empty() && name.back() != '/') members.push_back(archive + "/" + name);
        }
        CSLDestroy(list);
    }
    if (members.empty()) return "; it is an archive GDAL cannot list";
    // The example: the first file that is not a sidecar of another (a shapefile's .dbf...).
    std::string example = members.front();
    for (const std::string& m : members) {
        const std::size_t dot = m.rfind('.');
        const std::string ext = lower(dot == std::string::npos ? "" : m.substr(dot));
        if (ext != ".dbf" && ext != ".shx" && ext != ".prj" && ext != ".cpg" && ext != ".xml" &&
            ext != ".ovr" && ext != ".tfw" && ext != ".qix" && ext != ".sbn" && ext != ".sbx") {
            example = m;
            break;
        }
    }
    return "; it is an archive: give the file inside it by a name such as '" + example +
           "' (its files: " + quotedNames(members) + ")";
}

}  // namespace unilod
