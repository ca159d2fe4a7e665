#include "pngwrite.h"

#include <png.h>

#include <cassert>
#include <cstdio>
#include <filesystem>

namespace unilod::engine {

namespace {

// Only trivially destructible locals here: libpng reports errors by longjmp.
bool encode(std::FILE* file, std::uint32_t width, std::uint32_t height, const std::uint8_t* rgba) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    if (!png) return false;
    png_infop info = png_create_info_struct(png);
    if (!info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, info ? &info : nullptr);
        return false;
    }
    png_init_io(png, file);
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

bool writePng(const std::string& path, std::uint32_t width, std::uint32_t height,
              const std::vector<std::uint8_t>& rgba, std::string& error) {
    assert(rgba.size() == std::size_t(width) * height * 4);
    const std::string temp = path + ".tmp";
    std::FILE* file = std::fopen(temp.c_str(), "wb");
    if (!file) {
        error = temp + ": cannot create";
        return false;
    }
    const bool encoded = encode(file, width, height, rgba.data());
    const bool closed = std::fclose(file) == 0;
    std::error_code ec;
    if (!encoded || !closed) {
        std::filesystem::remove(temp, ec);
        error = path + ": cannot write PNG";
        return false;
    }
    std::filesystem::rename(temp, path, ec);
    if (ec) {
        std::filesystem::remove(temp, ec);
        error = path + ": cannot move into place";
        return false;
    }
    return true;
}

}  // namespace unilod::engine
