// image_read.cpp: reads a PNG (through stb_image) or a PPM (P6 binary or P3 text, our own
// parser) into a float Image. Every problem becomes an InputError naming the file; a PNG
// whose CRCs or zlib checksum do not match is a DamagedImage. A file is opened once, its type
// and declared size looked at from its first bytes, and only then read whole, so a 1x1 PPM
// followed by a gigabyte of junk is refused unread and a PNG that inflates to more than its
// declared picture is refused after inflating one byte more than the picture holds.
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG       // the checker reads PNGs; the other stb decoders are dead weight
#define STBI_NO_STDIO       // we read the bytes ourselves, so errors name the file
#define STBI_FAILURE_USERMSG
#include <stb_image.h>
#include "image.h"
#include "tools/image_read.h"
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstring>
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

[[noreturn]] void damaged(const std::string& path, const std::string& problem) {
    throw DamagedImage("'" + path + "': " + problem);
}

uint32_t big_endian_32(const unsigned char* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
}

constexpr size_t png_signature_size = 8, png_chunk_overhead = 12;  // length, type, CRC
constexpr size_t png_ihdr_end = png_signature_size + png_chunk_overhead + 13;  // 33 bytes

// What IHDR declares: the picture's size and the exact number of bytes its image data
// inflates to (a filter byte per row, per interlace pass).
struct PngHeader {
    long long width = 0, height = 0;
    int bit_depth = 0, colour_type = 0, interlace = 0;
    unsigned long long raw_bytes = 0;
};

