// image.cpp: PNG output (stb_image_write), written atomically.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
#include "image.h"
#include <sys/stat.h>
#include <algorithm>
#include <unistd.h>
#include <cerrno>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <functional>
#include <vector>
#include "error.h"
#include "output_files.h"

namespace ctlab {

unsigned char to_byte(float value) {
    // Clamp in float first: casting 256.0f (or NaN) to a byte is undefined behaviour. Without
    // branches (max and min), so that a picture's loop over its pixels has none; 1 rounds
    // to 255.5, cut to 255.
    const float above = value > 0.0f ? value : 0.0f;  // NaN is no more than 0
    const float clamped = above < 1.0f ? above : 1.0f;
    return static_cast<unsigned char>(clamped * 255.0f + 0.5f);
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
// Eight bytes a step through eight tables ("slicing by 8"): table[0] is the classic bytewise
// one, table[t][n] is byte n followed by t zero bytes. A ray picture is ~0.7 MB: bytewise,
// its CRC was the largest share of a --debug-pixel run's time.
static uint32_t crc32_of(const unsigned char* data, size_t size, uint32_t crc = 0) {
    using Tables = std::array<std::array<uint32_t, 256>, 8>;
    static const Tables table = [] {
        Tables t{};
        for (uint32_t n = 0; n < 256; ++n) {
            uint32_t c = n;
            for (int bit = 0; bit < 8; ++bit) c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
            t[0][n] = c;
        }
        for (uint32_t n = 0; n < 256; ++n) {
            for (size_t k = 1; k < t.size(); ++k) {
                t[k][n] = t[0][t[k - 1][n] & 255] ^ (t[k - 1][n] >> 8);
            }
        }
        return t;
    }();
    crc = ~crc;
    size_t n = 0;
    for (; n + 8 <= size; n += 8) {  // the bytes in order, whatever the machine's byte order
        const uint32_t low = crc ^ (uint32_t(data[n]) | uint32_t(data[n + 1]) << 8 |
                                    uint32_t(data[n + 2]) << 16 | uint32_t(data[n + 3]) << 24);
        crc = table[7][low & 255] ^ table[6][(low >> 8) & 255] ^ table[5][(low >> 16) & 255] ^
              table[4][low >> 24] ^ table[3][data[n + 4]] ^ table[2][data[n + 5]] ^
              table[1][data[n + 6]] ^ table[0][data[n + 7]];
    }
    for (; n < size; ++n) crc = table[0][(crc ^ data[n]) & 255] ^ (crc >> 8);
    return ~crc;
}

static void put_u32(unsigned char* out, uint32_t value) {  // big-endian
    for (int n = 0; n < 4; ++n) out[n] = (value >> (24 - 8 * n)) & 255;
}

// Adler-32 (zlib's checksum of the uncompressed stream), fed in pieces.
class Adler32 {
public:
    void add(const unsigned char* bytes, size_t count) {
        while (count > 0) {
            const size_t run = std::min(count, adler_run - since_reduced_);
            size_t n = 0;
            // 16 bytes x0..x15 at a time: a grows by their sum, b by 16 a + sum (16 - i) xi,
            // what the loop below adds byte by byte (a sum the compiler can vectorise).
            for (; n + 16 <= run; n += 16) {
                uint32_t sum_x = 0, weighted = 0;
                for (uint32_t i = 0; i < 16; ++i) {
                    sum_x += bytes[n + i];
                    weighted += (16 - i) * bytes[n + i];
                }
                b_ += 16 * a_ + weighted;
                a_ += sum_x;
            }
            for (; n < run; ++n) {
                a_ += bytes[n];
                b_ += a_;
            }
            bytes += run;
            count -= run;
            since_reduced_ += run;
            if (since_reduced_ == adler_run) {
                a_ %= adler_base;
                b_ %= adler_base;
                since_reduced_ = 0;
            }
        }
    }
    uint32_t value() const { return (b_ % adler_base) << 16 | (a_ % adler_base); }

private:
    // The sums are reduced once per 5552 bytes at the most, the longest run that cannot
    // overflow 32 bits (zlib's NMAX).
    static constexpr uint32_t adler_base = 65521;
    static constexpr size_t adler_run = 5552;
    uint32_t a_ = 1, b_ = 0;
    size_t since_reduced_ = 0;
};

// Writes `image` to `file` as an 8-bit RGB PNG whose rows are stored, a row at a time through
// one small buffer: a ray picture (~0.7 MB) is never held whole as bytes, nor twice (its
// pages, faulted in and unmapped per picture, were as costly as its checksums).
static bool write_stored_png(const Image& image, std::FILE* file) {
    const int width = image.width, height = image.height;
    const size_t row_bytes = size_t(width) * 3;
    const size_t rows_size = (row_bytes + 1) * size_t(height);  // a filter byte 0 (none) a row
    constexpr size_t max_block = 65535;  // a stored block's largest length
    const size_t blocks = std::max<size_t>(1, (rows_size + max_block - 1) / max_block);
    const size_t zlib_size = 2 + 5 * blocks + rows_size + 4;
    constexpr unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    bool written = std::fwrite(signature, 1, sizeof signature, file) == sizeof signature;

    // A chunk's length, then its type and data, which its CRC covers.
    unsigned char header[8 + 13 + 4];
    put_u32(header, 13);
    std::memcpy(header + 4, "IHDR", 4);
    put_u32(header + 8, uint32_t(width));
    put_u32(header + 12, uint32_t(height));
    const unsigned char rest[5] = {8, 2, 0, 0, 0};  // 8 bits, RGB, deflate, filters, no interlace
    std::memcpy(header + 16, rest, sizeof rest);
    put_u32(header + 21, crc32_of(header + 4, 4 + 13));
    written = written && std::fwrite(header, 1, sizeof header, file) == sizeof header;

    unsigned char idat[8];
    put_u32(idat, uint32_t(zlib_size));
    std::memcpy(idat + 4, "IDAT", 4);
    written = written && std::fwrite(idat, 1, sizeof idat, file) == sizeof idat;
    uint32_t crc = crc32_of(idat + 4, 4);

    // The IDAT data through `buffer`: its CRC taken and written each time it fills.
    constexpr size_t buffer_size = 64 * 1024;
    std::vector<unsigned char> buffer(buffer_size);
    size_t used = 0;
    auto flush = [&] {
        crc = crc32_of(buffer.data(), used, crc);
        written = written && std::fwrite(buffer.data(), 1, used, file) == used;
        used = 0;
    };
    auto emit = [&](const unsigned char* bytes, size_t count) {
        while (count > 0) {
            if (used == buffer_size) flush();
            const size_t part = std::min(count, buffer_size - used);
            std::memcpy(buffer.data() + used, bytes, part);
            used += part;
            bytes += part;
            count -= part;
        }
    };
    const unsigned char zlib_header[2] = {0x78, 0x01};  // deflate, 32 KiB window; fastest
    emit(zlib_header, sizeof zlib_header);

    // Stored blocks of up to max_block bytes of the row stream, cut wherever they fall.
    Adler32 adler;
    size_t done = 0;  // bytes of the row stream written
    size_t block_left = 0;
    auto put = [&](const unsigned char* bytes, size_t count) {
        adler.add(bytes, count);
        while (count > 0) {
            if (block_left == 0) {
                const size_t length = std::min(max_block, rows_size - done);
                const unsigned char block[5] = {
                    static_cast<unsigned char>(done + length == rows_size),  // BFINAL, stored
                    static_cast<unsigned char>(length & 255),
                    static_cast<unsigned char>(length >> 8),
                    static_cast<unsigned char>(~length & 255),
                    static_cast<unsigned char>((~length >> 8) & 255)};
                emit(block, sizeof block);
                block_left = length;
            }
            const size_t part = std::min(count, block_left);
            emit(bytes, part);
            bytes += part;
            count -= part;
            block_left -= part;
            done += part;
        }
    };
    std::vector<unsigned char> row(row_bytes + 1, 0);  // the filter byte 0, then the pixels
    // A ray picture is mostly runs of one colour (its background, a curve's fill): a pixel
    // with the bits of the one before it gets its bytes without converting them again.
    Rgb last{};
    unsigned char last_bytes[3] = {0, 0, 0};
    bool have_last = false;
    for (int y = 0; y < height; ++y) {
        const Rgb* pixel = &image.pixels[size_t(y) * size_t(width)];
        unsigned char* byte = row.data() + 1;
        for (int x = 0; x < width; ++x, ++pixel, byte += 3) {
            if (!have_last || std::memcmp(pixel, &last, sizeof last) != 0) {
                last = *pixel;
                last_bytes[0] = to_byte(pixel->r);
                last_bytes[1] = to_byte(pixel->g);
                last_bytes[2] = to_byte(pixel->b);
                have_last = true;
            }
            byte[0] = last_bytes[0];
            byte[1] = last_bytes[1];
            byte[2] = last_bytes[2];
        }
        put(row.data(), row.size());
    }
    if (rows_size == 0) {  // no rows: one empty final block
        const unsigned char empty[5] = {1, 0, 0, 0xff, 0xff};
        emit(empty, sizeof empty);
    }
    unsigned char checksum[4];
    put_u32(checksum, adler.value());
    emit(checksum, sizeof checksum);
    flush();
    unsigned char end[4 + 12];  // the IDAT's CRC, then IEND
    put_u32(end, crc);
    put_u32(end + 4, 0);
    std::memcpy(end + 8, "IEND", 4);
    put_u32(end + 12, crc32_of(end + 8, 4));
    return written && std::fwrite(end, 1, sizeof end, file) == sizeof end;
}

void write_png(const Image& image, const std::string& path, int compression) {
    // Through a temporary renamed into place: the PNG appears whole or not at all (and, during
    // a step's run, only together with the other views: see output_files.h).
    if (compression == stored_png_compression) {
        write_output_file(path, [&](std::FILE* file) { return write_stored_png(image, file); });
        return;
    }
    std::vector<unsigned char> bytes(static_cast<size_t>(image.width) * image.height * 3);
    unsigned char* byte = bytes.data();
    for (const Rgb& pixel : image.pixels) {
        *byte++ = to_byte(pixel.r);
        *byte++ = to_byte(pixel.g);
        *byte++ = to_byte(pixel.b);
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

Image scaled_difference(const Image& a, const Image& b, float scale, double* largest) {
    Image difference(a.width, a.height);
    *largest = 0;
    for (size_t n = 0; n < a.pixels.size(); ++n) {
        const Rgb& p = a.pixels[n];
        const Rgb& q = b.pixels[n];
        const Rgb d = {std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b)};
        *largest = std::max({*largest, double(d.r), double(d.g), double(d.b)});
        difference.pixels[n] = {scale * d.r, scale * d.g, scale * d.b};
    }
    return difference;
}

}  // namespace ctlab
