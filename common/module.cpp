// module.cpp: opening ctlab's shared modules (module.h) with dlopen, once per process.
#include "module.h"
#include <dlfcn.h>
#include <unistd.h>
#include <climits>
#include <mutex>
#include "error.h"

namespace ctlab {

std::string program_folder() {
    char path[PATH_MAX];
    const ssize_t length = readlink("/proc/self/exe", path, sizeof path - 1);
    if (length <= 0) return "";
    const std::string exe(path, size_t(length));
    const size_t slash = exe.rfind('/');
    return slash == std::string::npos ? "." : exe.substr(0, slash);
}

std::string package_of_library(const std::string& loader_message) {
    // Library name stems, as the loader names them, and the -dev package that brings each
    // (the runtime package alone would do, but the lab is built from source: make deps).
    static const struct { const char* stem; const char* package; } known[] = {
        {"libgdcm", "libgdcm-dev"},   {"libniftiio", "libnifti2-dev"},
        {"libznz", "libnifti2-dev"},  {"libteem", "libteem-dev"},
        {"libz.so", "zlib1g-dev"},    {"libSDL2", "libsdl2-dev"},
        {"libimgui", "libimgui-dev"},
    };
    for (const auto& entry : known) {
        if (loader_message.find(entry.stem) != std::string::npos) return entry.package;
    }
    return "";
}

void* module_entry(const char* file_name, const char* symbol, const std::string& needed_for) {
    // dlopen counts its handles, but the first call's error is the one worth keeping: a
    // module that failed once fails the same way again (and says so again).
    static std::mutex lock;
    std::lock_guard<std::mutex> hold(lock);
    const std::string path = program_folder() + "/" + file_name;
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        const char* why = dlerror();
        const std::string message = why ? why : "unknown dlopen error";
        const std::string package = package_of_library(message);
        if (access(path.c_str(), F_OK) != 0) {
            throw InputError("ctlab needs its module " + printable(path) + " " + needed_for +
                             ", and it is not there: build it with make (it is built beside "
                             "the step binaries)");
        }
        throw InputError("ctlab could not load " + printable(path) + " " + needed_for + ": " +
                         printable(message) +
                         (package.empty() ? std::string()
                                          : " (install " + package + ": make deps)"));
    }
    void* entry = dlsym(handle, symbol);
    if (!entry) {
        throw InputError("ctlab's module " + printable(path) + " has no entry " + symbol +
                         ": rebuild it with make");
    }
    return entry;
}

}  // namespace ctlab
