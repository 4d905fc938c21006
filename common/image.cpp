// image.cpp: PNG output (stb_image_write), written atomically.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
#include "image.h"
#include <sys/stat.h>
#include <algorithm>
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

// --- A PNG whose zlib stream stores the rows uncompressed (compression level 0) --------------
// stb_image_write compresses at level 5 at the least, which was most of a --debug-pixel run's
// time; a stored stream costs a copy and two checksums.

// CRC-32 of PNG chunks (ISO 3309, polynomial 0xedb88320), `crc` carried from the last call.
static uint32_t crc32_of(const unsigned char* data, size_t size, uint32_t crc = 0) {
    static const std::vector<uint32_t> table = [] {
        std::vector<uint32_t> t(256);
        for (uint32_t n = 0; n < 256; ++n) {
            uint32_t c = n;
            for (int bit = 0; bit < 8; ++bit) c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
            t[n] = c;
        }
        return t;
    }();
    crc = ~crc;
    for (size_t n = 0; n < size; ++n) crc = table[(crc ^ data[n]) & 255] ^ (crc >> 8);
    return ~crc;
}

static void put_u32(std::vector<unsigned char>& out, uint32_t value) {  // big-endian
    for (int shift = 24; shift >= 0; shift -= 8) out.push_back((value >> shift) & 255);
}

static void put_chunk(std::vector<unsigned char>& out, const char* type,
                      const std::vector<unsigned char>& data) {
    put_u32(out, uint32_t(data.size()));
    const size_t start = out.size();
    out.insert(out.end(), type, type + 4);
    out.insert(out.end(), data.begin(), data.end());
    put_u32(out, crc32_of(out.data() + start, out.size() - start));
}

// An 8-bit RGB PNG of `rgb` (rows top to bottom, 3 bytes a pixel), its rows stored.
static std::vector<unsigned char> stored_png(const unsigned char* rgb, int width, int height) {
    std::vector<unsigned char> rows;  // each row: filter byte 0 (none), then its pixels
    const size_t row_bytes = size_t(width) * 3;
    rows.reserve((row_bytes + 1) * height);
    for (int y = 0; y < height; ++y) {
        rows.push_back(0);
        rows.insert(rows.end(), rgb + y * row_bytes, rgb + (y + 1) * row_bytes);
    }
    std::vector<unsigned char> zlib = {0x78, 0x01};  // deflate, 32 KiB window, no dictionary
    constexpr size_t max_block = 65535;               // a stored block's largest length
    size_t done = 0;
    do {
        const size_t length = std::min(max_block, rows.size() - done);
        zlib.push_back(done + length == rows.size() ? 1 : 0);  // BFINAL, BTYPE 00 (stored)
        zlib.push_back(length & 255);
        zlib.push_back(length >> 8);
        zlib.push_back(~length & 255);
        zlib.push_back((~length >> 8) & 255);
        zlib.insert(zlib.end(), rows.begin() + done, rows.begin() + done + length);
        done += length;
    } while (done < rows.size());
    // Adler-32 of the rows; the sums are reduced once per 5552 bytes, the most that cannot
    // overflow 32 bits (zlib's NMAX).
    constexpr uint32_t adler_base = 65521;
    constexpr size_t adler_run = 5552;
    uint32_t a = 1, b = 0;
    for (size_t start = 0; start < rows.size(); start += adler_run) {
        const size_t end = std::min(rows.size(), start + adler_run);
        for (size_t n = start; n < end; ++n) {
            a += rows[n];
            b += a;
        }
        a %= adler_base;
        b %= adler_base;
    }
    put_u32(zlib, (b << 16) | a);

    std::vector<unsigned char> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    std::vector<unsigned char> header;
    put_u32(header, uint32_t(width));
    put_u32(header, uint32_t(height));
    header.insert(header.end(), {8, 2, 0, 0, 0});  // 8 bits, RGB, deflate, filters, no interlace
    put_chunk(png, "IHDR", header);
    put_chunk(png, "IDAT", zlib);
    put_chunk(png, "IEND", {});
    return png;
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
    if (compression == stored_png_compression) {
        const std::vector<unsigned char> png = stored_png(bytes.data(), image.width, image.height);
        write_output_file(path, [&](std::FILE* file) {
            return std::fwrite(png.data(), 1, png.size(), file) == png.size();
        });
        return;
    }
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
