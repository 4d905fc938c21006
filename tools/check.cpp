// check.cpp: the instructor's submission checker. Compares a student's PNGs with the
// reference images, one pair or a whole folder, and says pass or fail with the numbers.
//
//   build/check STUDENT.png REFERENCE.png [--tol N] [--diff OUT.png]
//   build/check --submission DIR [--reference DIR] [--tol N] [--report OUT_PREFIX]
//
// Errors are in 8-bit units after quantising both pictures; a pixel fails when one of its
// channels differs by more than --tol. Exit status: 0 pass, 1 fail, 2 bad input.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>
#include <unistd.h>
#include "args.h"
#include "compare.h"
#include "error.h"
#include "image.h"

using namespace ctlab;
namespace fs = std::filesystem;

namespace {

constexpr double default_tolerance = 2;  // 8-bit units: rounding differences pass
constexpr double max_tolerance = 255;    // 8-bit units: above this every picture passes
constexpr int exit_pass = 0, exit_fail = 1;
const char* const default_reference = "data/reference";
const char* const report_stem = "check_report";  // DIR/check_report.md and .csv
const char* const diff_folder = "check_diffs";   // DIR/check_diffs/NAME.png for failures

// Only NN_name_top|front|side.png count: variants (..._front_skin030.png), manifests and
// anything else in the reference folder are not expected from the student.
const std::regex expected_name("^[0-9]{2}_[a-z0-9_]+_(top|front|side)\\.png$");

const char* const usage_text =
    "usage: check STUDENT.png REFERENCE.png [--tol N] [--diff OUT.png]\n"
    "       check --submission DIR [--reference DIR] [--tol N] [--report OUT_PREFIX]\n"
    "\n"
    "Compares pictures after rounding both to 8 bits per channel. Errors are in 8-bit\n"
    "units (0..255); a pixel fails when any channel differs by more than the tolerance.\n"
    "\n"
    "  --tol N             tolerance in 8-bit units, a number from 0 to 255 (default 2)\n"
    "  --diff OUT.png      one pair: write a heat map of the differences (black = equal,\n"
    "                      blue = within the tolerance, magenta, yellow, white = largest)\n"
    "  --submission DIR    a whole folder: every NN_name_top|front|side.png of the\n"
    "                      reference folder is expected in DIR, under the same name\n"
    "  --reference DIR     the reference folder (default data/reference)\n"
    "  --report PREFIX     writes PREFIX.md and PREFIX.csv (default DIR/check_report);\n"
    "                      heat maps of failing pictures go to DIR/check_diffs/\n"
    "  --help              this text\n"
    "\n"
    "One pair prints: max_abs= mean_abs= rmse= psnr_db= over_tol_pct= tol= result=\n"
    "Exit status: 0 all pass, 1 a picture fails or is missing, 2 bad input.\n";

struct Settings {
    std::vector<std::string> files;  // STUDENT.png REFERENCE.png
    double tolerance = default_tolerance;
    std::string diff, submission, reference, report;
    bool has_submission = false, has_reference = false, has_report = false, help = false;
};

Settings parse_arguments(int argc, char** argv) {
    Settings settings;
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        auto take_value = [&]() -> std::string {
            if (a + 1 >= argc) throw InputError(arg + ": expected a value after it");
            return argv[++a];
        };
        if (arg == "--help" || arg == "-h") {
            settings.help = true;
        } else if (arg == "--tol") {
            settings.tolerance = parse_double(arg, take_value(), 0, max_tolerance);
        } else if (arg == "--diff") {
            settings.diff = take_value();
        } else if (arg == "--submission") {
            settings.submission = take_value();
            settings.has_submission = true;
        } else if (arg == "--reference") {
            settings.reference = take_value();
            settings.has_reference = true;
        } else if (arg == "--report") {
            settings.report = take_value();
            settings.has_report = true;
        } else if (arg.size() > 1 && arg[0] == '-') {
            throw InputError("unknown flag '" + arg + "' (see check --help)");
        } else {
            settings.files.push_back(arg);
        }
    }
    if (settings.help) return settings;
    if (settings.has_submission) {
        if (settings.submission.empty()) throw InputError("--submission: expected a folder");
        if (!settings.files.empty()) {
            throw InputError("--submission compares a folder: no picture names expected, got '" +
                             settings.files[0] + "'");
        }
        if (!settings.diff.empty()) {
            throw InputError("--diff is for one pair; --submission writes its heat maps to " +
                             settings.submission + "/" + diff_folder);
        }
        if (settings.has_reference && settings.reference.empty()) {
            throw InputError("--reference: expected a folder, got ''");
        }
        if (settings.has_report && settings.report.empty()) {
            throw InputError("--report: expected a file name prefix, got ''");
        }
        return settings;
    }
    if (settings.has_reference || settings.has_report) {
        throw InputError("--reference and --report need --submission DIR");
    }
    if (settings.files.size() != 2) {
        throw InputError("expected STUDENT.png REFERENCE.png or --submission DIR, got " +
                         std::to_string(settings.files.size()) + " file names (see --help)");
    }
    return settings;
}

