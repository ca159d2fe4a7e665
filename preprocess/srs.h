// One parser for every CRS text a user or a file gives us (--t-srs, --s-srs, the CRS a .ulod
// header records): GDAL's SetFromUserInput with its documented limitations, no file and no
// network access. Without them the text may name a file, which GDAL opens and reads: a FIFO or a
// device there blocks or never ends (DEVELOPERS.md: no option value or file content may hang).
// EPSG codes, WKT, PROJJSON and PROJ strings are read as before.
#pragma once

#include <ogr_spatialref.h>

#include <string>

namespace unilod {

// False when GDAL cannot read `text` as a CRS (then `srs` is unspecified).
inline bool parseSrs(const std::string& text, OGRSpatialReference& srs) {
    if (text.find('\0') != std::string::npos) return false;  // GDAL would read a prefix
    return srs.SetFromUserInput(text.c_str(),
                                OGRSpatialReference::SET_FROM_USER_INPUT_LIMITATIONS_get()) ==
           OGRERR_NONE;
}

}  // namespace unilod
