// file_input.cpp: opening volume files safely and streaming their data into the volume.
#include "file_input.h"
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <new>
#include "error.h"
#include "samples.h"

namespace ctlab {

namespace {
constexpr size_t chunk_bytes = size_t(1) << 20;      // the samples' buffer: 1 MiB

std::string quoted(const std::string& path) { return "'" + printable(path) + "'"; }

// What a file that is not an ordinary file is, for the message.
const char* kind_of(mode_t mode) {
    if (S_ISDIR(mode)) return "a folder, not a file";
    if (S_ISFIFO(mode)) return "a FIFO (named pipe), not an ordinary file";
    if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device, not an ordinary file";
    if (S_ISSOCK(mode)) return "a socket, not an ordinary file";
    return "not an ordinary file";
}
}  // namespace

std::string bytes_text(uint64_t count) {
    return std::to_string(count) + (count == 1 ? " byte" : " bytes");
}

Endian host_endian() {
    const uint16_t probe = 1;
    unsigned char first;
    std::memcpy(&first, &probe, 1);
    return first == 1 ? Endian::little : Endian::big;
}

// --- InputFile --------------------------------------------------------------------------------

InputFile::InputFile(const std::string& path) : path_(path) {
    // O_NONBLOCK: opening a FIFO with no writer returns at once instead of waiting for one
    // (fstat then refuses it); it changes nothing for an ordinary file.
    fd_ = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd_ < 0) throw InputError("cannot open " + quoted(path) + ": " + std::strerror(errno));
    struct stat info {};
    if (fstat(fd_, &info) != 0) {
        const int error = errno;
        close(fd_);
        throw InputError("cannot open " + quoted(path) + ": " + std::strerror(error));
    }
    if (!S_ISREG(info.st_mode)) {
        close(fd_);
        throw InputError(quoted(path) + " is " + kind_of(info.st_mode));
    }
    size_ = uint64_t(info.st_size);
}

InputFile::~InputFile() {
    if (fd_ >= 0) close(fd_);
}

size_t InputFile::read_at(uint64_t offset, void* into, size_t count) const {
    size_t done = 0;
    while (done < count) {
        const ssize_t got = pread(fd_, static_cast<char*>(into) + done, count - done,
                                  off_t(offset + done));
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) {
            throw InputError("cannot read " + quoted(path_) + ": " + std::strerror(errno));
        }
        if (got == 0) break;
        done += size_t(got);
    }
    return done;
}

std::vector<unsigned char> read_small_file(const std::string& path, uint64_t max_bytes) {
    const InputFile file(path);
    if (file.size() > max_bytes) {
        throw InputError(quoted(path) + " has " + bytes_text(file.size()) +
                         ", over the limit of " + bytes_text(max_bytes));
    }
    // One byte more than fstat said: a file that grew since is refused, not read on and on.
    std::vector<unsigned char> bytes(size_t(file.size()) + 1);
    bytes.resize(file.read_at(0, bytes.data(), bytes.size()));
    if (bytes.size() != file.size()) {
        throw InputError("cannot read " + quoted(path) + ": it changed while it was read");
    }
    return bytes;
}

// --- ByteStream -------------------------------------------------------------------------------

void ByteStream::skip(uint64_t count) {
    unsigned char scratch[1 << 14];
    while (count > 0) {
        const size_t want = size_t(std::min<uint64_t>(count, sizeof scratch));
        const size_t got = read(scratch, want);
        count -= got;
        if (got < want) break;  // ended: the data read next will be found short
    }
}

size_t ByteStream::read_all(void* into, size_t count) {
    size_t done = 0;
    while (done < count) {
        const size_t got = read(static_cast<unsigned char*>(into) + done, count - done);
        if (got == 0) break;
        done += got;
    }
    return done;
}

bool ByteStream::at_end() {
    unsigned char extra;
    return read(&extra, 1) == 0;
}

namespace {
class PlainStream : public ByteStream {
public:
    PlainStream(const InputFile& file, uint64_t offset) : file_(file), start_(offset),
                                                          position_(offset) {}
    size_t read(void* into, size_t count) override {
        const size_t got = file_.read_at(position_, into, count);
        position_ += got;
        return got;
    }
    void restart() override { position_ = start_; }
    const char* kind() const override { return "data"; }

private:
    const InputFile& file_;
    uint64_t start_, position_;
};

}  // namespace

std::unique_ptr<ByteStream> ByteStream::plain(const InputFile& file, uint64_t offset) {
    return std::unique_ptr<ByteStream>(new PlainStream(file, offset));
}

// --- Samples into the volume --------------------------------------------------------------------

namespace {
std::string voxels_text(const Volume& volume, SampleType type) {
    return std::to_string(volume.nx) + "x" + std::to_string(volume.ny) + "x" +
           std::to_string(volume.nz) + " " + sample_type_name(type) + " voxels";
}

[[noreturn]] void data_short(const ByteStream& stream, uint64_t got, uint64_t needed,
                             const std::string& voxels) {
    throw InputError(stream.prefix + "the " + stream.kind() + " ends after " + bytes_text(got) +
                     ", its header promises " + std::to_string(needed) + " (" + voxels + ")");
}

[[noreturn]] void data_long(const ByteStream& stream, uint64_t needed, const std::string& voxels) {
    throw InputError(stream.prefix + "the " + stream.kind() + " holds more than the " +
                     bytes_text(needed) + " its header promises (" + voxels + ")");
}

void allocate(Volume& volume, const ByteStream& stream) {
    try {
        resize_dense(volume);
    } catch (const std::bad_alloc&) {
        throw InputError(stream.prefix + "its " + std::to_string(volume.nx) + "x" +
                         std::to_string(volume.ny) + "x" + std::to_string(volume.nz) +
                         " volume needs " + std::to_string((volume.voxel_count() * 2) >> 20) +
                         " MiB, more memory than this process may take (ulimit -v?)");
    } catch (const std::length_error&) {
        throw InputError(stream.prefix + "its volume is too large for this machine");
    }
}
}  // namespace

