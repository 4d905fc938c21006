// handout_listings.cpp: refreshes the code listings in the handouts from the steps
// (`make handouts`), so that a handout quotes the code exactly as it is.
//
//   build/handout_listings [--check] [HANDOUT.md ...]     (default: every handouts/*.md)
//
// Run from the repository root. Every block
//     <!-- listing: steps/05_interpolated_hits.cpp first_hit [FUNCTION] -->
//     ```cpp
//     ...
//     ```
// gets the text between that file's `//> lesson: first_hit` and `//< lesson: first_hit` lines
// (or only FUNCTION with its comment lines). Format: tools/lesson_markers.h.
// --check writes nothing and exits 1 when a listing differs from the code.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include "error.h"
#include "tools/lesson_markers.h"

using ctlab::InputError;
namespace fs = std::filesystem;

namespace {

constexpr int exit_stale = 1;  // --check: a listing differs from the code

std::vector<std::string> all_handouts() {
    std::vector<std::string> paths;
    if (!fs::is_directory("handouts")) {
        throw InputError("no handouts/ folder here: run from the repository root");
    }
    for (const auto& item : fs::directory_iterator("handouts")) {
        if (item.is_regular_file() && item.path().extension() == ".md") {
            paths.push_back(item.path().generic_string());
        }
    }
    std::sort(paths.begin(), paths.end());
    return paths;
}

void write_text(const std::string& path, const std::string& text) {
    std::ofstream file(path, std::ios::binary);
    file << text;
    file.close();
    if (!file) throw InputError("cannot write '" + path + "'");
}

int run(int argc, char** argv) {
    bool check_only = false;
    std::vector<std::string> handouts;
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        if (arg == "--check") {
            check_only = true;
        } else if (arg == "--help" || arg == "-h") {
            std::printf("usage: handout_listings [--check] [HANDOUT.md ...]\n");
            return 0;
        } else if (!arg.empty() && arg[0] == '-') {
            throw InputError("unknown flag '" + arg + "' (see --help)");
        } else {
            handouts.push_back(arg);
        }
    }
    if (handouts.empty()) handouts = all_handouts();

    int listings = 0, stale = 0;
    for (const std::string& path : handouts) {
        const std::string markdown = lesson::read_text(path);
        const auto found = lesson::find_listings(markdown, path);
        const std::string refreshed =
            lesson::refresh_listings(markdown, found, [&](const lesson::Listing& listing) {
                const std::string code = lesson::listing_text(
                    lesson::read_listed_file(".", listing, path), listing, path);
                const std::string old = markdown.substr(
                    listing.content_begin, listing.content_end - listing.content_begin);
                if (old != code) {
                    std::printf("%s:%d: %s %s %s\n", path.c_str(), listing.line,
                                check_only ? "differs from" : "refreshed from",
                                listing.path.c_str(), listing.marker.c_str());
                    ++stale;
                }
                return code;
            });
        listings += static_cast<int>(found.size());
        if (!check_only && refreshed != markdown) write_text(path, refreshed);
    }
    std::printf("handout_listings: %d listings in %zu handouts, %d %s\n", listings,
                handouts.size(), stale, check_only ? "differ from the code" : "refreshed");
    return check_only && stale > 0 ? exit_stale : 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "handout_listings: error: %s\n", error.what());
        return ctlab::exit_bad_input;
    }
}
