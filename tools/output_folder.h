// output_folder.h: where the checker writes, and how. Every file is written to a temporary
// created exclusively (O_CREAT|O_EXCL, a random name, never through a link) beside its target
// and renamed into place, so a reader sees the whole file or the old one, and a link planted
// under a predictable name is replaced, never followed. Folders are opened once and used by
// descriptor: a folder swapped for a link afterwards changes nothing.
#pragma once
#include <memory>
#include <string>
#include <vector>
#include "error.h"
#include "image.h"

namespace ctlab {

class OutputFolder {
public:
    // Opens PATH, creating it (only its last component: the parent must exist) when missing.
    // `created` says whether it was made now.
    static OutputFolder open(const std::string& path, bool* created = nullptr);

    // A folder inside this one, created when missing; refused when NAME is a link or a file.
    OutputFolder subfolder(const std::string& name) const;

    // Writes NAME (replacing a file or a link of that name; refusing a folder).
    void write(const std::string& name, const std::string& bytes) const;
    void write_png(const std::string& name, const Image& image) const;
    // Removes NAME when it is there (a file or a link; never what a link points to).
    void remove(const std::string& name) const;

    std::string path(const std::string& name = "") const;  // for messages
    int fd() const { return *fd_; }

private:
    OutputFolder(std::shared_ptr<int> fd, std::string path)
        : fd_(std::move(fd)), path_(std::move(path)) {}
    std::shared_ptr<int> fd_;
    std::string path_;
};

// The PNG encoding of a picture (8-bit RGB), as write_png would write it.
std::string png_bytes(const Image& image);

// Writes `bytes` to PATH through an exclusive temporary in the same folder and a rename. The
// folder must exist (it is not created). Throws InputError.
void write_file_replacing(const std::string& path, const std::string& bytes);

}  // namespace ctlab
