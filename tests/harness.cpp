// harness.cpp: the steps run as processes for the tests (see harness.h).
#include "harness.h"
#include <doctest/doctest.h>
#include <sys/statfs.h>
#include <sys/statvfs.h>
#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include "phantom.h"

namespace ctlab_test {

namespace fs = std::filesystem;

// The repository: the current folder when the tests run from it (make test), else the
// folder above the test binary's (build/ctlab_tests).
static fs::path repository() {
    if (fs::is_directory("steps") && fs::is_directory("data")) return ".";
    return fs::path(ctlab::build_folder()).parent_path();
}

const std::vector<std::string>& step_names() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> found;
        for (const auto& entry : fs::directory_iterator(repository() / "steps")) {
            const std::string file = entry.path().filename().string();
            const bool numbered = file.size() > 7 &&
                                  std::isdigit(static_cast<unsigned char>(file[0])) &&
                                  std::isdigit(static_cast<unsigned char>(file[1])) &&
                                  file[2] == '_';
            if (numbered && entry.path().extension() == ".cpp") {
                found.push_back(entry.path().stem().string());
            }
        }
        std::sort(found.begin(), found.end());
        return found;
    }();
    return names;
}

bool is_camera_step(const std::string& name) { return name >= "13"; }

const std::vector<std::string>& phantom_flags() {
    static const ctlab::TempFolder folder("phantom");
    static const std::vector<std::string> flags =
        ctlab::write_raw_volume(ctlab::make_phantom(), folder.path("phantom.raw"));
    return flags;
}

std::vector<std::string> phantom_from_file(std::vector<std::string> flags) {
    for (size_t n = 0; n + 1 < flags.size(); ++n) {
        if (flags[n] != "--volume" || flags[n + 1] != "phantom") continue;
        flags.erase(flags.begin() + long(n), flags.begin() + long(n) + 2);
        flags.insert(flags.begin() + long(n), phantom_flags().begin(), phantom_flags().end());
        break;
    }
    return flags;
}

const std::vector<std::string>& part1_step_names() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> part1;
        for (const std::string& name : step_names()) {
            if (!is_camera_step(name)) part1.push_back(name);
        }
        return part1;
    }();
    return names;
}

std::vector<std::string> size_flags(const std::string& name) {
    if (!is_camera_step(name)) return {};
    return {"--size", std::to_string(camera_width) + "x" + std::to_string(camera_height)};
}

std::vector<ctlab::View> default_views(const std::string& name, const ctlab::Volume& volume) {
    if (!is_camera_step(name)) return ctlab::views_named(volume, "all");
    ctlab::View camera;
    camera.camera = true;
    camera.name = "camera";
    camera.width = camera_width;
    camera.height = camera_height;
    return {camera};
}

const ctlab::Image& StepRender::image(const std::string& view) const {
    for (size_t n = 0; n < views.size(); ++n) {
        if (views[n] == view) return images[n];
    }
    throw std::runtime_error(run.command() + ": no image of the " + view + " view");
}

const std::string& scratch_parent() {
    static const std::string parent = [] {
        const char* memory = "/dev/shm";
        constexpr unsigned long long tmpfs_magic = 0x01021994;     // statfs f_type
        constexpr unsigned long long least_free = 256ull << 20;   // bytes
        struct statfs kind {};
        struct statvfs room {};
        if (std::getenv("TMPDIR") || statfs(memory, &kind) != 0 ||
            static_cast<unsigned long long>(kind.f_type) != tmpfs_magic ||
            statvfs(memory, &room) != 0 ||
            static_cast<unsigned long long>(room.f_bavail) * room.f_frsize < least_free ||
            access(memory, W_OK | X_OK) != 0) {
            return std::string();
        }
        return std::string(memory);
    }();
    return parent;
}

StepRender render_in(const TempFolder& folder, const std::string& name,
                     std::vector<std::string> flags) {
    flags.insert(flags.end(), {"--pfm", "--out", folder.path()});
    StepRender result;
    result.run = ctlab::run_step(name, flags);
    INFO(result.run.command() << "\n" << result.run.err);
    CHECK_MESSAGE(result.run.status == 0, name << " exited with status " << result.run.status);
    CHECK(result.run.summaries.size() > 0);
    for (const ctlab::Summary& summary : result.run.summaries) {
        const auto view = summary.find("view");
        if (view == summary.end()) continue;
        result.views.push_back(view->second);
        result.images.push_back(
            ctlab::read_pfm(ctlab::step_output(folder.path(), name, view->second, "pfm")));
    }
    return result;
}

StepRender render(const std::string& name, const std::vector<std::string>& flags) {
    const TempFolder folder("render");
    return render_in(folder, name, flags);
}

StepRender render(const std::string& name, const std::vector<std::string>& flags,
                  const ctlab::Volume& volume) {
    const TempFolder folder("render");
    std::vector<std::string> all = ctlab::write_raw_volume(volume, folder.path("volume.raw"));
    all.insert(all.end(), flags.begin(), flags.end());
    return render_in(folder, name, all);
}

std::vector<ctlab::Image> render_step(const std::string& name,
                                      const std::vector<std::string>& flags,
                                      const ctlab::Volume& volume) {
    return render(name, flags, volume).images;
}

}  // namespace ctlab_test
