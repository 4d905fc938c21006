// image_read.h: how the checker reads pictures it does not trust (image.h has read_image and
// read_image_bytes for the common case). Every read is bounded before anything is allocated:
// the file's size, its declared picture size and, for a PNG, the bytes its data inflates to.
#pragma once
#include <string>
#include <vector>
#include "error.h"
#include "image.h"

namespace ctlab {

// A picture whose own checks fail: a PNG chunk's CRC, zlib's Adler-32 or a cut-short stream.
// The bytes changed after the picture was written (a flipped byte, a bad copy): the checker's
// verdict is "damaged", not "fail".
struct DamagedImage : InputError {
    explicit DamagedImage(const std::string& message) : InputError(message) {}
};

// No picture file the checker reads is larger (a 4096 x 4096 16-bit PNG needs about 100 MB).
constexpr long long max_picture_file_bytes = 256LL << 20;

// Reads NAME inside the folder open as `folder_fd` without following a symbolic link: a link
// is refused ("is a symbolic link"), as is anything but an ordinary file (a FIFO is not
// waited for). `shown` stands for the file in messages. Throws InputError or DamagedImage.
// With `bytes`, the file's bytes are kept there too (to find identical submissions).
Image read_image_at(int folder_fd, const std::string& name, const std::string& shown,
                    std::vector<unsigned char>* bytes = nullptr);

// The same for a path; with follow_links = false its last component must not be a link.
Image read_image_file(const std::string& path, bool follow_links);

// The bytes of an ordinary file NAME in `folder_fd` (no link followed), at most max_bytes
// (larger: InputError, nothing read). For comparing two students' files byte for byte.
std::vector<unsigned char> read_file_at(int folder_fd, const std::string& name,
                                        const std::string& shown, long long max_bytes);

}  // namespace ctlab
