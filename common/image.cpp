// image.cpp: PNG output (stb_image_write), written atomically.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
#include "image.h"
#include <sys/stat.h>
#include <unistd.h>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>
#include "error.h"
#include "output_files.h"

namespace ctlab {

unsigned char to_byte(float value) {
    // Clamp in float first: casting 256.0f (or NaN) to a byte is undefined behaviour.
    if (!(value > 0.0f)) return 0;  // also catches NaN
    if (value >= 1.0f) return 255;
    return static_cast<unsigned char>(value * 255.0f + 0.5f);
}

void make_folder(const std::string& path) {
    if (path.empty()) return;
    std::string partial;
    size_t start = 0;
    while (start <= path.size()) {
        size_t slash = path.find('/', start);
        if (slash == std::string::npos) slash = path.size();
        partial = path.substr(0, slash);
        start = slash + 1;
        if (partial.empty() || partial == ".") continue;
        struct stat info {};
        if (stat(partial.c_str(), &info) == 0) {
            if (!S_ISDIR(info.st_mode)) {
                throw InputError("cannot write to '" + path + "': '" + partial +
                                 "' is a file, not a folder");
            }
            continue;
        }
        if (mkdir(partial.c_str(), 0777) != 0 && errno != EEXIST) {
            throw InputError("cannot create folder '" + partial + "': " + std::strerror(errno));
        }
    }
}

static void write_bytes(void* context, void* data, int size) {
    std::FILE* file = static_cast<std::FILE*>(context);
    std::fwrite(data, 1, static_cast<size_t>(size), file);
}

void write_png(const Image& image, const std::string& path, int compression) {
    std::vector<unsigned char> bytes(static_cast<size_t>(image.width) * image.height * 3);
    for (size_t n = 0; n < image.pixels.size(); ++n) {
        bytes[3 * n + 0] = to_byte(image.pixels[n].r);
        bytes[3 * n + 1] = to_byte(image.pixels[n].g);
        bytes[3 * n + 2] = to_byte(image.pixels[n].b);
    }
    // Through a temporary renamed into place: the PNG appears whole or not at all (and, during
    // a step's run, only together with the other views: see output_files.h).
    stbi_write_png_compression_level = compression;
    stbi_write_force_png_filter = compression < default_png_compression ? 1 : -1;
    write_output_file(path, [&](std::FILE* file) {
        return stbi_write_png_to_func(write_bytes, file, image.width, image.height, 3,
                                      bytes.data(), image.width * 3) != 0;
    });
    stbi_write_png_compression_level = default_png_compression;
    stbi_write_force_png_filter = -1;
}

void write_pfm(const Image& image, const std::string& path) {
    const std::string header =
        "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";
    std::vector<unsigned char> bytes(header.begin(), header.end());
    bytes.reserve(header.size() + image.pixels.size() * 12);
    auto put = [&](float value) {  // little-endian whatever the machine's byte order
        uint32_t bits;
        std::memcpy(&bits, &value, sizeof bits);
        for (int shift = 0; shift < 32; shift += 8) bytes.push_back((bits >> shift) & 0xff);
    };
    for (int y = image.height - 1; y >= 0; --y) {  // PFM rows run bottom to top
        for (int x = 0; x < image.width; ++x) {
            const Rgb& p = image.at(x, y);
            put(p.r);
            put(p.g);
            put(p.b);
        }
    }
    // Like a PNG: through a temporary, renamed with the other outputs of the run.
    write_output_file(path, [&](std::FILE* file) {
        return std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
    });
}

}  // namespace ctlab