void read_volume_samples(Volume& volume, ByteStream& stream, SampleType type, Endian endian,
                         double slope, double inter) {
    const size_t count = volume.voxel_count();
    const size_t size = sample_size(type);
    const uint64_t needed = uint64_t(count) * size;
    const std::string voxels = voxels_text(volume, type);
    const bool compressed = std::strcmp(stream.kind(), "data") != 0;
    if (type == SampleType::int16 && slope == 1.0 && inter == 0.0 && !compressed) {
        // Straight into the volume: the file's bytes are the volume's, swapped when needed.
        // (Plain data only: its length is known before the volume is allocated.)
        allocate(volume, stream);
        const size_t got = stream.read_all(volume.data.data(), count * 2);
        if (got < count * 2) data_short(stream, got, needed, voxels);
        if (!stream.at_end()) data_long(stream, needed, voxels);
        if (endian != host_endian()) {
            for (int16_t& value : volume.data) {
                const uint16_t bits = uint16_t(value);
                value = int16_t(uint16_t((bits >> 8) | (bits << 8)));
            }
        }
        volume.map = ValueMap{};
        update_range(volume);
        return;
    }
    // Two passes through one buffer: the range (for the map), then the values. The first
    // pass also proves the data is all there before the volume takes its memory.
    const size_t chunk = chunk_bytes / size;
    std::vector<unsigned char> buffer(chunk * size);
    ValueRange range;
    for (size_t done = 0; done < count; done += chunk) {
        const size_t n = std::min(chunk, count - done);
        const size_t got = stream.read_all(buffer.data(), n * size);
        if (got < n * size) data_short(stream, uint64_t(done) * size + got, needed, voxels);
        scan_samples(range, buffer.data(), n, type, endian, slope, inter);
    }
    if (!stream.at_end()) data_long(stream, needed, voxels);
    volume.map = choose_map(range, volume.name);
    allocate(volume, stream);
    stream.rewind();
    for (size_t done = 0; done < count; done += chunk) {
        const size_t n = std::min(chunk, count - done);
        if (stream.read_all(buffer.data(), n * size) < n * size) {
            throw InputError(stream.prefix + "the file changed while it was read");
        }
        convert_samples(volume.data.data() + done, buffer.data(), n, type, endian, slope, inter,
                        volume.map);
    }
    update_range(volume);
}

// --- Library output -------------------------------------------------------------------------------

std::string capture_stderr(const std::function<void()>& call) {
    std::fflush(stderr);
    std::FILE* sink = std::tmpfile();
    const int saved = sink ? dup(2) : -1;
    if (saved >= 0) dup2(fileno(sink), 2);
    std::string said;
    auto restore = [&] {
        if (saved < 0) return;
        std::fflush(stderr);
        dup2(saved, 2);
        close(saved);
    };
    try {
        call();
    } catch (...) {
        restore();
        if (sink) std::fclose(sink);
        throw;
    }
    restore();
    if (sink) {
        std::rewind(sink);
        char line[512];
        while (std::fgets(line, sizeof line, sink)) {
            std::string text = line;
            for (char& c : text) {
                if (static_cast<unsigned char>(c) < 32 || c == 127) c = ' ';
            }
            const size_t first = text.find_first_not_of(' ');
            const size_t last = text.find_last_not_of(' ');
            if (first != std::string::npos) said = text.substr(first, last - first + 1);
        }
        std::fclose(sink);
    }
    return said;
}

// --- Directions -----------------------------------------------------------------------------------

void check_axes_independent(const Directions& directions, const std::string& prefix,
                            const std::string& source) {
    double unit[3][3];
    for (int a = 0; a < 3; ++a) {
        const double* d = directions.axis[a];
        const double length = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(length > 0) || !std::isfinite(length)) {
            throw InputError(prefix + source + " gives file axis " + std::to_string(a + 1) +
                             " no direction (zero or not a number)");
        }
        for (int w = 0; w < 3; ++w) unit[a][w] = d[w] / length;
    }
    constexpr double parallel_cosine = 0.9999;  // |cos| above it: under 0.8 degrees apart
    for (int a = 0; a < 3; ++a) {
        for (int b = a + 1; b < 3; ++b) {
            const double cosine =
                unit[a][0] * unit[b][0] + unit[a][1] * unit[b][1] + unit[a][2] * unit[b][2];
            if (std::fabs(cosine) > parallel_cosine) {
                throw InputError(prefix + source + " gives file axes " + std::to_string(a + 1) +
                                 " and " + std::to_string(b + 1) +
                                 " the same direction: the volume has no 3-D shape");
            }
        }
    }
    const double* u = unit[0];
    const double* v = unit[1];
    const double* w = unit[2];
    const double det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
                       u[2] * (v[0] * w[1] - v[1] * w[0]);
    constexpr double min_volume = 1e-3;  // of the unit cube the three directions span
    if (std::fabs(det) < min_volume) {
        throw InputError(prefix + source +
                         " gives the three file axes directions in one plane: the volume has no "
                         "3-D shape");
    }
}

}  // namespace ctlab
