// transfer_function.cpp: the .tf text format (see data/tf/classic.tf) and its checks.
#include "transfer_function.h"
#include <sys/stat.h>
#include <cerrno>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include "error.h"
#include "volume.h"

namespace ctlab {

// The same ranges as data/tf/classic.tf, for runs from a folder without data/.
static const char* const classic_text =
    "-300    50 constant 1.0 0.79 0.6 0.12 skin\n"
    " 300 32768 constant 1.0 1.0  1.0 0.8  bone\n";
static const char* const classic_source = "built-in-classic";
// No real transfer function comes near this; the cap bounds the memory a file can ask for.
constexpr long long max_tf_bytes = 1 << 20;
static const char* const utf8_bom = "\xEF\xBB\xBF";
static const char* const non_breaking_space = "\xC2\xA0";  // U+00A0 in UTF-8

namespace {

// A piece of the file quoted in a message: at most 40 characters, so that a damaged file
// cannot flood the terminal.
std::string shown(const std::string& text) {
    constexpr size_t longest = 40;
    return text.size() <= longest ? text : text.substr(0, longest) + "...";
}

bool looks_like_number(const std::string& text) {
    char* end = nullptr;
    std::strtod(text.c_str(), &end);
    return end != text.c_str() && *end == '\0';
}

// Reads one line's fields and reports problems as "SOURCE:LINE: ...".
struct LineReader {
    std::string source;
    int line = 0;

    // Control characters of a binary or damaged file become '?': the message stays one line.
    [[noreturn]] void fail(std::string message) const {
        for (char& c : message) {
            if ((c >= 0 && c < ' ') || c == 127) c = '?';
        }
        throw InputError(source + ":" + std::to_string(line) + ": " + message);
    }

    int ct_value(const std::string& name, const std::string& text) const {
        errno = 0;
        char* end = nullptr;
        const long value = std::strtol(text.c_str(), &end, 10);
        // The whole field must be the number (a NUL byte inside would end c_str() early).
        if (end != text.c_str() + text.size() || errno == ERANGE) {
            // A decimal is for a volume whose values are mapped (floats: map= on its line).
            const bool decimal = looks_like_number(text);
            fail(name + " must be a whole CT value, got '" + shown(text) + "'" +
                 (decimal ? " (this volume's values are whole numbers)" : ""));
        }
        if (value < lowest_ct_value || value > ct_value_end) {
            fail(name + " must be from " + std::to_string(lowest_ct_value) + " to " +
                 std::to_string(ct_value_end) + ", got " + shown(text));
        }
        return int(value);
    }

    // FROM or TO in the units of a file whose values are not int16's own: any finite number.
    double file_value(const std::string& name, const std::string& text) const {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || end != text.c_str() + text.size()) {
            fail(name + " must be a number (a value in the volume file's units), got '" +
                 shown(text) + "'");
        }
        if (!std::isfinite(value)) fail(name + " must be a finite number, got " + shown(text));
        return value;
    }

    // A colour channel or an opacity: a number from 0 to 1 (NaN and infinity refused).
    float unit_number(const std::string& name, const std::string& text) const {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (end != text.c_str() + text.size()) {
            fail(name + " must be a number from 0 to 1, got '" + shown(text) + "'");
        }
        if (std::isnan(value)) {
            fail(name + " is not a number (" + shown(text) + "), expected 0 to 1");
        }
        if (!(value >= 0 && value <= 1)) {
            fail(name + " must be from 0 to 1, got " + shown(text));
        }
        return float(value);
    }

    // Four fields from `first` on: R G B A.
    Rgba colour(const std::vector<std::string>& fields, size_t first,
                const std::string& which) const {
        return {unit_number(which + "red", fields[first]),
                unit_number(which + "green", fields[first + 1]),
                unit_number(which + "blue", fields[first + 2]),
                unit_number(which + "opacity", fields[first + 3])};
    }
};

// A FROM or TO as a message shows it: whole numbers as they are, others with 9 digits.
std::string value_text(double value) {
    char text[40];
    if (value == std::floor(value) && std::fabs(value) < 1e15) {
        std::snprintf(text, sizeof text, "%.0f", value);
    } else {
        std::snprintf(text, sizeof text, "%.9g", value);
    }
    return text;
}

// The range as the file gives it, in the file's units.
std::string range_text(const TfRange& range) {
    return "[" + value_text(range.file_from) + ", " + value_text(range.file_to) + ")";
}

// A FROM or TO in file units -> the volume's int16 values (see parse_transfer_function): a
// shift is exact (the smallest volume value whose file value is at least `file_value`); a
// scale rounds as store_samples() rounded each sample.
int volume_value(double file_value, const ValueMap& map) {
    const double value = map.scale == 1.0 ? std::ceil(file_value - map.offset)
                                          : std::round(map.to_volume(file_value));
    return int(std::clamp(value, double(lowest_ct_value), double(ct_value_end)));
}

}  // namespace

