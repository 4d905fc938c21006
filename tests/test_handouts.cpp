// test_handouts.cpp: the handouts cannot drift from the code. Every step has a handout listed
// in handouts/README.md; every listing is the exact text between its markers; its "What you
// write" section names every lesson function the student kit stubs; every file, image, link
// and `function()` a handout names exists; every quoted --debug-pixel trace is what the step
// prints today. Paths are relative to the repository root, where tests run.
#include <doctest/doctest.h>
#include "harness.h"
#include "tools/run_step.h"
#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <sstream>
#include <string>
#include <vector>
#include "tools/lesson_markers.h"

namespace fs = std::filesystem;

namespace {

struct Step {
    std::string stem;  // "05_interpolated_hits"
    std::string number;
};

std::vector<Step> steps() {
    std::vector<Step> result;
    const std::regex step_file("([0-9]{2})_[a-z0-9_]+\\.cpp");
    for (const auto& item : fs::directory_iterator("steps")) {
        const std::string name = item.path().filename().string();
        std::smatch match;
        if (std::regex_match(name, match, step_file)) {
            result.push_back({item.path().stem().string(), match[1]});
        }
    }
    std::sort(result.begin(), result.end(),
              [](const Step& a, const Step& b) { return a.stem < b.stem; });
    return result;
}

std::vector<std::string> handouts() {
    std::vector<std::string> paths;
    for (const auto& item : fs::directory_iterator("handouts")) {
        if (item.path().extension() == ".md") paths.push_back(item.path().generic_string());
    }
    std::sort(paths.begin(), paths.end());
    return paths;
}

// The handout's prose: its text with the listings' contents left out (code is not prose).
std::string prose(const std::string& markdown, const std::string& path) {
    std::string text;
    size_t copied = 0;
    for (const lesson::Listing& listing : lesson::find_listings(markdown, path)) {
        text += markdown.substr(copied, listing.content_begin - copied);
        copied = listing.content_end;
    }
    return text + markdown.substr(copied);
}

// The code (comments and strings blanked) in which a handout's `name()` must be defined
// or called: its own step and the common headers; for the other handouts, every step and tool.
std::string code_for(const std::string& handout) {
    std::vector<std::string> files;
    const std::string stem = fs::path(handout).stem().string();
    const bool step_handout = fs::exists("steps/" + stem + ".cpp");
    if (step_handout) files.push_back("steps/" + stem + ".cpp");
    for (const char* folder : {"common", "steps", "tools"}) {
        if (step_handout && std::string(folder) != "common") continue;
        for (const auto& item : fs::directory_iterator(folder)) {
            const std::string extension = item.path().extension().string();
            const bool header = extension == ".h";
            if (header || (!step_handout && extension == ".cpp")) {
                files.push_back(item.path().generic_string());
            }
        }
    }
    std::string code;
    for (const std::string& file : files) code += lesson::mask_code(lesson::read_text(file));
    return code;
}

// What .gitignore lists (build output, the real data set): a handout may name these paths
// although a fresh clone does not have them.
std::vector<std::string> ignored_paths() {
    std::vector<std::string> paths;
    std::istringstream lines(fs::exists(".gitignore") ? lesson::read_text(".gitignore") : "");
    for (std::string line; std::getline(lines, line);) {
        line = lesson::trim(line);
        if (!line.empty() && line[0] != '#') paths.push_back(line);
    }
    return paths;
}

bool is_ignored(const std::string& path, const std::vector<std::string>& ignored) {
    for (const std::string& pattern : ignored) {
        const bool folder = pattern.back() == '/';
        if (path == pattern || (folder && path.rfind(pattern, 0) == 0)) return true;
    }
    return false;
}

// Does `code` call or define name(): the whole identifier, then "(" after any white space.
// (A plain scan: a std::regex over every step's code for each name cost seconds.)
bool names_function(const std::string& code, const std::string& name) {
    auto identifier = [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
    };
    for (size_t at = code.find(name); at != std::string::npos; at = code.find(name, at + 1)) {
        if (at > 0 && identifier(code[at - 1])) continue;
        size_t after = at + name.size();
        while (after < code.size() && std::isspace(static_cast<unsigned char>(code[after]))) {
            ++after;
        }
        if (after < code.size() && code[after] == '(') return true;
    }
    return false;
}

// A quoted trace: a ```text block whose first line is the command, "$ build/STEP ARGUMENTS",
// followed by lines it prints ("..." stands for lines left out).
struct QuotedTrace {
    std::string step, arguments;
    int line = 0;
    std::vector<std::string> lines;
};

std::vector<QuotedTrace> quoted_traces(const std::string& markdown) {
    std::vector<QuotedTrace> traces;
    const std::string opener = "```text\n$ build/";
    for (size_t at = markdown.find(opener); at != std::string::npos;
         at = markdown.find(opener, at + 1)) {
        QuotedTrace trace;
        trace.line = lesson::line_of(markdown, at) + 1;
        const size_t end = markdown.find("\n```", at + opener.size());
        std::istringstream lines(markdown.substr(at + opener.size(), end - at - opener.size()));
        std::string command;
        std::getline(lines, command);
        std::istringstream words(command);
        words >> trace.step;
        std::getline(words, trace.arguments);
        for (std::string line; std::getline(lines, line);) trace.lines.push_back(line);
        traces.push_back(trace);
    }
    return traces;
}


// What a shell command prints on stdout.
std::string output_of(const std::string& command) {
    std::string text;
    if (FILE* pipe = popen(command.c_str(), "r")) {
        char buffer[4096];
        for (size_t got; (got = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) {
            text.append(buffer, got);
        }
        pclose(pipe);
    }
    return text;
}

}  // namespace

TEST_CASE("every step has a handout, and handouts/README.md links to each") {
    REQUIRE_MESSAGE(fs::is_directory("handouts"), "run the tests from the repository root");
    const std::string index = lesson::read_text("handouts/README.md");
    const std::vector<Step> all = steps();
    REQUIRE(!all.empty());
    for (const Step& step : all) {
        INFO("step " << step.stem);
        CHECK_MESSAGE(fs::exists("handouts/" + step.stem + ".md"),
                      "missing handouts/" << step.stem << ".md");
        CHECK_MESSAGE(index.find("(" + step.stem + ".md)") != std::string::npos,
                      "handouts/README.md does not link to " << step.stem << ".md");
        // The title and the index's link text carry the step's number: a renumbered step
        // must not keep its old one.
        if (fs::exists("handouts/" + step.stem + ".md")) {
            const std::string handout = lesson::read_text("handouts/" + step.stem + ".md");
            CHECK_MESSAGE(handout.rfind("# " + step.number + " \u00b7 ", 0) == 0,
                          "its title does not start with '# " << step.number << " \u00b7'");
        }
        CHECK_MESSAGE(index.find("[" + step.number + " \u00b7 ") != std::string::npos,
                      "handouts/README.md has no link text '[" << step.number << " \u00b7'");
    }
}

TEST_CASE("every listing in a handout is the exact text between its markers") {
    int listings = 0;
    for (const std::string& handout : handouts()) {
        const std::string markdown = lesson::read_text(handout);
        for (const lesson::Listing& listing : lesson::find_listings(markdown, handout)) {
            ++listings;
            INFO(handout << ":" << listing.line << ": " << listing.path << " "
                         << listing.marker << " " << listing.function);
            std::string expected;
            try {
                expected = lesson::listing_text(
                    lesson::read_listed_file(".", listing, handout), listing, handout);
            } catch (const ctlab::InputError& error) {
                FAIL_CHECK(error.what());
                continue;
            }
            const std::string quoted = markdown.substr(
                listing.content_begin, listing.content_end - listing.content_begin);
            CHECK_MESSAGE(quoted == expected, "the listing differs from the code: run make "
                                              "handouts");
        }
    }
    CHECK(listings > 0);
}

TEST_CASE("each step's handout quotes its own step and shows what is new with make diff") {
    for (const Step& step : steps()) {
        const std::string path = "handouts/" + step.stem + ".md";
        if (!fs::exists(path)) continue;  // reported by the first test
        INFO(path);
        const std::string markdown = lesson::read_text(path);
        bool quotes_own_step = false;
        for (const lesson::Listing& listing : lesson::find_listings(markdown, path)) {
            quotes_own_step = quotes_own_step || listing.path == "steps/" + step.stem + ".cpp";
        }
        CHECK_MESSAGE(quotes_own_step, "no listing of steps/" << step.stem << ".cpp");
        if (step.number != "00") {
            CHECK_MESSAGE(markdown.find("make diff STEP=" + step.number) != std::string::npos,
                          "does not mention make diff STEP=" << step.number);
        }
    }
}

TEST_CASE("each step's handout says what the student writes: every lesson function, by name") {
    // The student kit stubs every lesson function (tools/make_student.cpp), so the handout's
    // "What you write" section names each one, `name(...)` or `name()`: with its formula, or
    // saying where the student's earlier version comes from.
    for (const Step& step : steps()) {
        const std::string path = "handouts/" + step.stem + ".md";
        if (!fs::exists(path)) continue;  // reported by the first test
        INFO(path);
        const std::string markdown = lesson::read_text(path);
        const size_t start = markdown.find("\n## What you write\n");
        if (start == std::string::npos) {
            FAIL_CHECK("no \"## What you write\" section");
            continue;
        }
        const size_t end = markdown.find("\n## ", start + 1);
        const std::string section = markdown.substr(start, end - start);
        const std::string source = lesson::read_text("steps/" + step.stem + ".cpp");
        const auto functions = lesson::lesson_functions(source, lesson::mask_code(source),
                                                        "steps/" + step.stem + ".cpp");
        CHECK(!functions.empty());
        for (const lesson::Function& function : functions) {
            CHECK_MESSAGE(section.find("`" + function.name + "(") != std::string::npos,
                          "\"What you write\" does not name " << function.name << "()");
        }
    }
}

TEST_CASE("handouts name only files, images, links and functions that exist") {
    // [text](target) and ![alt](target): relative targets are resolved from handouts/.
    const std::regex link("\\]\\(([^)\\s]+)\\)");
    // `steps/02_threshold.cpp`, `data/reference/...png`: repository paths in backticks.
    const std::regex path_in_code("`((steps|common|tools|tests|data|handouts)/[^`\\s]+)`");
    // `first_hit()` or `View::voxel()` in the prose.
    const std::regex function_in_code("`([A-Za-z_][A-Za-z0-9_]*(::[A-Za-z_][A-Za-z0-9_]*)*)"
                                      "\\(\\)`");
    const std::vector<std::string> ignored = ignored_paths();
    int links = 0, paths = 0, functions = 0;
    for (const std::string& handout : handouts()) {
        const std::string text = prose(lesson::read_text(handout), handout);
        const std::string code = code_for(handout);
        for (auto it = std::sregex_iterator(text.begin(), text.end(), link);
             it != std::sregex_iterator(); ++it) {
            std::string target = (*it)[1];
            if (target.find("://") != std::string::npos || target[0] == '#' ||
                target.rfind("mailto:", 0) == 0) {
                continue;
            }
            target = target.substr(0, target.find('#'));
            ++links;
            CHECK_MESSAGE(fs::exists(fs::path("handouts") / target),
                          handout << " links to " << target << ", which does not exist");
        }
        for (auto it = std::sregex_iterator(text.begin(), text.end(), path_in_code);
             it != std::sregex_iterator(); ++it) {
            const std::string path = (*it)[1];
            if (path.find_first_of("<*") != std::string::npos ||
                path.find("NN") != std::string::npos || path.find("...") != std::string::npos ||
                is_ignored(path, ignored)) {
                continue;  // a pattern such as data/reference/NN_name_<view>.png, or data/CThead
            }
            ++paths;
            CHECK_MESSAGE(fs::exists(path), handout << " names " << path
                                                    << ", which does not exist");
        }
        for (auto it = std::sregex_iterator(text.begin(), text.end(), function_in_code);
             it != std::sregex_iterator(); ++it) {
            std::string name = (*it)[1];
            if (name.rfind("std::", 0) == 0) continue;  // the standard library's
            name = name.substr(name.rfind(':') == std::string::npos ? 0 : name.rfind(':') + 1);
            ++functions;
            CHECK_MESSAGE(names_function(code, name),
                          handout << " names " << name << "(), which is not in the code "
                                  << "(for a step's handout: the step or common/*.h)");
        }
    }
    CHECK(links > 0);
    CHECK(paths > 0);
    CHECK(functions > 0);
}

TEST_CASE("every quoted --debug-pixel trace is what the step prints") {
    if (fs::exists(".ctlab-student")) {
        MESSAGE("skipped in a student tree: the traces are the solution's, the code the student's");
        return;
    }
    const std::string build = ctlab::build_folder();  // the steps are beside the tests
    const fs::path out = fs::temp_directory_path() / ("ctlab_handout_traces_" +
                                                      std::to_string(getpid()));
    int traces = 0;
    for (const std::string& handout : handouts()) {
        for (const QuotedTrace& trace : quoted_traces(lesson::read_text(handout))) {
            ++traces;
            INFO(handout << ":" << trace.line << ": trace of " << trace.step << trace.arguments);
            const std::string binary = build + "/" + trace.step;
            if (!fs::exists(binary)) {
                FAIL_CHECK(binary << " is not built");
                continue;
            }
            // --volume phantom: the same voxels and spacing loaded from the raw file of the
            // phantom painted once in this process (harness.h), not painted by every run; a
            // trace names no volume, so it prints the same lines.
            std::string arguments = trace.arguments;
            const std::string built_in = " --volume phantom ";
            const size_t at = (arguments + " ").find(built_in);
            if (at != std::string::npos) {
                std::string raw;
                for (const std::string& flag : ctlab_test::phantom_flags()) raw += " " + flag;
                arguments.replace(at, built_in.size() - 1, raw);
            }
            std::string command = binary + arguments + " --out " + out.string();
            if (trace.arguments.find("--no-window") == std::string::npos) {
                command += " --no-window";
            }
            // The trace is all a quoted run is read for: its rays alone are cast (no picture
            // rendered, no ray picture drawn), as a whole run would cast them.
            bool whole_picture = false;  // a run that asks for a file of the whole picture
            for (const char* flag : {"--pfm", "--work-map", "--repeat"}) {
                whole_picture = whole_picture || (arguments + " ").find(std::string(" ") + flag +
                                                                        " ") != std::string::npos;
            }
            if (!whole_picture) command += " --trace-only --no-ray-picture";
            std::istringstream printed(output_of(command + " 2>&1"));
            // Each quoted line, "..." aside, must be printed, in the same order.
            std::string line;
            for (const std::string& quoted : trace.lines) {
                if (lesson::trim(quoted) == "...") continue;
                bool found = false;
                while (!found && std::getline(printed, line)) found = line == quoted;
                CHECK_MESSAGE(found, "the step no longer prints: " << quoted);
                if (!found) break;
            }
        }
    }
    std::error_code ignored;
    fs::remove_all(out, ignored);
    CHECK(traces > 0);
}
