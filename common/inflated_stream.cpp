// inflated_stream.cpp: ByteStream::inflated, a zlib or gzip stream inflated as it is read
// (common/file_input.h). In a file of its own: only the format loaders need zlib.
#include <zlib.h>
#include <algorithm>
#include <cstring>
#include <new>
#include "error.h"
#include "file_input.h"

namespace ctlab {

namespace {
constexpr size_t compressed_chunk = size_t(1) << 16;  // compressed bytes read at a time

class InflatedStream : public ByteStream {
public:
    InflatedStream(const InputFile& file, uint64_t offset) : file_(file), start_(offset),
                                                             input_(compressed_chunk) {
        // 15 + 32: a zlib or a gzip header, told apart by zlib.
        if (inflateInit2(&stream_, 15 + 32) != Z_OK) throw std::bad_alloc();
        restart();
    }
    ~InflatedStream() override { inflateEnd(&stream_); }

    void restart() override {
        inflateReset(&stream_);
        position_ = start_;
        stream_.avail_in = 0;
        ended_ = false;
        out_before_ = 0;
    }
    const char* kind() const override { return "compressed data"; }

    size_t read(void* into, size_t count) override {
        stream_.next_out = static_cast<unsigned char*>(into);
        stream_.avail_out = uInt(count);
        while (stream_.avail_out > 0 && !ended_) {
            if (stream_.avail_in == 0) {
                const size_t got = file_.read_at(position_, input_.data(), input_.size());
                position_ += got;
                if (got == 0) {
                    throw InputError(prefix + "the compressed data is cut short (the file ends "
                                     "inside the stream, after " +
                                     bytes_text(stream_.total_out + uint64_t(out_before_)) +
                                     " unpacked)");
                }
                stream_.next_in = input_.data();
                stream_.avail_in = uInt(got);
            }
            const int status = inflate(&stream_, Z_NO_FLUSH);
            if (status == Z_STREAM_END) {
                // Another gzip member may follow (gzip a; gzip b; cat): read on, as gzip does.
                // Anything else after the stream is not data.
                out_before_ += stream_.total_out;
                unsigned char next[2] = {0, 0};
                size_t have = std::min<size_t>(stream_.avail_in, 2);
                std::memcpy(next, stream_.next_in, have);
                if (have < 2) {
                    have += file_.read_at(position_, next + have, 2 - have);
                }
                if (have == 2 && next[0] == 0x1f && next[1] == 0x8b) {
                    const uInt left = stream_.avail_in;
                    unsigned char* at = stream_.next_in;
                    inflateReset(&stream_);
                    stream_.next_in = at;
                    stream_.avail_in = left;
                    continue;
                }
                ended_ = true;
            } else if (status == Z_NEED_DICT || status == Z_DATA_ERROR ||
                       status == Z_STREAM_ERROR) {
                throw InputError(prefix + "the compressed data is damaged (zlib: " +
                                 (stream_.msg ? stream_.msg : "not zlib or gzip data") + ")");
            } else if (status == Z_MEM_ERROR) {
                throw std::bad_alloc();
            }
        }
        return count - stream_.avail_out;
    }

private:
    const InputFile& file_;
    uint64_t start_, position_ = 0;
    std::vector<unsigned char> input_;
    z_stream stream_{};
    bool ended_ = false;
    uLong out_before_ = 0;  // bytes of earlier gzip members (total_out restarts per member)
};
}  // namespace

std::unique_ptr<ByteStream> ByteStream::inflated(const InputFile& file, uint64_t offset) {
    return std::unique_ptr<ByteStream>(new InflatedStream(file, offset));
}

}  // namespace ctlab