TransferFunction parse_transfer_function(const std::string& text, const std::string& source,
                                         const ValueMap& map) {
    TransferFunction tf;
    tf.source = source;
    std::istringstream lines(text);
    std::string line_text;
    LineReader reader{source, 0};
    // What an editor hides: named, since the field they spoil would look right on screen.
    if (text.compare(0, 3, utf8_bom) == 0) {
        reader.line = 1;
        reader.fail("the file starts with a UTF-8 byte order mark (bytes EF BB BF): save it "
                    "as UTF-8 without BOM");
    }
    const size_t cr = text.find('\r');
    if (cr != std::string::npos && (cr + 1 == text.size() || text[cr + 1] != '\n')) {
        reader.line = 1 + int(std::count(text.begin(), text.begin() + cr, '\n'));
        reader.fail("a line ends with CR alone (old Mac line endings): save the file with LF "
                    "(or CRLF) line endings");
    }
    while (std::getline(lines, line_text)) {
        ++reader.line;
        const size_t nbsp = line_text.find(non_breaking_space);
        if (nbsp != std::string::npos && nbsp < line_text.find('#')) {
            reader.fail("a non-breaking space (bytes C2 A0) at byte " +
                        std::to_string(nbsp + 1) + ": separate the fields with ordinary spaces");
        }
        const size_t comment = line_text.find('#');
        if (comment != std::string::npos) line_text.erase(comment);
        std::istringstream words(line_text);
        std::vector<std::string> fields;
        for (std::string word; words >> word;) fields.push_back(word);
        if (fields.empty()) continue;

        // FROM TO KIND, then 4 numbers (constant) or 8 (ramp), then an optional label.
        if (fields.size() < 3) {
            reader.fail("expected FROM TO constant|ramp R G B A ..., got '" + shown(line_text) +
                        "'");
        }
        TfRange range;
        range.line = reader.line;
        if (map.identity()) {  // CT values (or the file's whole numbers), as they are
            range.from = reader.ct_value("FROM", fields[0]);
            range.to = reader.ct_value("TO", fields[1]);
            range.file_from = range.from;
            range.file_to = range.to;
        } else {
            range.file_from = reader.file_value("FROM", fields[0]);
            range.file_to = reader.file_value("TO", fields[1]);
            range.from = volume_value(range.file_from, map);
            range.to = volume_value(range.file_to, map);
        }
        if (fields[2] != "constant" && fields[2] != "ramp") {
            reader.fail("the kind must be constant or ramp, got '" + shown(fields[2]) + "'");
        }
        range.ramp = fields[2] == "ramp";
        const size_t numbers = range.ramp ? 8 : 4;
        if (fields.size() != 3 + numbers && fields.size() != 4 + numbers) {
            reader.fail("a " + fields[2] + " range has FROM TO " + fields[2] + ", " +
                        std::to_string(numbers) + " numbers (" +
                        (range.ramp ? "R G B A at FROM, R G B A at TO" : "R G B A") +
                        ") and an optional label: " + std::to_string(fields.size()) +
                        " fields found");
        }
        if (range.file_from >= range.file_to) {
            reader.fail("FROM must be below TO, got " + fields[0] + " " + fields[1] +
                        " (the range is FROM <= value < TO)");
        }
        range.start = reader.colour(fields, 3, range.ramp ? "start " : "");
        range.end = range.ramp ? reader.colour(fields, 7, "end ") : range.start;
        if (fields.size() == 4 + numbers) {
            range.label = fields.back();
            if (looks_like_number(range.label)) {
                reader.fail("the label must be a name, got the number " + range.label +
                            " (too many numbers?)");
            }
        }

        // Sorted, not overlapping, and every label once.
        if (!tf.ranges.empty()) {
            const TfRange& previous = tf.ranges.back();
            if (range.file_from < previous.file_from) {
                reader.fail("ranges must be sorted by FROM: " + range_text(range) +
                            " comes after " + range_text(previous) + " on line " +
                            std::to_string(previous.line));
            }
            if (range.file_from < previous.file_to) {
                reader.fail("the range " + range_text(range) + " overlaps " +
                            range_text(previous) + " on line " + std::to_string(previous.line));
            }
        }
        if (!range.label.empty()) {
            if (const TfRange* same = find_range(tf, range.label)) {
                reader.fail("the label '" + shown(range.label) + "' is already used on line " +
                            std::to_string(same->line));
            }
        }
        tf.ranges.push_back(range);
    }
    return tf;
}

