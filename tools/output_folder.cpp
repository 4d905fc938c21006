// output_folder.cpp: exclusive temporaries, renames and folders by descriptor (see the .h).
#include "tools/output_folder.h"
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <stb_image_write.h>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>
#include "error.h"

namespace ctlab {

namespace {

std::shared_ptr<int> own(int fd) {
    return std::shared_ptr<int>(new int(fd), [](int* p) {
        ::close(*p);
        delete p;
    });
}

std::string join(const std::string& folder, const std::string& name) {
    if (name.empty()) return folder;
    if (folder.empty() || folder.back() == '/') return folder + name;
    return folder + "/" + name;
}

std::string reason() { return std::strerror(errno); }

// Writes all of `bytes` to fd; false on a short write.
bool write_all(int fd, const std::string& bytes) {
    size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t wrote = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (wrote < 0 && errno == EINTR) continue;
        if (wrote <= 0) return false;
        done += static_cast<size_t>(wrote);
    }
    return true;
}

// The exclusive temporary-and-rename write inside the folder open as folder_fd.
void write_in(int folder_fd, const std::string& name, const std::string& bytes,
              const std::string& shown) {
    struct stat existing {};
    if (::fstatat(folder_fd, name.c_str(), &existing, AT_SYMLINK_NOFOLLOW) == 0 &&
        S_ISDIR(existing.st_mode)) {
        throw InputError("cannot write '" + printable(shown) + "': a folder of that name is there");
    }
    static std::mt19937_64 random{std::random_device{}()};
    std::string temporary;
    int fd = -1;
    for (int attempt = 0; attempt < 32 && fd < 0; ++attempt) {
        char suffix[24];
        std::snprintf(suffix, sizeof suffix, "%016llx",
                      static_cast<unsigned long long>(random()));
        temporary = "." + name.substr(0, 100) + ".tmp" + suffix;
        fd = ::openat(folder_fd, temporary.c_str(),
                      O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
        if (fd < 0 && errno != EEXIST) break;
    }
    if (fd < 0) throw InputError("cannot write '" + printable(shown) + "': " + reason());
    const bool written = write_all(fd, bytes);
    const bool closed = ::close(fd) == 0;
    if (!written || !closed) {
        ::unlinkat(folder_fd, temporary.c_str(), 0);
        throw InputError("cannot write '" + printable(shown) + "' (disk full?)");
    }
    if (::renameat(folder_fd, temporary.c_str(), folder_fd, name.c_str()) != 0) {
        const std::string why = reason();
        ::unlinkat(folder_fd, temporary.c_str(), 0);
        throw InputError("cannot write '" + printable(shown) + "': " + why);
    }
}

void append_bytes(void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                               static_cast<size_t>(size));
}

}  // namespace

OutputFolder OutputFolder::open(const std::string& path, bool* created) {
    if (created) *created = false;
    if (::mkdir(path.c_str(), 0777) == 0) {
        if (created) *created = true;
    } else if (errno != EEXIST) {
        throw InputError("cannot create folder '" + printable(path) + "': " + reason() +
                         (errno == ENOENT ? " (its parent folder must exist)" : ""));
    }
    const int fd = ::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) {
        throw InputError("cannot open folder '" + printable(path) + "': " +
                         (errno == ENOTDIR ? std::string("it is a file") : reason()));
    }
    return OutputFolder(own(fd), path);
}

OutputFolder OutputFolder::subfolder(const std::string& name) const {
    const std::string shown = path(name);
    if (::mkdirat(*fd_, name.c_str(), 0777) != 0 && errno != EEXIST) {
        throw InputError("cannot create folder '" + printable(shown) + "': " + reason());
    }
    const int fd = ::openat(*fd_, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) {
        throw InputError("cannot use folder '" + printable(shown) + "': " +
                         (errno == ELOOP || errno == ENOTDIR
                              ? std::string("a link or a file of that name is in the way")
                              : reason()));
    }
    return OutputFolder(own(fd), shown);
}

void OutputFolder::write(const std::string& name, const std::string& bytes) const {
    write_in(*fd_, name, bytes, path(name));
}

void OutputFolder::write_png(const std::string& name, const Image& image) const {
    write(name, png_bytes(image));
}

void OutputFolder::remove(const std::string& name) const {
    ::unlinkat(*fd_, name.c_str(), 0);  // unlink never follows a link; a folder stays
}

std::string OutputFolder::path(const std::string& name) const { return join(path_, name); }

std::string png_bytes(const Image& image) {
    std::vector<unsigned char> rgb(static_cast<size_t>(image.width) * image.height * 3);
    for (size_t n = 0; n < image.pixels.size(); ++n) {
        rgb[3 * n + 0] = to_byte(image.pixels[n].r);
        rgb[3 * n + 1] = to_byte(image.pixels[n].g);
        rgb[3 * n + 2] = to_byte(image.pixels[n].b);
    }
    std::string bytes;
    if (!stbi_write_png_to_func(append_bytes, &bytes, image.width, image.height, 3, rgb.data(),
                                image.width * 3)) {
        throw InputError("cannot encode a " + std::to_string(image.width) + "x" +
                         std::to_string(image.height) + " PNG");
    }
    return bytes;
}

void write_file_replacing(const std::string& path, const std::string& bytes) {
    const size_t slash = path.rfind('/');
    const std::string folder = slash == std::string::npos ? "." : path.substr(0, slash + 1);
    const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
    if (name.empty() || name == "." || name == "..") {
        throw InputError("'" + printable(path) + "' names a folder, not a file");
    }
    const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) {
        throw InputError("cannot write '" + printable(path) + "': the folder '" +
                         printable(folder) + "' " +
                         (errno == ENOENT ? "does not exist (create it first)" : reason()));
    }
    const std::shared_ptr<int> owner = own(fd);
    write_in(fd, name, bytes, path);
}

}  // namespace ctlab
