// image.h: a float RGB picture and its PNG output.
#pragma once
#include <string>
#include <vector>

namespace ctlab {

struct Rgb {
    float r = 0, g = 0, b = 0;  // linear 0..1; values outside are clamped only when written
};

inline Rgb grey(float value) { return {value, value, value}; }

struct Image {
    int width = 0, height = 0;
    std::vector<Rgb> pixels;  // row-major, row y = image row (top row first)

    Image() = default;
    Image(int w, int h) : width(w), height(h), pixels(static_cast<size_t>(w) * h) {}
    Rgb& at(int x, int y) { return pixels[static_cast<size_t>(y) * width + x]; }
    const Rgb& at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
};

// 0..1 float to a byte: clamped in floating point first (NaN counts as 0), then rounded.
unsigned char to_byte(float value);

// zlib's compression levels for write_png: the pictures a step renders get stb's default;
// the ray pictures of --debug-pixel, which a test or a student opens at most once, are
// stored uncompressed (level 0: no compression at all, several times bigger, a copy's cost;
// stb's own fastest level still took most of a --debug-pixel run).
constexpr int default_png_compression = 8;
constexpr int stored_png_compression = 0;
constexpr int fast_png_compression = stored_png_compression;

// Writes an 8-bit RGB PNG through a temporary file renamed into place, so a reader never
// sees a half-written PNG. Throws InputError when the folder cannot be written. Not for two
// threads at once (the level is stb's global setting).
void write_png(const Image& image, const std::string& path,
               int compression = default_png_compression);

// Writes the float RGB values themselves, before any clamping or rounding, as a colour PFM
// ("PF", scale -1.0 = little-endian floats, rows from the bottom row up), through a temporary
// file renamed into place like write_png. For tests and tools that need more than 8 bits.
void write_pfm(const Image& image, const std::string& path);

// |a - b| per channel times `scale` (a picture of where two renders of one view differ), and
// in *largest the largest |a - b| of any channel of any pixel, before the scaling. a and b
// have the same size.
Image scaled_difference(const Image& a, const Image& b, float scale, double* largest);

// Reads a PNG (any bit depth stb_image reads) or a PPM (P6 or P3, maxval up to 65535) as
// 0..1 RGB.
// Throws InputError naming the file and the problem.
Image read_image(const std::string& path);

// The same from the bytes of a file already in memory; `name` stands for the file in the
// messages (read_image reads the file and calls this; the fuzz tests call it directly).
Image read_image_bytes(const std::vector<unsigned char>& bytes, const std::string& name);

// Creates a folder and its parents (like mkdir -p). Throws InputError when it cannot.
void make_folder(const std::string& path);

}  // namespace ctlab