static bool file_exists(const std::string& path) {
    struct stat info {};
    return stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
}

// One line saying what the ranges became in the volume's values (only for a map that is not
// the identity: CT users see nothing new).
static void print_units(const TransferFunction& tf, const ValueMap& map) {
    if (map.identity()) return;
    std::string text = "units: --tf " + printable(tf.source) + " (file units)";
    constexpr size_t most_shown = 8;  // ranges: a long file still prints one short line
    for (size_t n = 0; n < tf.ranges.size() && n < most_shown; ++n) {
        const TfRange& range = tf.ranges[n];
        text += " " + range_text(range) + " = [" + std::to_string(range.from) + ", " +
                std::to_string(range.to) + ")";
    }
    if (tf.ranges.size() > most_shown) text += " ...";
    std::printf("%s in the volume's values\n", text.c_str());
}

TransferFunction load_transfer_function(const std::string& path, const ValueMap& map) {
    if (path.empty()) {
        if (!file_exists(classic_tf_path)) {
            TransferFunction tf = parse_transfer_function(classic_text, classic_source, map);
            print_units(tf, map);
            return tf;
        }
        return load_transfer_function(classic_tf_path, map);
    }
    std::vector<unsigned char> bytes;
    try {
        struct stat info {};
        if (stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode) &&
            info.st_size > max_tf_bytes) {
            throw InputError("'" + path + "' has " + std::to_string(info.st_size) +
                             " bytes, over the limit of " + std::to_string(max_tf_bytes) +
                             " bytes for a transfer function");
        }
        bytes = read_file_bytes(path);
    } catch (const InputError& error) {
        throw InputError(std::string("--tf: ") + error.what());
    }
    if (bytes.size() > size_t(max_tf_bytes)) {  // it grew after the check
        throw InputError("--tf: '" + path + "' is over the limit of " +
                         std::to_string(max_tf_bytes) + " bytes for a transfer function");
    }
    TransferFunction tf =
        parse_transfer_function(std::string(bytes.begin(), bytes.end()), path, map);
    print_units(tf, map);
    if (tf.ranges.empty()) {
        std::fprintf(stderr,
                     "note: %s has no ranges: every value is transparent, the pictures will be "
                     "black\n",
                     printable(path).c_str());
    }
    return tf;
}

// A colour or opacity with the digits that read back to the same float.
static std::string channel_text(float value) {
    char text[40];
    for (int digits = 3; digits <= 9; ++digits) {
        std::snprintf(text, sizeof text, "%.*g", digits, double(value));
        if (std::strtof(text, nullptr) == value) break;
    }
    return text;
}

std::string transfer_function_text(const TransferFunction& tf, const ValueMap& map,
                                   const std::string& title) {
    std::string text = "# " + title + "\n# The format: see data/tf/classic.tf.\n"
                       "# from  to  kind  r g b opacity  [r g b opacity]  label\n";
    for (const TfRange& range : tf.ranges) {
        if (range.to <= range.from) continue;
        // The volume's values back to the file's: the identity keeps whole numbers.
        const double from = map.identity() ? range.from : map.to_file(range.from);
        const double to = map.identity() ? range.to : map.to_file(range.to);
        text += value_text(from) + " " + value_text(to) + (range.ramp ? " ramp" : " constant");
        for (const Rgba* colour : {&range.start, &range.end}) {
            text += " " + channel_text(colour->r) + " " + channel_text(colour->g) + " " +
                    channel_text(colour->b) + " " + channel_text(colour->a);
            if (!range.ramp) break;
        }
        if (!range.label.empty()) text += " " + range.label;
        text += "\n";
    }
    return text;
}

TransferFunction classic_transfer_function() {
    return parse_transfer_function(classic_text, classic_source);
}

const TfRange* find_range(const TransferFunction& tf, const std::string& label) {
    for (const TfRange& range : tf.ranges) {
        if (range.label == label) return &range;
    }
    return nullptr;
}

void set_opacity(TransferFunction& tf, const std::string& label, double opacity,
                 const std::string& flag) {
    if (!(opacity >= 0 && opacity <= 1)) {
        throw InputError(flag + ": expected an opacity from 0 to 1, got " +
                         std::to_string(opacity));
    }
    for (TfRange& range : tf.ranges) {
        if (range.label != label) continue;
        range.start.a = range.end.a = float(opacity);
        return;
    }
    throw InputError(flag + ": " + tf.source + " has no range labelled '" + label + "'");
}

}  // namespace ctlab
