// measured.cpp: copies measured figures into the handouts, so that a handout quotes a
// measurement only as the command that measured it last wrote it (`make bench` and
// `make study` run this after measuring; later speed work just reruns them).
//
//   build/measured [--check] SOURCE.md [HANDOUT.md ...]     (default: every handouts/*.md)
//
// A measuring tool marks each figure it writes into SOURCE.md (out/bench.md, out/study/...):
//     <!-- section: NAME -->
//     ...a table, a sentence...
//     <!-- end section -->
// and a handout quotes it in a block of the same NAME:
//     <!-- measured: NAME -->
//     ...
//     <!-- end measured -->
// Every block whose NAME the SOURCE has is rewritten with the section's text; blocks of other
// names (another tool's) are left alone. Prints how many blocks it rewrote and which names
// no block quotes. --check writes nothing and exits 1 when a block differs from SOURCE.
// A block or section without its end line, or a name given twice in SOURCE, is bad input
// (exit status 2).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>
#include "error.h"

using ctlab::InputError;
namespace fs = std::filesystem;

namespace {

constexpr int exit_stale = 1;  // --check: a block differs from SOURCE
const std::string section_open = "<!-- section: ", section_close = "<!-- end section -->";
const std::string block_open = "<!-- measured: ", block_close = "<!-- end measured -->";
const std::string marker_end = " -->";

std::string read_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError("cannot read '" + path + "'");
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
}

// NAME when the line is exactly OPEN NAME " -->", else "".
std::string marker_name(const std::string& line, const std::string& open) {
    if (line.compare(0, open.size(), open) != 0 || line.size() <= open.size() + marker_end.size() ||
        line.compare(line.size() - marker_end.size(), marker_end.size(), marker_end) != 0) {
        return "";
    }
    return line.substr(open.size(), line.size() - open.size() - marker_end.size());
}

// The sections of SOURCE: NAME -> the lines between its markers, joined with newlines.
std::map<std::string, std::string> sections_of(const std::string& path) {
    std::map<std::string, std::string> sections;
    const std::vector<std::string> lines = lines_of(read_text(path));
    for (size_t n = 0; n < lines.size(); ++n) {
        const std::string name = marker_name(lines[n], section_open);
        if (name.empty()) continue;
        if (sections.count(name)) throw InputError(path + ": section '" + name + "' twice");
        std::string body;
        size_t end = n + 1;
        for (; end < lines.size() && lines[end] != section_close; ++end) body += lines[end] + "\n";
        if (end == lines.size()) {
            throw InputError(path + ":" + std::to_string(n + 1) + ": section '" + name +
                             "' has no '" + section_close + "' line");
        }
        sections[name] = body;
        n = end;
    }
    return sections;
}

// The handout with every block SOURCE has a section for rewritten; counts them in `used`.
std::string rewritten(const std::string& path, const std::map<std::string, std::string>& sections,
                      std::set<std::string>& used, int& blocks) {
    const std::vector<std::string> lines = lines_of(read_text(path));
    std::string out;
    for (size_t n = 0; n < lines.size(); ++n) {
        out += lines[n] + "\n";
        const std::string name = marker_name(lines[n], block_open);
        if (name.empty()) continue;
        size_t end = n + 1;
        while (end < lines.size() && lines[end] != block_close) ++end;
        if (end == lines.size()) {
            throw InputError(path + ":" + std::to_string(n + 1) + ": block '" + name +
                             "' has no '" + block_close + "' line");
        }
        const auto section = sections.find(name);
        if (section == sections.end()) {  // another tool's figures: keep them
            for (size_t m = n + 1; m < end; ++m) out += lines[m] + "\n";
        } else {
            out += section->second;
            used.insert(name);
            ++blocks;
        }
        out += lines[end] + "\n";
        n = end;
    }
    return out;
}

int run(int argc, char** argv) {
    bool check = false;
    std::string source;
    std::vector<std::string> handouts;
    for (int n = 1; n < argc; ++n) {
        const std::string arg = argv[n];
        if (arg == "--help" || arg == "-h") {
            std::printf("usage: measured [--check] SOURCE.md [HANDOUT.md ...]\n"
                        "Copies SOURCE.md's measured sections into the handouts' blocks of the "
                        "same name\n(default: every handouts/*.md); --check only reports "
                        "blocks that differ (exit 1).\n");
            return 0;
        }
        if (arg == "--check") check = true;
        else if (source.empty()) source = arg;
        else handouts.push_back(arg);
    }
    if (source.empty()) {
        throw InputError("usage: measured [--check] SOURCE.md [HANDOUT.md ...]");
    }
    if (handouts.empty()) {
        for (const auto& entry : fs::directory_iterator("handouts")) {
            if (entry.path().extension() == ".md") handouts.push_back(entry.path().string());
        }
    }
    const std::map<std::string, std::string> sections = sections_of(source);
    std::set<std::string> used;
    int blocks = 0, stale = 0;
    for (const std::string& path : handouts) {
        const std::string before = read_text(path);
        const std::string after = rewritten(path, sections, used, blocks);
        if (after == before) continue;
        ++stale;
        if (check) {
            std::printf("measured: %s quotes figures that differ from %s\n", path.c_str(),
                        source.c_str());
            continue;
        }
        const std::string temporary = path + ".measured.tmp";
        {
            std::ofstream out(temporary, std::ios::binary);
            out << after;
            if (!out) throw InputError("cannot write '" + temporary + "'");
        }
        fs::rename(temporary, path);
    }
    std::string unquoted;
    for (const auto& [name, body] : sections) {
        if (!used.count(name)) unquoted += " " + name;
    }
    std::printf("measured: %d blocks from %s, %d handouts %s%s%s\n", blocks, source.c_str(),
                stale, check ? "differ" : "rewritten",
                unquoted.empty() ? "" : "; quoted nowhere:", unquoted.c_str());
    return check && stale > 0 ? exit_stale : 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "measured: error: %s\n", error.what());
        return ctlab::exit_bad_input;
    }
}
