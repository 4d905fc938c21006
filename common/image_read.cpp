// image_read.cpp: reads a PNG (through stb_image) or a PPM (P6 binary or P3 text, our own
// parser) into a float Image. Every problem becomes an InputError naming the file.
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG       // the checker reads PNGs; the other stb decoders are dead weight
#define STBI_NO_STDIO       // we read the bytes ourselves, so errors name the file
#define STBI_FAILURE_USERMSG
#include <stb_image.h>
#include "image.h"
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <vector>
#include "error.h"

namespace ctlab {

namespace {

constexpr int max_image_side = 16384;  // pixels: refuse anything wider or taller, unread
// Pixels in all: refused before decoding. stb sizes its buffer from the header, so a tiny
// damaged PNG claiming 16384 x 16384 would otherwise ask for gigabytes.
constexpr long long max_image_pixels = 4096LL * 4096;
constexpr int max_ppm_maxval = 65535;  // PPM samples are 1 or 2 bytes (big-endian)

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
    throw InputError("'" + path + "': " + problem);
}

std::vector<unsigned char> read_bytes(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code error;
    const fs::file_status status = fs::status(path, error);
    if (status.type() == fs::file_type::not_found) fail(path, "no such file");
    if (error) fail(path, "cannot be read (" + error.message() + ")");
    if (fs::is_directory(status)) fail(path, "is a folder, not an image file");
    if (!fs::is_regular_file(status)) fail(path, "is not an ordinary file");  // /dev/zero...
    std::ifstream file(path, std::ios::binary);
    if (!file) fail(path, "cannot be opened for reading");
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(file)),
                                     std::istreambuf_iterator<char>());
    if (file.bad()) fail(path, "read error");
    return bytes;
}

void check_size(const std::string& path, long long width, long long height) {
    if (width < 1 || height < 1) {
        fail(path, "has an empty picture (" + std::to_string(width) + "x" +
                       std::to_string(height) + ")");
    }
    if (width > max_image_side || height > max_image_side || width * height > max_image_pixels) {
        fail(path, "is " + std::to_string(width) + "x" + std::to_string(height) +
                       " pixels: larger than the limit (" + std::to_string(max_image_side) +
                       " per side, " + std::to_string(max_image_pixels) + " in all)");
    }
}

// --- PNG -------------------------------------------------------------------------------

bool is_png(const std::vector<unsigned char>& bytes) {
    static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    return bytes.size() >= 8 && std::memcmp(bytes.data(), signature, 8) == 0;
}

// Walks the chunks (length, type, data, CRC) up to IEND: each must fit in the file. stb
// allocates what a chunk's length claims before reading it, so a damaged length in a tiny
// file would otherwise ask for gigabytes (found by `make fuzz`).
void check_png_chunks(const std::string& path, const std::vector<unsigned char>& bytes) {
    constexpr size_t signature_size = 8, chunk_overhead = 12;  // length, type, CRC
    size_t position = signature_size;
    while (position < bytes.size()) {
        if (bytes.size() - position < chunk_overhead) {
            fail(path, "is a truncated PNG (its last chunk is cut short)");
        }
        const unsigned char* chunk = bytes.data() + position;
        const size_t length = (size_t(chunk[0]) << 24) | (size_t(chunk[1]) << 16) |
                              (size_t(chunk[2]) << 8) | size_t(chunk[3]);
        const std::string type(reinterpret_cast<const char*>(chunk + 4), 4);
        const size_t left = bytes.size() - position - chunk_overhead;
        if (length > left) {
            fail(path, "is a damaged or truncated PNG (a chunk claims " + std::to_string(length) +
                           " bytes, the file has " + std::to_string(left) + " left)");
        }
        if (type == "IEND") return;
        position += chunk_overhead + length;
    }
    // No IEND: stb says what is wrong.
}

Image read_png(const std::string& path, const std::vector<unsigned char>& bytes) {
    if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
        fail(path, "is too large a file for a PNG we can read");
    }
    check_png_chunks(path, bytes);
    const int length = static_cast<int>(bytes.size());
    int width = 0, height = 0, channels = 0;
    // The header first: the size is checked before stb allocates the pixels.
    if (!stbi_info_from_memory(bytes.data(), length, &width, &height, &channels)) {
        fail(path, std::string("is not a readable PNG (") + stbi_failure_reason() + ")");
    }
    check_size(path, width, height);
    const bool sixteen_bit = stbi_is_16_bit_from_memory(bytes.data(), length) != 0;
    // Asking for 3 channels: grey becomes RGB; an alpha channel is dropped, not blended.
    constexpr int rgb = 3;
    void* data = sixteen_bit
        ? static_cast<void*>(stbi_load_16_from_memory(bytes.data(), length, &width, &height,
                                                       &channels, rgb))
        : static_cast<void*>(stbi_load_from_memory(bytes.data(), length, &width, &height,
                                                    &channels, rgb));
    if (!data) fail(path, std::string("is a damaged PNG (") + stbi_failure_reason() + ")");
    std::unique_ptr<void, void (*)(void*)> owner(data, stbi_image_free);

    Image image(width, height);
    const auto* words = static_cast<const uint16_t*>(data);
    const auto* octets = static_cast<const unsigned char*>(data);
    auto channel = [&](size_t n) {
        return sixteen_bit ? words[n] / 65535.0f : octets[n] / 255.0f;
    };
    for (size_t n = 0; n < image.pixels.size(); ++n) {
        image.pixels[n] = {channel(3 * n), channel(3 * n + 1), channel(3 * n + 2)};
    }
    return image;
}