// --- One pair ----------------------------------------------------------------------------

int check_pair(const Settings& settings) {
    const std::string& student_path = settings.files[0];
    const std::string& reference_path = settings.files[1];
    const Image student = read_image(student_path);
    const Image reference = read_image(reference_path);
    const Comparison result =
        compare_images(student, reference, settings.tolerance, student_path, reference_path);
    if (!settings.diff.empty()) {
        write_png(diff_heat_map(student, reference, settings.tolerance), settings.diff);
    }
    std::printf("%s\n", comparison_line(result).c_str());
    return result.pass ? exit_pass : exit_fail;
}

// --- A whole folder ------------------------------------------------------------------------

struct Row {
    std::string file;
    std::string result;        // pass, fail, error, missing or extra
    bool has_numbers = false;  // pass and fail rows carry the metrics
    Comparison numbers;
    std::string note;          // why a row is an error
};

void require_folder(const std::string& path, const std::string& what) {
    std::error_code error;
    const fs::file_status status = fs::status(path, error);
    if (!fs::exists(status)) throw InputError(what + " '" + path + "' does not exist");
    if (!fs::is_directory(status)) throw InputError(what + " '" + path + "' is not a folder");
}

// Names of the regular files directly in `folder` (sorted).
std::vector<std::string> file_names(const std::string& folder) {
    std::vector<std::string> names;
    std::error_code error;
    for (const fs::directory_entry& entry : fs::directory_iterator(folder, error)) {
        std::error_code ignored;
        if (entry.is_regular_file(ignored)) names.push_back(entry.path().filename().string());
    }
    if (error) throw InputError("cannot list '" + folder + "': " + error.message());
    std::sort(names.begin(), names.end());
    return names;
}

bool has_png_extension(const std::string& name) {
    if (name.size() < 4) return false;
    std::string extension = name.substr(name.size() - 4);
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return extension == ".png";
}

const std::vector<std::string> metrics = {"max_abs", "mean_abs", "rmse", "psnr_db",
                                          "over_tol_pct"};
const std::vector<std::string> columns = {"file",     "result", "max_abs",      "mean_abs",
                                          "rmse",     "psnr_db", "over_tol_pct", "note"};

// A row as the text of its columns (no metrics for missing, extra and error rows).
std::vector<std::string> cells(const Row& row) {
    std::vector<std::string> result = {row.file, row.result};
    std::map<std::string, std::string> values;
    if (row.has_numbers) {
        for (const auto& [name, value] : comparison_fields(row.numbers)) values[name] = value;
    }
    for (const std::string& metric : metrics) result.push_back(values[metric]);
    result.push_back(row.note);
    return result;
}

