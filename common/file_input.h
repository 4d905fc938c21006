// file_input.h: reading volume files safely, for every loader (raw, NIfTI, NRRD, MetaImage,
// DICOM, transfer functions).
//
// A file is opened with O_NONBLOCK and checked with fstat before a byte is read: a FIFO, a
// device (/dev/zero), a socket or a folder is refused at once instead of hanging or loading as
// zeros. Its data is streamed (plain bytes from an offset, or a zlib/gzip stream inflated on
// the fly) into the volume through a buffer of bounded size, so loading takes the volume plus
// that buffer, whatever the header claims; the data must end exactly where the header says.
#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>
#include "volume.h"

namespace ctlab {

// An open regular file (closed by the destructor). Throws InputError naming the path when it
// is missing, unreadable, a folder, or not an ordinary file.
class InputFile {
public:
    explicit InputFile(const std::string& path);
    ~InputFile();
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    const std::string& path() const { return path_; }
    uint64_t size() const { return size_; }  // bytes, as fstat saw them at open
    int descriptor() const { return fd_; }

    // Reads up to count bytes at offset; returns how many (fewer only at the end of the file).
    size_t read_at(uint64_t offset, void* into, size_t count) const;

private:
    std::string path_;
    int fd_ = -1;
    uint64_t size_ = 0;
};

// Reads a whole regular file of at most max_bytes (InputError past it).
std::vector<unsigned char> read_small_file(const std::string& path, uint64_t max_bytes);

// The bytes of a volume's data: a stretch of a file, or a zlib or gzip stream in it inflated
// as it is read. rewind() starts again (a second pass re-inflates: nothing is kept).
class ByteStream {
public:
    // Plain bytes of `file` from `offset` to its end.
    static std::unique_ptr<ByteStream> plain(const InputFile& file, uint64_t offset);
    // A zlib or gzip stream starting at `offset` of `file` (gzip members one after another are
    // read as one stream, as gzip itself does).
    static std::unique_ptr<ByteStream> inflated(const InputFile& file, uint64_t offset);
    virtual ~ByteStream() = default;

    // Fills `into` with up to count bytes; fewer only where the data ends. Throws InputError
    // (prefix + what zlib said) on damaged compressed data.
    virtual size_t read(void* into, size_t count) = 0;
    // Reads count bytes, as many reads as it takes; fewer only where the data ends.
    size_t read_all(void* into, size_t count);
    // Back to the start of the data (past what skip_start skipped).
    void rewind() {
        restart();
        skip(skipped_);
    }
    // Skips count bytes (NIfTI extensions, NRRD byte skip) without keeping them.
    void skip(uint64_t count);
    // Skips count bytes now and again after every rewind: where the data starts in the stream.
    void skip_start(uint64_t count) {
        skip(count);
        skipped_ += count;
    }
    // True when no byte is left.
    bool at_end();
    // What the data is, for messages: "data" or "compressed data".
    virtual const char* kind() const = 0;
    // Messages start with this ("'head.nii' (NIfTI): ").
    std::string prefix;

protected:
    // Back to the stream's first byte.
    virtual void restart() = 0;

private:
    uint64_t skipped_ = 0;
};

// Reads exactly volume.voxel_count() samples of `type` from `stream` into the volume (whose
// nx, ny, nz and name are set), each times slope plus inter, choosing volume.map as
// store_samples does: int16 read straight into the volume, other types in two passes through
// a 1 MiB buffer. Refuses data shorter or longer than that, naming both byte counts.
void read_volume_samples(Volume& volume, ByteStream& stream, SampleType type, Endian endian,
                         double slope = 1.0, double inter = 0.0);

// The host's byte order.
Endian host_endian();

// Calls `call` with the process's stderr sent to a temporary file, and returns the last
// non-empty line the call wrote there ("" when none), control characters made spaces: a
// library's own messages (nifticlib, teem, GDCM, libjpeg) become part of our one line
// instead of lines of their own.
std::string capture_stderr(const std::function<void()>& call);

// Refuses file axis directions of which two are parallel (or nearly: the unit vectors span
// less than a thousandth of a cube), naming where they came from ("sform", "space
// directions", "TransformMatrix"); such a volume has no 3-D shape to turn.
void check_axes_independent(const Directions& directions, const std::string& prefix,
                            const std::string& source);

// "1 byte", "48 bytes".
std::string bytes_text(uint64_t count);

}  // namespace ctlab