// --- PPM -------------------------------------------------------------------------------
// "P6 W H MAXVAL" then exactly one whitespace byte and the binary samples; "P3" has the
// samples as decimal text. '#' starts a comment up to the end of the line.

class PpmReader {
public:
    PpmReader(const std::string& path, const std::vector<unsigned char>& bytes)
        : path_(path), bytes_(bytes) {}

    Image read() {
        const bool binary = bytes_[1] == '6';
        position_ = 2;
        if (!at_end() && !is_space(bytes_[position_])) {
            fail(path_, "is not a PPM image (bad magic number)");
        }
        const long long width = number("width", max_image_side);
        const long long height = number("height", max_image_side);
        check_size(path_, width, height);
        maxval_ = number("maxval", max_ppm_maxval);
        if (maxval_ < 1) fail(path_, "has maxval 0 (expected 1..65535)");
        const size_t samples = static_cast<size_t>(width * height * 3);
        if (binary) {
            // Exactly one whitespace byte separates maxval from the raster (no comment).
            if (at_end()) fail(path_, "is truncated: no pixel data after the header");
            ++position_;
            check_available(samples * (maxval_ > 255 ? 2 : 1), "bytes of pixel data");
        } else {
            // Cheap early check: every sample needs a digit and a separator (the last one
            // may end the file).
            check_available(2 * samples - 1, "bytes for the text samples");
        }
        // Only now, with the data known to be there, the picture is allocated.
        Image image(static_cast<int>(width), static_cast<int>(height));
        if (binary) {
            read_binary(image);
        } else {
            read_text(image);
        }
        return image;
    }

private:
    static bool is_space(unsigned char c) {
        return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
    }
    bool at_end() const { return position_ >= bytes_.size(); }

    void skip_space_and_comments() {
        while (!at_end()) {
            if (is_space(bytes_[position_])) {
                ++position_;
            } else if (bytes_[position_] == '#') {
                while (!at_end() && bytes_[position_] != '\n' && bytes_[position_] != '\r') {
                    ++position_;
                }
            } else {
                return;
            }
        }
    }

    // A decimal number in [0, limit]; `what` names it in the error.
    long long number(const std::string& what, long long limit) {
        skip_space_and_comments();
        if (at_end()) fail(path_, "is truncated: expected the " + what);
        if (bytes_[position_] < '0' || bytes_[position_] > '9') {
            fail(path_, "has a bad PPM " + what + " (expected a decimal number)");
        }
        long long value = 0;
        while (!at_end() && bytes_[position_] >= '0' && bytes_[position_] <= '9') {
            value = value * 10 + (bytes_[position_] - '0');
            if (value > limit) {
                fail(path_, "has a PPM " + what + " above " + std::to_string(limit));
            }
            ++position_;
        }
        if (!at_end() && !is_space(bytes_[position_]) && bytes_[position_] != '#') {
            fail(path_, "has a bad PPM " + what + " (expected a decimal number)");
        }
        return value;
    }

    float sample(long long value) const {
        if (value > maxval_) {
            fail(path_, "has a sample " + std::to_string(value) + " above its maxval " +
                            std::to_string(maxval_));
        }
        return static_cast<float>(static_cast<double>(value) / maxval_);
    }

    // At least `needed` bytes after the header, else the file is truncated.
    void check_available(size_t needed, const std::string& what) const {
        const size_t available = bytes_.size() - position_;
        if (available < needed) {
            fail(path_, "is truncated: " + std::to_string(available) + " " + what +
                            ", expected at least " + std::to_string(needed));
        }
    }

    void read_binary(Image& image) {
        const size_t bytes_per_sample = maxval_ > 255 ? 2 : 1;
        const unsigned char* data = bytes_.data() + position_;
        auto next = [&]() -> long long {
            long long value = *data++;
            if (bytes_per_sample == 2) value = value * 256 + *data++;  // big-endian
            return value;
        };
        for (Rgb& pixel : image.pixels) {
            pixel.r = sample(next());
            pixel.g = sample(next());
            pixel.b = sample(next());
        }
    }

    void read_text(Image& image) {
        for (Rgb& pixel : image.pixels) {
            pixel.r = sample(number("sample", max_ppm_maxval));
            pixel.g = sample(number("sample", max_ppm_maxval));
            pixel.b = sample(number("sample", max_ppm_maxval));
        }
    }

    const std::string& path_;
    const std::vector<unsigned char>& bytes_;
    size_t position_ = 0;
    long long maxval_ = 255;
};

bool is_ppm(const std::vector<unsigned char>& bytes) {
    return bytes.size() >= 2 && bytes[0] == 'P' && (bytes[1] == '6' || bytes[1] == '3');
}

}  // namespace

Image read_image_bytes(const std::vector<unsigned char>& bytes, const std::string& name) {
    if (bytes.empty()) fail(name, "is empty (0 bytes), not an image");
    if (is_png(bytes)) return read_png(name, bytes);
    if (is_ppm(bytes)) return PpmReader(name, bytes).read();
    fail(name, "is not a PNG or PPM (P6/P3) image");
}

Image read_image(const std::string& path) { return read_image_bytes(read_bytes(path), path); }

}  // namespace ctlab