std::string csv_field(const std::string& text) {
    if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

std::string markdown_field(std::string text) {
    for (size_t at = 0; (at = text.find('|', at)) != std::string::npos; at += 2) {
        text.replace(at, 1, "\\|");
    }
    std::replace(text.begin(), text.end(), '\n', ' ');
    return text;
}

// Writes beside the target and renames, so a half-written report never appears.
void write_text(const std::string& path, const std::string& text) {
    const fs::path parent = fs::path(path).parent_path();
    if (!parent.empty()) make_folder(parent.string());
    const std::string temporary = path + ".tmp" + std::to_string(getpid());
    {
        std::ofstream file(temporary, std::ios::binary);
        file << text;
        file.close();
        if (!file) {
            std::remove(temporary.c_str());
            throw InputError("cannot write '" + path + "'");
        }
    }
    std::error_code error;
    fs::rename(temporary, path, error);
    if (error) {
        std::remove(temporary.c_str());
        throw InputError("cannot write '" + path + "': " + error.message());
    }
}

void print_table(const std::vector<Row>& rows) {
    std::vector<size_t> widths(columns.size());
    for (size_t c = 0; c < columns.size(); ++c) widths[c] = columns[c].size();
    for (const Row& row : rows) {
        const std::vector<std::string> text = cells(row);
        for (size_t c = 0; c < text.size(); ++c) widths[c] = std::max(widths[c], text[c].size());
    }
    auto print_line = [&](const std::vector<std::string>& text) {
        std::string line;
        for (size_t c = 0; c < text.size(); ++c) {
            const bool left = c < 2 || c + 1 == text.size();  // names left, numbers right
            const std::string pad(widths[c] - text[c].size(), ' ');
            line += (c ? "  " : "") + (left ? text[c] + pad : pad + text[c]);
        }
        while (!line.empty() && line.back() == ' ') line.pop_back();
        std::printf("%s\n", line.c_str());
    };
    print_line(columns);
    for (const Row& row : rows) print_line(cells(row));
}

std::string markdown_report(const Settings& settings, const std::string& reference,
                            const std::vector<Row>& rows, const std::string& summary) {
    std::string text = "# Check report\n\n";
    text += "- submission: `" + settings.submission + "`\n";
    text += "- reference: `" + reference + "`\n";
    char tolerance[32];
    std::snprintf(tolerance, sizeof tolerance, "%g", settings.tolerance);
    text += "- tolerance: " + std::string(tolerance) + " (8-bit units)\n";
    text += "- " + summary + "\n\n";
    std::string header = "|", rule = "|";
    for (const std::string& column : columns) {
        header += " " + column + " |";
        rule += column == "file" || column == "result" || column == "note" ? "---|" : "--:|";
    }
    text += header + "\n" + rule + "\n";
    for (const Row& row : rows) {
        std::string line = "|";
        for (const std::string& cell : cells(row)) line += " " + markdown_field(cell) + " |";
        text += line + "\n";
    }
    return text;
}

std::string csv_report(const std::vector<Row>& rows) {
    std::string text;
    auto add_line = [&](const std::vector<std::string>& fields) {
        for (size_t f = 0; f < fields.size(); ++f) text += (f ? "," : "") + csv_field(fields[f]);
        text += "\n";
    };
    add_line(columns);
    for (const Row& row : rows) add_line(cells(row));
    return text;
}

// Checks one expected picture; a student picture that cannot be read is an error row,
// a reference that cannot be read stops the run (bad input).
Row check_one(const Settings& settings, const std::string& reference_folder,
              const std::string& name) {
    const std::string student_path = (fs::path(settings.submission) / name).string();
    const std::string reference_path = (fs::path(reference_folder) / name).string();
    const std::string diff_path =
        (fs::path(settings.submission) / diff_folder / name).string();
    const Image reference = read_image(reference_path);
    Row row{name, "error", false, {}, ""};
    Image student;
    try {
        student = read_image(student_path);
        row.numbers = compare_images(student, reference, settings.tolerance, student_path,
                                     reference_path);
    } catch (const InputError& error) {
        row.note = error.what();
        return row;
    }
    row.has_numbers = true;
    row.result = row.numbers.pass ? "pass" : "fail";
    std::error_code ignored;
    if (row.numbers.pass) {
        fs::remove(diff_path, ignored);  // a heat map left from an earlier, failing run
    } else {
        write_png(diff_heat_map(student, reference, settings.tolerance), diff_path);
    }
    return row;
}

int check_folder(const Settings& settings) {
    const std::string reference_folder =
        settings.has_reference ? settings.reference : default_reference;
    require_folder(settings.submission, "submission folder");
    require_folder(reference_folder, "reference folder");

    std::vector<std::string> expected;
    for (const std::string& name : file_names(reference_folder)) {
        if (std::regex_match(name, expected_name)) expected.push_back(name);
    }
    if (expected.empty()) {
        throw InputError("reference folder '" + reference_folder +
                         "' has no pictures named NN_name_top|front|side.png");
    }
    std::set<std::string> submitted;
    for (const std::string& name : file_names(settings.submission)) {
        if (has_png_extension(name)) submitted.insert(name);
    }

    std::vector<Row> rows;
    std::map<std::string, int> counts;  // result -> number of rows
    for (const std::string& name : expected) {
        if (!submitted.count(name)) {
            rows.push_back({name, "missing", false, {}, "not in the submission"});
        } else {
            rows.push_back(check_one(settings, reference_folder, name));
        }
        ++counts[rows.back().result];
    }
    const std::set<std::string> expected_set(expected.begin(), expected.end());
    for (const std::string& name : submitted) {
        if (expected_set.count(name)) continue;
        rows.push_back({name, "extra", false, {}, "not in the reference folder"});
        ++counts["extra"];
    }

    const bool all_pass = counts["pass"] == static_cast<int>(expected.size());
    const std::string summary =
        std::to_string(expected.size()) + " expected: " + std::to_string(counts["pass"]) +
        " pass, " + std::to_string(counts["fail"]) + " fail, " +
        std::to_string(counts["error"]) + " error, " + std::to_string(counts["missing"]) +
        " missing; " + std::to_string(counts["extra"]) + " extra; result=" +
        (all_pass ? "pass" : "fail");

    const std::string prefix = settings.has_report
        ? settings.report
        : (fs::path(settings.submission) / report_stem).string();
    write_text(prefix + ".md", markdown_report(settings, reference_folder, rows, summary));
    write_text(prefix + ".csv", csv_report(rows));

    std::error_code ignored;
    fs::remove(fs::path(settings.submission) / diff_folder, ignored);  // only if left empty
    print_table(rows);
    std::printf("%s\n", summary.c_str());
    std::printf("report: %s.md %s.csv\n", prefix.c_str(), prefix.c_str());
    if (counts["fail"] > 0) {
        std::printf("heat maps of failing pictures: %s\n",
                    (fs::path(settings.submission) / diff_folder).string().c_str());
    }
    return all_pass ? exit_pass : exit_fail;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        const Settings settings = parse_arguments(argc, argv);
        if (settings.help) {
            std::printf("%s", usage_text);
            return exit_pass;
        }
        return settings.has_submission ? check_folder(settings) : check_pair(settings);
    } catch (const std::exception& error) {
        // InputError, or a picture too large for memory: either way the input is at fault.
        std::fprintf(stderr, "check: error: %s\n", error.what());
        return exit_bad_input;
    }
}
