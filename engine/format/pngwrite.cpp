#include "pngwrite.h"

#include <png.h>

#include <cassert>

namespace unilod::format {

namespace {

void appendBytes(png_structp png, png_bytep data, png_size_t size) {
    auto* out = static_cast<std::string*>(png_get_io_ptr(png));
    out->append(reinterpret_cast<const char*>(data), size);
}

void flushNothing(png_structp) {}

// Encodes in memory, so that the file is written (and every write checked) by AtomicFile.
// Only trivially destructible locals here: libpng reports errors by longjmp.
bool encode(std::string& out, std::uint32_t width, std::uint32_t height, const std::uint8_t* rgba) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    if (!png) return false;
    png_infop info = png_create_info_struct(png);
    if (!info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, info ? &info : nullptr);
        return false;
    }
    png_set_write_fn(png, &out, appendBytes, flushNothing);
    png_set_compression_level(png, 1);
    png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (std::uint32_t y = 0; y < height; ++y)
        png_write_row(png, rgba + std::size_t(y) * width * 4);
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return true;
}

}  // namespace

bool encodePng(std::uint32_t width, std::uint32_t height, const std::vector<std::uint8_t>& rgba,
               std::string& png) {
    assert(rgba.size() == std::size_t(width) * height * 4);
    png.clear();
    return encode(png, width, height, rgba.data());
}

bool writePng(const std::string& path, std::uint32_t width, std::uint32_t height,
              const std::vector<std::uint8_t>& rgba, const OutputOptions& output,
              std::string& error) {
    std::string bytes;
    if (!encodePng(width, height, rgba, bytes)) {
        error = path + ": cannot encode the PNG";
        return false;
    }
    return writeFileAtomically(path, bytes, output, error);
}

}  // namespace unilod::format