PngHeader png_header(const std::string& path, const unsigned char* bytes, size_t size) {
    if (size < png_ihdr_end || big_endian_32(bytes + 8) != 13 ||
        std::memcmp(bytes + 12, "IHDR", 4) != 0) {
        fail(path, "is a damaged or truncated PNG (no IHDR chunk at its start)");
    }
    const unsigned char* data = bytes + 16;
    PngHeader header;
    header.width = big_endian_32(data);
    header.height = big_endian_32(data + 4);
    header.bit_depth = data[8];
    header.colour_type = data[9];
    header.interlace = data[12];
    int channels = 0;  // per pixel, by colour type
    switch (header.colour_type) {
        case 0: channels = 1; break;  // grey
        case 2: channels = 3; break;  // RGB
        case 3: channels = 1; break;  // palette index
        case 4: channels = 2; break;  // grey + alpha
        case 6: channels = 4; break;  // RGBA
        default: fail(path, "is not a readable PNG (colour type " +
                                std::to_string(header.colour_type) + ")");
    }
    const int depth = header.bit_depth;
    if (depth != 1 && depth != 2 && depth != 4 && depth != 8 && depth != 16) {
        fail(path, "is not a readable PNG (bit depth " + std::to_string(depth) + ")");
    }
    if (header.interlace > 1) fail(path, "is not a readable PNG (unknown interlace method)");
    check_size(path, header.width, header.height);
    const unsigned long long bits_per_pixel = static_cast<unsigned long long>(channels) * depth;
    auto pass_bytes = [&](long long x0, long long y0, long long dx, long long dy) {
        const long long w = (header.width - x0 + dx - 1) / dx;
        const long long h = (header.height - y0 + dy - 1) / dy;
        if (w <= 0 || h <= 0) return 0ULL;
        return static_cast<unsigned long long>(h) * (1 + (w * bits_per_pixel + 7) / 8);
    };
    if (header.interlace == 0) {
        header.raw_bytes = pass_bytes(0, 0, 1, 1);
    } else {  // Adam7: seven passes, each with its own rows
        static const int passes[7][4] = {{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                                         {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}};
        for (const auto& p : passes) header.raw_bytes += pass_bytes(p[0], p[1], p[2], p[3]);
    }
    return header;
}

// The largest PNG file a declared picture can need: its data stored uncompressed (zlib's
// worst case adds 5 bytes per 64 KiB block), chunk overheads, and room for ancillary chunks
// (text, a colour profile).
unsigned long long max_png_file_bytes(const PngHeader& header) {
    constexpr unsigned long long ancillary_room = 4ULL << 20;
    return header.raw_bytes + header.raw_bytes / 16 + ancillary_room;
}

// Walks every chunk (length, type, data, CRC): each must fit in the file and match its CRC;
// the IDAT chunks are inflated as they come, into a small buffer that is only counted, and
// must give exactly the bytes IHDR declares, ending with zlib's Adler-32 checksum. stb_image
// trusts chunk lengths and grows its output without a limit, so this runs before it.
void check_png_data(const std::string& path, const std::vector<unsigned char>& bytes,
                    const PngHeader& header) {
    z_stream stream{};
    if (inflateInit(&stream) != Z_OK) fail(path, "cannot be inflated (zlib failed to start)");
    std::unique_ptr<z_stream, int (*)(z_stream*)> owner(&stream, inflateEnd);
    std::vector<unsigned char> scratch(1 << 16);
    unsigned long long inflated = 0;
    bool stream_ended = false, seen_idat = false, idat_done = false;
    size_t position = png_signature_size;
    while (true) {
        if (bytes.size() - position < png_chunk_overhead) {
            damaged(path, "is a truncated PNG (it ends without an IEND chunk)");
        }
        const unsigned char* chunk = bytes.data() + position;
        const size_t length = big_endian_32(chunk);
        const std::string type(reinterpret_cast<const char*>(chunk + 4), 4);
        const size_t left = bytes.size() - position - png_chunk_overhead;
        if (length > left) {
            damaged(path, "is a damaged or truncated PNG (a chunk claims " +
                              std::to_string(length) + " bytes, the file has " +
                              std::to_string(left) + " left)");
        }
        const uint32_t stored_crc = big_endian_32(chunk + 8 + length);
        const uint32_t crc = static_cast<uint32_t>(
            crc32(crc32(0L, Z_NULL, 0), chunk + 4, static_cast<uInt>(length + 4)));
        if (crc != stored_crc) {
            std::string shown_type;
            for (char c : type) shown_type += std::isalpha(static_cast<unsigned char>(c)) ? c : '?';
            damaged(path, "is a damaged PNG (the CRC of its " + shown_type + " chunk at byte " +
                              std::to_string(position) + " does not match: a changed byte?)");
        }
        if (type == "IDAT") {
            if (idat_done) damaged(path, "is a damaged PNG (its IDAT chunks are not together)");
            seen_idat = true;
            stream.next_in = const_cast<unsigned char*>(chunk + 8);
            stream.avail_in = static_cast<uInt>(length);
            while (stream.avail_in > 0) {
                if (stream_ended) {
                    damaged(path, "is a damaged PNG (data after the end of its image data)");
                }
                stream.next_out = scratch.data();
                stream.avail_out = static_cast<uInt>(scratch.size());
                const int status = inflate(&stream, Z_NO_FLUSH);
                inflated += scratch.size() - stream.avail_out;
                if (inflated > header.raw_bytes) {
                    fail(path, "inflates to more than the " + std::to_string(header.raw_bytes) +
                                   " bytes its " + std::to_string(header.width) + "x" +
                                   std::to_string(header.height) +
                                   " picture holds: refused (a decompression bomb?)");
                }
                if (status == Z_STREAM_END) {
                    stream_ended = true;
                } else if (status == Z_DATA_ERROR) {
                    damaged(path, std::string("is a damaged PNG (zlib: ") +
                                      (stream.msg ? stream.msg : "bad compressed data") + ")");
                } else if (status != Z_OK && status != Z_BUF_ERROR) {
                    fail(path, "cannot be inflated (zlib status " + std::to_string(status) + ")");
                }
            }
        } else if (seen_idat) {
            idat_done = true;
        }
        position += png_chunk_overhead + length;
        if (type == "IEND") break;
    }
    if (!seen_idat) damaged(path, "is a damaged PNG (no image data: no IDAT chunk)");
    if (!stream_ended) {
        damaged(path, "is a damaged or truncated PNG (its image data stops early, after " +
                          std::to_string(inflated) + " of " + std::to_string(header.raw_bytes) +
                          " bytes)");
    }
    if (inflated != header.raw_bytes) {
        damaged(path, "is a damaged PNG (its image data holds " + std::to_string(inflated) +
                          " bytes, a " + std::to_string(header.width) + "x" +
                          std::to_string(header.height) + " picture " +
                          std::to_string(header.raw_bytes) + ")");
    }
    if (position != bytes.size()) {
        fail(path, "has " + std::to_string(bytes.size() - position) +
                       " bytes after its end (IEND): not a plain PNG");
    }
}

Image read_png(const std::string& path, const std::vector<unsigned char>& bytes) {
    const PngHeader header = png_header(path, bytes.data(), bytes.size());
    if (bytes.size() > max_png_file_bytes(header) ||
        bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
        fail(path, "is " + std::to_string(bytes.size()) + " bytes: more than a " +
                       std::to_string(header.width) + "x" + std::to_string(header.height) +
                       " PNG can need");
    }
    check_png_data(path, bytes, header);
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

    // Reads the header (magic, width, height, maxval): after it, position_ is at the first
    // pixel byte (P6) or after maxval (P3). Returns the largest file the picture can need:
    // exactly the header and the raster for P6; for P3 room for long numbers and comments.
    unsigned long long header() {
        binary_ = bytes_[1] == '6';
        position_ = 2;
        if (!at_end() && !is_space(bytes_[position_])) {
            fail(path_, "is not a PPM image (bad magic number)");
        }
        width_ = number("width", max_image_side);
        height_ = number("height", max_image_side);
        check_size(path_, width_, height_);
        maxval_ = number("maxval", max_ppm_maxval);
        if (maxval_ < 1) fail(path_, "has maxval 0 (expected 1..65535)");
        const unsigned long long samples = static_cast<unsigned long long>(width_ * height_ * 3);
        if (binary_) {
            // Exactly one whitespace byte separates maxval from the raster (no comment).
            if (at_end()) fail(path_, "is truncated: no pixel data after the header");
            ++position_;
            return position_ + samples * (maxval_ > 255 ? 2 : 1);
        }
        constexpr unsigned long long text_bytes_per_sample = 24, comment_room = 1 << 16;
        return position_ + samples * text_bytes_per_sample + comment_room;
    }

    Image read() {
        header();
        const size_t samples = static_cast<size_t>(width_ * height_ * 3);
        if (binary_) {
            const size_t raster = samples * (maxval_ > 255 ? 2 : 1);
            check_available(raster, "bytes of pixel data");
            if (bytes_.size() - position_ > raster) {
                fail(path_, "has " + std::to_string(bytes_.size() - position_ - raster) +
                                " bytes after its pixel data: one picture per file");
            }
        } else {
            // Cheap early check: every sample needs a digit and a separator (the last one
            // may end the file).
            check_available(2 * samples - 1, "bytes for the text samples");
        }
        // Only now, with the data known to be there, the picture is allocated.
        Image image(static_cast<int>(width_), static_cast<int>(height_));
        if (binary_) {
            read_binary(image);
        } else {
            read_text(image);
            skip_space_and_comments();
            if (!at_end()) fail(path_, "has more after its last sample: one picture per file");
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
    bool binary_ = false;
    long long width_ = 0, height_ = 0;
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

namespace {

// Closes a file descriptor when it goes out of scope.
struct FileCloser {
    int fd;
    ~FileCloser() { if (fd >= 0) ::close(fd); }
};

// Opens NAME (relative to folder_fd, or a path with AT_FDCWD) for reading: an ordinary file
// only, never waiting on a FIFO, and with follow_links = false never through a link.
int open_picture(int folder_fd, const std::string& name, const std::string& shown,
                 bool follow_links, struct stat& info) {
    int flags = O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC;
    if (!follow_links) flags |= O_NOFOLLOW;
    const int fd = ::openat(folder_fd, name.c_str(), flags);
    if (fd < 0) {
        const int error = errno;
        struct stat link {};
        if (!follow_links && error == ELOOP &&
            ::fstatat(folder_fd, name.c_str(), &link, AT_SYMLINK_NOFOLLOW) == 0 &&
            S_ISLNK(link.st_mode)) {
            fail(shown, "is a symbolic link: not followed (a submission's pictures must be "
                        "ordinary files)");
        }
        if (error == ENOENT) fail(shown, "no such file");
        if (error == EISDIR) fail(shown, "is a folder, not an image file");
        fail(shown, std::string("cannot be opened for reading (") + std::strerror(error) + ")");
    }
    if (::fstat(fd, &info) != 0) {
        const int error = errno;
        ::close(fd);
        fail(shown, std::string("cannot be read (") + std::strerror(error) + ")");
    }
    if (S_ISDIR(info.st_mode)) {
        ::close(fd);
        fail(shown, "is a folder, not an image file");
    }
    if (!S_ISREG(info.st_mode)) {
        ::close(fd);
        fail(shown, "is not an ordinary file");  // /dev/zero, a FIFO, a socket
    }
    return fd;
}

// Reads up to `count` bytes from the current offset (fewer only at the end of the file).
size_t read_up_to(int fd, unsigned char* data, size_t count, const std::string& shown) {
    size_t done = 0;
    while (done < count) {
        const ssize_t got = ::read(fd, data + done, count - done);
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) fail(shown, std::string("read error (") + std::strerror(errno) + ")");
        if (got == 0) break;
        done += static_cast<size_t>(got);
    }
    return done;
}

// The bytes of a picture file, bounded before they are read: the file's size against the
// overall limit, then the type and declared size from its first bytes against the size.
std::vector<unsigned char> read_picture_bytes(int fd, const struct stat& info,
                                              const std::string& shown) {
    const unsigned long long size = static_cast<unsigned long long>(info.st_size);
    if (size > static_cast<unsigned long long>(max_picture_file_bytes)) {
        fail(shown, "is " + std::to_string(size) + " bytes: larger than any picture the "
                    "checker reads (" + std::to_string(max_picture_file_bytes >> 20) + " MiB)");
    }
    constexpr size_t prefix_size = 1 << 16;  // enough for any header we accept
    std::vector<unsigned char> bytes(std::min<size_t>(size, prefix_size));
    bytes.resize(read_up_to(fd, bytes.data(), bytes.size(), shown));
    if (bytes.empty()) fail(shown, "is empty (0 bytes), not an image");
    unsigned long long largest = 0;
    if (is_png(bytes)) {
        largest = max_png_file_bytes(png_header(shown, bytes.data(), bytes.size()));
    } else if (is_ppm(bytes)) {
        largest = PpmReader(shown, bytes).header();
    } else {
        fail(shown, "is not a PNG or PPM (P6/P3) image");
    }
    if (size > largest) {
        fail(shown, "is " + std::to_string(size) + " bytes, more than its declared picture "
                    "can need (" + std::to_string(largest) + "): refused unread");
    }
    const size_t have = bytes.size();
    bytes.resize(static_cast<size_t>(size));
    bytes.resize(have + read_up_to(fd, bytes.data() + have, bytes.size() - have, shown));
    return bytes;
}

}  // namespace

Image read_image_at(int folder_fd, const std::string& name, const std::string& shown,
                    std::vector<unsigned char>* bytes) {
    struct stat info {};
    const FileCloser file{open_picture(folder_fd, name, shown, false, info)};
    std::vector<unsigned char> read = read_picture_bytes(file.fd, info, shown);
    Image image = read_image_bytes(read, shown);
    if (bytes) *bytes = std::move(read);
    return image;
}

Image read_image_file(const std::string& path, bool follow_links) {
    struct stat info {};
    const FileCloser file{open_picture(AT_FDCWD, path, path, follow_links, info)};
    return read_image_bytes(read_picture_bytes(file.fd, info, path), path);
}

Image read_image(const std::string& path) { return read_image_file(path, true); }

std::vector<unsigned char> read_file_at(int folder_fd, const std::string& name,
                                        const std::string& shown, long long max_bytes) {
    struct stat info {};
    const FileCloser file{open_picture(folder_fd, name, shown, false, info)};
    if (info.st_size > max_bytes) {
        fail(shown, "is " + std::to_string(info.st_size) + " bytes, over the limit of " +
                        std::to_string(max_bytes));
    }
    std::vector<unsigned char> bytes(static_cast<size_t>(info.st_size));
    bytes.resize(read_up_to(file.fd, bytes.data(), bytes.size(), shown));
    return bytes;
}

}  // namespace ctlab
