// lesson_markers.h: the lesson regions of the step sources and the listings that quote them.
// Shared by tools/make_student.cpp (stubs), tools/carry.cpp and tools/find_answers.cpp (the
// student kit), tools/handout_listings.cpp (refreshes listings) and tests/test_handouts.cpp
// (checks them). Header-only: each tool is a single .cpp file.
//
// In a step, a region is a run of whole lines between two marker lines:
//     //> lesson: first_hit
//     ... the code the handout quotes and the student skeleton stubs ...
//     //< lesson: first_hit
// Regions do not nest, a name is used once per file, and the braces between the markers
// balance. A function defined at the top level of a region (not inside a struct) is a lesson
// function: the student skeleton keeps its comments and signature and stubs its body.
//
// In a handout, a listing is a marker comment (at the start of a line) and a fenced block:
//     <!-- listing: steps/05_interpolated_hits.cpp first_hit -->        (a whole region)
//     <!-- listing: steps/05_interpolated_hits.cpp gradient gradient_along_ray -->  (one function)
// The block holds the exact text of the region (marker lines left out), or of the function
// with the comment lines above it.
#pragma once
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include "error.h"

namespace lesson {

using ctlab::InputError;

struct Region {
    std::string name;
    size_t begin = 0, end = 0;  // offsets of the text between the marker lines
    int line = 0;               // line number of the opening marker, from 1
};

struct Function {
    std::string name;
    std::string return_type;              // "void", "float", "Hit", ...; "" for a constructor
    std::vector<std::string> parameters;  // parameter names; unnamed ones are left out
    bool is_static = false, is_template = false;
    size_t start = 0;      // first line of its comment block (or of its code if none)
    size_t header = 0;     // first code line: `template <...>` or the signature
    size_t body_open = 0;  // its `{`
    size_t body_close = 0; // the matching `}`
};

struct Listing {
    std::string path, marker, function;  // function "" = the whole region
    int line = 0;                        // line of the <!-- listing: --> comment, from 1
    size_t content_begin = 0, content_end = 0;  // the text between the fences
};

inline std::string read_text(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw InputError("cannot read '" + path + "'");
    std::ostringstream text;
    text << file.rdbuf();
    return text.str();
}

// 64-bit FNV-1a, as 16 hex digits: enough to notice that a file or a function was edited.
inline std::string content_hash(const std::string& text) {
    unsigned long long hash = 14695981039346656037ull;
    for (unsigned char c : text) hash = (hash ^ c) * 1099511628211ull;
    std::string hex(16, '0');
    for (int n = 15; n >= 0; --n, hash >>= 4) hex[n] = "0123456789abcdef"[hash & 15];
    return hex;
}

inline bool is_identifier_char(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
}

inline std::string trim(const std::string& text) {
    const size_t first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos) return "";
    return text.substr(first, text.find_last_not_of(" \t\r\n") - first + 1);
}

inline int line_of(const std::string& text, size_t offset) {
    int line = 1;
    for (size_t n = 0; n < offset && n < text.size(); ++n) line += text[n] == '\n';
    return line;
}

inline size_t line_start(const std::string& text, size_t offset) {
    const size_t newline = offset == 0 ? std::string::npos : text.rfind('\n', offset - 1);
    return newline == std::string::npos ? 0 : newline + 1;
}

// The source with comments, preprocessor lines and the insides of string and character
// literals blanked (newlines kept), so braces and names can be found by plain scanning.
inline std::string mask_code(const std::string& source) {
    std::string masked = source;
    auto blank = [&](size_t from, size_t to) {
        for (size_t n = from; n < to && n < masked.size(); ++n) {
            if (masked[n] != '\n') masked[n] = ' ';
        }
    };
    size_t n = 0;
    bool line_has_code = false;  // a `#` after code is not a directive
    while (n < source.size()) {
        const char c = source[n];
        const char next = n + 1 < source.size() ? source[n + 1] : '\0';
        if (c == '\n') {
            line_has_code = false;
            ++n;
        } else if (c == '#' && !line_has_code) {  // directive, with continued lines
            size_t end = n;
            while (end < source.size() && !(source[end] == '\n' && source[end - 1] != '\\')) ++end;
            blank(n, end);
            n = end;
        } else if (c == '/' && next == '/') {
            const size_t end = source.find('\n', n);
            blank(n, end == std::string::npos ? source.size() : end);
            n = end == std::string::npos ? source.size() : end;
        } else if (c == '/' && next == '*') {
            const size_t end = source.find("*/", n + 2);
            const size_t stop = end == std::string::npos ? source.size() : end + 2;
            blank(n, stop);
            n = stop;
        } else if (c == '"' && n > 0 && source[n - 1] == 'R' &&
                   (n < 2 || !is_identifier_char(source[n - 2]) || source[n - 2] == '8' ||
                    source[n - 2] == 'u' || source[n - 2] == 'U' || source[n - 2] == 'L')) {
            const size_t paren = source.find('(', n);  // R"delimiter( ... )delimiter"
            const std::string close = paren == std::string::npos
                ? "\"" : ")" + source.substr(n + 1, paren - n - 1) + "\"";
            const size_t end = source.find(close, n + 1);
            const size_t stop = end == std::string::npos ? source.size() : end + close.size();
            blank(n + 1, stop - 1);
            n = stop;
            line_has_code = true;
        } else if (c == '"' || (c == '\'' && !(n > 0 && std::isxdigit(
                                    static_cast<unsigned char>(source[n - 1]))))) {
            size_t end = n + 1;  // a quote after a digit is a digit separator (1'000)
            while (end < source.size() && source[end] != c && source[end] != '\n') {
                end += source[end] == '\\' ? 2 : 1;
            }
            blank(n + 1, end);
            n = end + 1;
            line_has_code = true;
        } else {
            if (!std::isspace(static_cast<unsigned char>(c))) line_has_code = true;
            ++n;
        }
    }
    return masked;
}

// Every region of a step source, in order. Throws InputError "PATH:LINE: ..." for unbalanced,
// nested, mismatched or repeated markers.
inline std::vector<Region> find_regions(const std::string& source, const std::string& path) {
    const std::string open_marker = "//> lesson:", close_marker = "//< lesson:";
    std::vector<Region> regions;
    bool inside = false;
    Region current;
    size_t at = 0;
    int line = 0;
    while (at < source.size()) {
        ++line;
        size_t end = source.find('\n', at);
        const size_t next = end == std::string::npos ? source.size() : end + 1;
        const std::string text = trim(source.substr(at, next - at));
        const bool opens = text.rfind(open_marker, 0) == 0;
        const bool closes = text.rfind(close_marker, 0) == 0;
        if (opens || closes) {
            const std::string name = trim(text.substr(open_marker.size()));
            const std::string where = path + ":" + std::to_string(line) + ": ";
            bool good_name = !name.empty();
            for (char c : name) good_name = good_name && is_identifier_char(c);
            if (!good_name) {
                throw InputError(where + "expected a marker name of letters, digits and _, got '" +
                                 name + "'");
            }
            if (opens) {
                if (inside) {
                    throw InputError(where + "region '" + name + "' opens inside region '" +
                                     current.name + "' (regions do not nest)");
                }
                for (const Region& region : regions) {
                    if (region.name == name) {
                        throw InputError(where + "region '" + name + "' is used twice");
                    }
                }
                current = Region{name, next, next, line};
                inside = true;
            } else {
                if (!inside) throw InputError(where + "'" + name + "' closes no open region");
                if (name != current.name) {
                    throw InputError(where + "'" + name + "' closes region '" + current.name +
                                     "' (opened on line " + std::to_string(current.line) + ")");
                }
                current.end = at;
                regions.push_back(current);
                inside = false;
            }
        }
        at = next;
    }
    if (inside) {
        throw InputError(path + ":" + std::to_string(current.line) + ": region '" +
                         current.name + "' is never closed (//< lesson: " + current.name + ")");
    }
    return regions;
}

inline const Region* find_region(const std::vector<Region>& regions, const std::string& name) {
    for (const Region& region : regions) {
        if (region.name == name) return &region;
    }
    return nullptr;
}

// The identifiers and punctuation of a masked piece of code, e.g. "static", "Hit", "(".
inline std::vector<std::string> tokens(const std::string& code) {
    std::vector<std::string> result;
    for (size_t n = 0; n < code.size();) {
        if (std::isspace(static_cast<unsigned char>(code[n]))) {
            ++n;
        } else if (is_identifier_char(code[n])) {
            size_t end = n;
            while (end < code.size() && is_identifier_char(code[end])) ++end;
            result.push_back(code.substr(n, end - n));
            n = end;
        } else if (code.compare(n, 2, "::") == 0 || code.compare(n, 2, "->") == 0 ||
                   code.compare(n, 2, "&&") == 0 || code.compare(n, 2, "[[") == 0 ||
                   code.compare(n, 2, "]]") == 0) {
            result.push_back(code.substr(n, 2));
            n += 2;
        } else {
            result.push_back(code.substr(n, 1));
            ++n;
        }
    }
    return result;
}

inline std::string join(const std::vector<std::string>& parts, size_t from, size_t to) {
    std::string text;
    for (size_t n = from; n < to && n < parts.size(); ++n) {
        const bool word = is_identifier_char(parts[n][0]);
        const bool after_word = !text.empty() && is_identifier_char(text.back());
        text += (word && after_word ? " " : "") + parts[n];
    }
    return text;
}

// The name of one parameter ("const Volume& volume" -> "volume"), "" when it has none.
inline std::string parameter_name(const std::vector<std::string>& parameter) {
    static const std::vector<std::string> not_names = {
        "const", "volatile", "int", "float", "double", "char", "bool", "long", "short",
        "unsigned", "signed", "auto", "void", "size_t"};
    size_t end = parameter.size();
    for (size_t n = 0; n < parameter.size(); ++n) {
        if (parameter[n] == "=" || parameter[n] == "[") {  // default value, array bound
            end = n;
            break;
        }
    }
    if (end < 2 || !is_identifier_char(parameter[end - 1][0])) return "";
    const std::string& name = parameter[end - 1];
    if (parameter[end - 2] == "::") return "";
    for (const std::string& word : not_names) {
        if (name == word) return "";
    }
    bool type_before = false;  // "const Foo" has no name: Foo is its type
    for (size_t n = 0; n + 1 < end; ++n) {
        type_before = type_before || (parameter[n] != "const" && parameter[n] != "volatile");
    }
    return type_before ? name : "";
}

// Reads a function header (masked code from the end of the previous declaration to its `{`).
// Returns false when it is not a function definition (a struct, an initialised variable...).
inline bool parse_header(const std::string& header, Function& function) {
    std::vector<std::string> words = tokens(header);
    size_t n = 0;
    if (n < words.size() && words[n] == "template") {  // skip `template <...>`
        function.is_template = true;
        int angle = 0;
        for (++n; n < words.size(); ++n) {
            if (words[n] == "<") ++angle;
            if (words[n] == ">" && --angle == 0) break;
        }
        ++n;
    }
    static const std::vector<std::string> not_functions = {
        "struct", "class", "union", "enum", "namespace", "extern", "typedef", "using"};
    if (n >= words.size()) return false;
    for (const std::string& word : not_functions) {
        if (words[n] == word) return false;
    }
    size_t open = n;  // the parameter list's `(`
    while (open < words.size() && words[open] != "(") {
        if (words[open] == "=") return false;  // a variable initialised with a lambda
        ++open;
    }
    if (open >= words.size() || open == n || !is_identifier_char(words[open - 1][0])) {
        return false;
    }
    function.name = words[open - 1];
    // The parameter names, splitting at commas outside brackets.
    int depth = 0;
    size_t close = open + 1;
    std::vector<std::string> parameter;
    for (; close < words.size(); ++close) {
        const std::string& word = words[close];
        if (word == "(" || word == "<" || word == "[" || word == "{") ++depth;
        if (word == ")" || word == ">" || word == "]" || word == "}") {
            if (depth == 0) break;
            --depth;
        }
        if (depth == 0 && word == ",") {
            const std::string name = parameter_name(parameter);
            if (!name.empty()) function.parameters.push_back(name);
            parameter.clear();
        } else {
            parameter.push_back(word);
        }
    }
    if (close >= words.size()) return false;
    const std::string last = parameter_name(parameter);
    if (!last.empty()) function.parameters.push_back(last);
    // After the list: qualifiers, a trailing return type or a constructor's initialisers.
    std::string trailing_type;
    for (size_t m = close + 1; m < words.size(); ++m) {
        const std::string& word = words[m];
        if (word == "->") {
            trailing_type = join(words, m + 1, words.size());
            break;
        }
        if (word == ":") break;
        if (word != "const" && word != "noexcept" && word != "override" && word != "final" &&
            word != "&" && word != "&&") {
            return false;
        }
    }
    // The return type: what precedes the name, less the specifiers and attributes.
    std::vector<std::string> type;
    for (size_t m = n; m + 1 < open; ++m) {
        const std::string& word = words[m];
        if (word == "[[") {
            while (m + 1 < open && words[m] != "]]") ++m;
            continue;
        }
        if (word == "static") function.is_static = true;
        if (word == "static" || word == "inline" || word == "constexpr" || word == "virtual" ||
            word == "friend" || word == "explicit") {
            continue;
        }
        type.push_back(word);
    }
    if (!type.empty() && type.back() == "::") return false;  // Class::member: not in a region
    function.return_type = trailing_type.empty() ? join(type, 0, type.size()) : trailing_type;
    return true;
}

// The functions defined at the top level of one region. Throws InputError when the region's
// braces do not balance.
inline std::vector<Function> find_functions(const std::string& source, const std::string& masked,
                                            const Region& region, const std::string& path) {
    std::vector<Function> functions;
    int depth = 0, parens = 0;
    size_t statement = region.begin;  // where the current top-level declaration starts
    bool in_function = false;
    Function current;
    for (size_t n = region.begin; n < region.end; ++n) {
        const char c = masked[n];
        if (c == '(') ++parens;
        if (c == ')') --parens;
        if (c == ';' && depth == 0) statement = n + 1;
        if (c == '{') {
            if (depth == 0 && parens == 0) {
                Function function;
                if (parse_header(masked.substr(statement, n - statement), function)) {
                    // Comments start at the first non-blank line; code at the first code line.
                    size_t first = statement;
                    while (first < n && std::isspace(static_cast<unsigned char>(source[first]))) {
                        ++first;
                    }
                    size_t code = statement;
                    while (code < n && std::isspace(static_cast<unsigned char>(masked[code]))) {
                        ++code;
                    }
                    function.start = line_start(source, first);
                    function.header = line_start(source, code);
                    function.body_open = n;
                    current = function;
                    in_function = true;
                }
            }
            ++depth;
        }
        if (c == '}') {
            if (--depth < 0) break;
            if (depth == 0) {
                if (in_function) {
                    current.body_close = n;
                    functions.push_back(current);
                    in_function = false;
                }
                statement = n + 1;
            }
        }
    }
    if (depth != 0 || parens != 0) {
        throw InputError(path + ":" + std::to_string(region.line) + ": region '" + region.name +
                         "': its braces or parentheses do not balance between the markers");
    }
    return functions;
}

inline std::vector<Function> find_functions(const std::string& source, const Region& region,
                                            const std::string& path) {
    return find_functions(source, mask_code(source), region, path);
}

// Every lesson function of a step source: the functions of all its regions, in order. `masked`
// is mask_code(source).
inline std::vector<Function> lesson_functions(const std::string& source,
                                              const std::string& masked,
                                              const std::string& path) {
    std::vector<Function> functions;
    for (const Region& region : find_regions(source, path)) {
        for (const Function& function : find_functions(source, masked, region, path)) {
            functions.push_back(function);
        }
    }
    return functions;
}

// The text a listing quotes: the whole region, or one function with its comment lines.
inline std::string region_text(const std::string& source, const Region& region) {
    return source.substr(region.begin, region.end - region.begin);
}

inline std::string function_text(const std::string& source, const Function& function) {
    size_t end = source.find('\n', function.body_close);
    end = end == std::string::npos ? source.size() : end + 1;
    return source.substr(function.start, end - function.start);
}

// The listings of a handout, in order. Throws InputError "PATH:LINE: ..." for a listing
// comment that is malformed or not followed by a ```cpp block.
inline std::vector<Listing> find_listings(const std::string& markdown, const std::string& path) {
    const std::string opener = "<!-- listing:";
    std::vector<Listing> listings;
    for (size_t at = markdown.find(opener); at != std::string::npos;
         at = markdown.find(opener, at + 1)) {
        if (at > 0 && markdown[at - 1] != '\n') continue;  // only at the start of a line
        Listing listing;
        listing.line = line_of(markdown, at);
        const std::string where = path + ":" + std::to_string(listing.line) + ": ";
        const size_t close = markdown.find("-->", at);
        const size_t line_end = markdown.find('\n', at);
        if (close == std::string::npos || close > line_end) {
            throw InputError(where + "expected '<!-- listing: FILE MARKER [FUNCTION] -->' "
                             "on one line");
        }
        std::istringstream words(markdown.substr(at + opener.size(), close - at - opener.size()));
        words >> listing.path >> listing.marker >> listing.function;
        std::string extra;
        if (listing.marker.empty() || (words >> extra)) {
            throw InputError(where + "expected '<!-- listing: FILE MARKER [FUNCTION] -->'");
        }
        const std::string fence = "```cpp\n";
        if (line_end == std::string::npos || markdown.compare(line_end + 1, fence.size(), fence)) {
            throw InputError(where + "the listing comment must be followed by a ```cpp line");
        }
        listing.content_begin = line_end + 1 + fence.size();
        const size_t closing = markdown.find("\n```", listing.content_begin - 1);
        if (closing == std::string::npos) {
            throw InputError(where + "the ```cpp block is not closed");
        }
        listing.content_end = closing + 1;
        listings.push_back(listing);
    }
    return listings;
}

// What a listing should hold, given the source of the file it names. Throws InputError
// naming the handout line when the marker or the function does not exist.
inline std::string listing_text(const std::string& source, const Listing& listing,
                                const std::string& handout) {
    const std::string where = handout + ":" + std::to_string(listing.line) + ": ";
    const std::vector<Region> regions = find_regions(source, listing.path);
    const Region* region = find_region(regions, listing.marker);
    if (!region) {
        throw InputError(where + "listing names marker '" + listing.marker + "', which " +
                         listing.path + " does not have");
    }
    if (listing.function.empty()) return region_text(source, *region);
    for (const Function& function : find_functions(source, *region, listing.path)) {
        if (function.name == listing.function) return function_text(source, function);
    }
    throw InputError(where + "listing names function '" + listing.function + "', which is " +
                     "not defined in region '" + listing.marker + "' of " + listing.path);
}

// The file a listing names, read from the repository folder `root`.
inline std::string read_listed_file(const std::string& root, const Listing& listing,
                                    const std::string& handout) {
    try {
        return read_text(root + "/" + listing.path);
    } catch (const InputError&) {
        throw InputError(handout + ":" + std::to_string(listing.line) + ": listing names '" +
                         listing.path + "', which does not exist");
    }
}

// A handout with every listing replaced by `text_of(listing)`.
template <class TextOf>
std::string refresh_listings(const std::string& markdown, const std::vector<Listing>& listings,
                             TextOf text_of) {
    std::string result;
    size_t copied = 0;
    for (const Listing& listing : listings) {
        result += markdown.substr(copied, listing.content_begin - copied) + text_of(listing);
        copied = listing.content_end;
    }
    return result + markdown.substr(copied);
}

}  // namespace lesson

// --- Answers: the lesson bodies of a solution, and copies of them anywhere else -------------
// The student tree must not hold the body of any lesson function (tools/find_answers.cpp,
// tests/student_test.sh). An answer is found as the whole body, whitespace-normalised, or as
// one of its distinctive code lines: long enough to mean something, and found nowhere in the
// solution outside the lesson bodies (so a line a stub, a main() or common/ also has is not
// an answer).
namespace lesson {

// Every run of whitespace as one space, trimmed; offsets[n] is where character n came from.
inline std::string collapse_spaces(const std::string& text, std::vector<size_t>* offsets = nullptr) {
    std::string result;
    if (offsets) offsets->clear();
    bool space = false;
    for (size_t n = 0; n < text.size(); ++n) {
        if (std::isspace(static_cast<unsigned char>(text[n]))) {
            space = !result.empty();
            continue;
        }
        if (space) {
            result += ' ';
            if (offsets) offsets->push_back(n);
            space = false;
        }
        result += text[n];
        if (offsets) offsets->push_back(n);
    }
    return result;
}

// One line of code without its trailing // comment (masked: the same line from mask_code).
inline std::string code_of_line(const std::string& line, const std::string& masked) {
    int quotes = 0;
    for (size_t n = 0; n + 1 < line.size() && n < masked.size(); ++n) {
        if (masked[n] == '"') ++quotes;
        if (quotes % 2 == 0 && line.compare(n, 2, "//") == 0 && masked[n] == ' ') {
            return line.substr(0, n);
        }
    }
    return line;
}

// Code without its // comments, whitespace-normalised: two functions that differ only in their
// comments or layout give the same text.
inline std::string code_only(const std::string& text) {
    std::istringstream lines(text), masked_lines(mask_code(text));
    std::string line, masked_line, code;
    while (std::getline(lines, line) && std::getline(masked_lines, masked_line)) {
        code += code_of_line(line, masked_line) + "\n";
    }
    return collapse_spaces(code);
}

struct Answer {
    std::string step, function;  // "02_threshold", "first_hit"
    std::string text;            // whitespace-normalised: a whole body, or one code line
    bool whole_body = false;
};

constexpr size_t shortest_answer_line = 24;  // normalised characters; shorter lines are common

// The solution's lesson bodies and their code lines (not yet filtered: see distinctive_answers)
// and, in `elsewhere`, the normalised code lines of the source outside those bodies.
inline std::vector<Answer> lesson_bodies(const std::string& source, const std::string& path,
                                         const std::string& step,
                                         std::vector<std::string>& elsewhere) {
    std::vector<Answer> answers;
    const std::string masked = mask_code(source);
    std::vector<std::pair<size_t, size_t>> bodies;  // [open, close] offsets
    for (const Function& function : lesson_functions(source, masked, path)) {
        bodies.push_back({function.body_open, function.body_close});
        const std::string body =
            source.substr(function.body_open + 1, function.body_close - function.body_open - 1);
        answers.push_back({step, function.name, collapse_spaces(body), true});
        const std::string masked_body =
            masked.substr(function.body_open + 1, function.body_close - function.body_open - 1);
        std::istringstream lines(body), masked_lines(masked_body);
        std::string line, masked_line;
        while (std::getline(lines, line) && std::getline(masked_lines, masked_line)) {
            const std::string code = collapse_spaces(code_of_line(line, masked_line));
            if (!code.empty()) answers.push_back({step, function.name, code, false});
        }
    }
    // The rest of the source, line by line.
    std::string outside = source, outside_masked = masked;
    for (auto body = bodies.rbegin(); body != bodies.rend(); ++body) {
        outside.erase(body->first + 1, body->second - body->first - 1);
        outside_masked.erase(body->first + 1, body->second - body->first - 1);
    }
    std::istringstream lines(outside), masked_lines(outside_masked);
    std::string line, masked_line;
    while (std::getline(lines, line) && std::getline(masked_lines, masked_line)) {
        const std::string code = collapse_spaces(code_of_line(line, masked_line));
        if (!code.empty()) elsewhere.push_back(code);
    }
    return answers;
}

// A loop header alone ("for (int t = 0; t < view.ray_length; ++t) {") says how to walk, not
// what the lesson computes: any code that walks a ray or an image has one.
inline bool is_loop_header(const std::string& line) {
    return (line.rfind("for (", 0) == 0 || line.rfind("while (", 0) == 0) &&
           line.back() == '{';
}

// Keeps whole bodies, and the lines of at least shortest_answer_line characters that no
// `elsewhere` line equals, that are no loop header, and that lesson functions of only one name
// have (a line shared by first_hit and composite_front_to_back is plumbing, such as reading
// the voxel at t); one Answer per distinct text.
inline std::vector<Answer> distinctive_answers(const std::vector<Answer>& candidates,
                                               const std::vector<std::string>& elsewhere) {
    std::vector<Answer> result;
    for (const Answer& answer : candidates) {
        if (answer.text.empty()) continue;
        if (!answer.whole_body) {
            if (answer.text.size() < shortest_answer_line || is_loop_header(answer.text)) {
                continue;
            }
            bool common = false;
            for (const std::string& line : elsewhere) common = common || line == answer.text;
            for (const Answer& other : candidates) {
                common = common || (!other.whole_body && other.text == answer.text &&
                                    other.function != answer.function);
            }
            if (common) continue;
        }
        bool seen = false;
        for (const Answer& kept : result) seen = seen || kept.text == answer.text;
        if (!seen) result.push_back(answer);
    }
    return result;
}

struct Leak {
    const Answer* answer;
    int line;  // in the file searched, from 1
};

// Where the answers occur in `text` (any file: code, markdown, data), whitespace-normalised;
// in the answers' order, each answer's finds in the text's order (a whole body: its first).
// One pass over the text, not one per answer: every answer of at least `prefix` characters
// is looked up by its first `prefix` characters' hash (a rolling hash of the text's window,
// a bit table first), then compared whole; a shorter one is searched for on its own. A
// generated kit (~600 files, ~730 answers): 0.37 s of CPU, 1.41 s with one search per answer.
inline std::vector<Leak> find_answers(const std::string& text, const std::vector<Answer>& answers) {
    constexpr size_t prefix = 16;          // characters hashed (answers are mostly >= 24)
    constexpr uint64_t base = 1099511628211ULL;  // the rolling hash's multiplier (odd)
    constexpr size_t table_bits = 16;      // the bit table that turns most windows away
    auto hash_of = [&](const char* at) {
        uint64_t hash = 0;
        for (size_t n = 0; n < prefix; ++n) hash = hash * base + static_cast<unsigned char>(at[n]);
        return hash;
    };
    auto slot_of = [&](uint64_t hash) { return static_cast<size_t>(hash >> (64 - table_bits)); };
    std::vector<size_t> offsets;
    const std::string collapsed = collapse_spaces(text, &offsets);
    std::vector<std::pair<size_t, size_t>> finds;  // (answer index, position in collapsed)
    std::vector<std::pair<uint64_t, size_t>> hashed;  // (prefix hash, answer index), sorted
    std::vector<bool> table(size_t(1) << table_bits);
    for (size_t index = 0; index < answers.size(); ++index) {
        const std::string& wanted = answers[index].text;
        if (wanted.size() >= prefix) {
            hashed.push_back({hash_of(wanted.data()), index});
            table[slot_of(hashed.back().first)] = true;
            continue;
        }
        for (size_t at = collapsed.find(wanted); at != std::string::npos;
             at = collapsed.find(wanted, at + 1)) {
            finds.push_back({index, at});
        }
    }
    std::sort(hashed.begin(), hashed.end());
    if (!hashed.empty() && collapsed.size() >= prefix) {
        uint64_t power = 1;  // base^(prefix - 1): the leaving character's weight
        for (size_t n = 1; n < prefix; ++n) power *= base;
        uint64_t hash = hash_of(collapsed.data());
        for (size_t at = 0;; ++at) {
            if (table[slot_of(hash)]) {
                for (auto candidate = std::lower_bound(hashed.begin(), hashed.end(),
                                                       std::make_pair(hash, size_t(0)));
                     candidate != hashed.end() && candidate->first == hash; ++candidate) {
                    const std::string& wanted = answers[candidate->second].text;
                    if (collapsed.compare(at, wanted.size(), wanted) == 0) {
                        finds.push_back({candidate->second, at});
                    }
                }
            }
            if (at + prefix >= collapsed.size()) break;
            hash = (hash - power * static_cast<unsigned char>(collapsed[at])) * base +
                   static_cast<unsigned char>(collapsed[at + prefix]);
        }
    }
    std::sort(finds.begin(), finds.end());
    std::vector<Leak> leaks;
    for (size_t n = 0; n < finds.size(); ++n) {
        const auto [index, at] = finds[n];
        if (answers[index].whole_body && n > 0 && finds[n - 1].first == index) continue;
        leaks.push_back({&answers[index], line_of(text, offsets[at])});
    }
    return leaks;
}

// The files under a folder, sorted (symbolic links left out); only those ending in
// `extension` when it is given.
inline std::vector<std::filesystem::path> files_under(const std::filesystem::path& folder,
                                                      const std::string& extension = "") {
    std::vector<std::filesystem::path> files;
    for (const auto& item : std::filesystem::recursive_directory_iterator(folder)) {
        if (item.is_regular_file() && !item.is_symlink() &&
            (extension.empty() || item.path().extension() == extension)) {
            files.push_back(item.path());
        }
    }
    std::sort(files.begin(), files.end());
    return files;
}

// steps/NN_name.cpp
inline bool is_step(const std::filesystem::path& path) {
    const std::string name = path.filename().string();
    return name.size() > 3 && std::isdigit(static_cast<unsigned char>(name[0])) &&
           std::isdigit(static_cast<unsigned char>(name[1])) && name[2] == '_' &&
           path.extension() == ".cpp";
}

// The answers of a solution folder: the lesson bodies of its steps/NN_*.cpp, and their
// distinctive lines (common/ and the steps outside the bodies are everybody's).
inline std::vector<Answer> solution_answers(const std::filesystem::path& solution) {
    std::vector<Answer> candidates;
    std::vector<std::string> elsewhere;
    for (const std::filesystem::path& path : files_under(solution / "steps", ".cpp")) {
        if (!is_step(path)) continue;
        const std::string relative = std::filesystem::relative(path, solution).generic_string();
        const auto found =
            lesson_bodies(read_text(path.string()), relative, path.stem().string(), elsewhere);
        candidates.insert(candidates.end(), found.begin(), found.end());
    }
    if (candidates.empty()) {
        throw InputError("no lesson function in '" + solution.string() + "/steps'");
    }
    // common/ is everybody's: a line it has is no answer.
    if (std::filesystem::is_directory(solution / "common")) {
        for (const std::filesystem::path& path : files_under(solution / "common")) {
            const std::string text = read_text(path.string());
            const std::string masked = mask_code(text);
            size_t at = 0;
            while (at < text.size()) {
                size_t end = text.find('\n', at);
                if (end == std::string::npos) end = text.size();
                const std::string code = collapse_spaces(code_of_line(
                    text.substr(at, end - at), masked.substr(at, end - at)));
                if (!code.empty()) elsewhere.push_back(code);
                at = end + 1;
            }
        }
    }
    std::sort(elsewhere.begin(), elsewhere.end());
    elsewhere.erase(std::unique(elsewhere.begin(), elsewhere.end()), elsewhere.end());
    return distinctive_answers(candidates, elsewhere);
}

}  // namespace lesson

// --- Copies across steps: a function that a later step takes unchanged ----------------------
// A step is the step it builds on plus its lesson, so a function defined in several steps is
// one function kept in several files. Part 2 branches: its header's "// Builds on:  15_trilinear"
// line names the step it builds on (`make diff` shows the difference), and steps 18, 19, 22 and
// 22 build on step 15, not on the jittered steps 16-17 numbered just before them. The rule
// (tests/test_lesson_markers.cpp checks it, and `make carry-lab` and `make carry` follow it):
//   - every top-level function of a step except main() is compared with the function of the
//     same name in the nearest of its ancestors that defines one: the steps its "Builds on:"
//     line names (a step without one builds on the step numbered before it), theirs, and so
//     on (step 19's composite_front_to_back() with step 15's, never with step 17's jittered
//     one); a function that no ancestor defines is new in the step;
//   - their code must be the same (comments and layout aside: lesson::code_only),
//   - unless the later step declares that it changes the function: a line of the comment block
//     above it says "changed in step NN" (NN: that step's own number), with the reason, e.g.
//         // Changed in step 16: the samples move by the pixel's jitter.
//     A copy carried further keeps that line, and names another step there: no change.
// A function that a step changes starts a new chain: the steps built on it are compared with it.
namespace lesson {

// The steps a source's header says it builds on: every step name ("15_trilinear") in its
// "// Builds on:" line and the indented comment lines that continue it, in order. The first is
// the step `make diff` compares with; step 30 names two ("25_free_leaping (...) and
// 18_projection_modes (MIP)"). None for "Builds on:  nothing" or a header without the line.
inline std::vector<std::string> builds_on(const std::string& source) {
    const std::string label = "// Builds on:";
    const auto word_char = [](char c) {
        return std::islower(static_cast<unsigned char>(c)) ||
               std::isdigit(static_cast<unsigned char>(c)) || c == '_';
    };
    std::vector<std::string> names;
    bool inside = false;  // on the label's line or a line continuing it
    for (size_t at = 0; at < source.size();) {
        size_t end = source.find('\n', at);
        if (end == std::string::npos) end = source.size();
        const std::string line = source.substr(at, end - at);
        at = end + 1;
        if (line.rfind(label, 0) == 0) {
            if (inside) break;  // the first such line only
            inside = true;
        } else if (!inside) {
            continue;
        } else if (line.rfind("//  ", 0) != 0) {
            break;  // "// Handout: ..." or code: the line is not continued
        }
        const size_t first = line.rfind(label, 0) == 0 ? label.size() : 2;
        for (size_t n = first; n < line.size(); ++n) {
            if (n > 0 && word_char(line[n - 1])) continue;  // a name starts a word
            size_t last = n;
            while (last < line.size() && word_char(line[last])) ++last;
            const std::string name = line.substr(n, last - n);
            if (name.size() > 3 && std::isdigit(static_cast<unsigned char>(name[0])) &&
                std::isdigit(static_cast<unsigned char>(name[1])) && name[2] == '_' &&
                std::islower(static_cast<unsigned char>(name[3]))) {
                names.push_back(name);
            }
            n = last;
        }
    }
    return names;
}

// For each step (stems and sources, in order), the indices of the steps it builds on: those
// its "Builds on:" line names, else the step before it; none for the first. Throws InputError
// when the line names a step that is not an earlier one in `steps`.
inline std::vector<std::vector<size_t>> step_parents(
    const std::vector<std::pair<std::string, std::string>>& steps) {
    std::vector<std::vector<size_t>> parents(steps.size());
    for (size_t n = 0; n < steps.size(); ++n) {
        const std::vector<std::string> named = builds_on(steps[n].second);
        if (named.empty() && n > 0) parents[n].push_back(n - 1);
        for (const std::string& name : named) {
            size_t m = 0;
            while (m < n && steps[m].first != name) ++m;
            if (m == n) {
                throw InputError("steps/" + steps[n].first + ".cpp: its \"Builds on:\" line "
                                 "names " + name + ", which is not an earlier step in steps/");
            }
            parents[n].push_back(m);
        }
    }
    return parents;
}

// The step that step n's function is compared with (and carried from), by the rule above:
// of the ancestors for which `defines(m)` holds, the nearest (fewest "Builds on" links away;
// at the same distance, the one named first); -1 when none does. `parents`: step_parents().
template <class Defines>
int compared_step(const std::vector<std::vector<size_t>>& parents, size_t n, Defines defines) {
    std::vector<size_t> ring = parents[n], seen = ring;  // the ancestors one link further each
    while (!ring.empty()) {
        for (size_t m : ring) {
            if (defines(m)) return int(m);
        }
        std::vector<size_t> next;
        for (size_t m : ring) {
            for (size_t parent : parents[m]) {
                if (std::find(seen.begin(), seen.end(), parent) != seen.end()) continue;
                seen.push_back(parent);
                next.push_back(parent);
            }
        }
        ring = next;
    }
    return -1;
}

struct StepFunction {
    std::string name;
    std::string text;  // comment block, signature and body (function_text)
    std::string code;  // code_only(text): what must match
    bool changed = false;  // its comments say "changed in step NN" for this step's NN
    Function where;
};

// "changed in step 14" (any case) in the comment lines of a function's text, for step "11".
inline bool declares_change(const std::string& comments, const std::string& number) {
    std::string lower;
    for (char c : comments) lower += char(std::tolower(static_cast<unsigned char>(c)));
    const std::string phrase = "changed in step " + number;
    for (size_t at = lower.find(phrase); at != std::string::npos;
         at = lower.find(phrase, at + 1)) {
        const size_t after = at + phrase.size();
        if (after >= lower.size() || !std::isdigit(static_cast<unsigned char>(lower[after]))) {
            return true;
        }
    }
    return false;
}

// The top-level functions of a step source (main() left out), in order. `number` is the
// step's two digits. A name defined twice (overloads) keeps its first definition only.
inline std::vector<StepFunction> step_functions(const std::string& source,
                                                const std::string& path,
                                                const std::string& number) {
    const std::string masked = mask_code(source);
    Region whole;
    whole.name = "(the whole file)";
    whole.end = source.size();
    std::vector<StepFunction> result;
    for (const Function& function : find_functions(source, masked, whole, path)) {
        if (function.name == "main") continue;
        bool seen = false;
        for (const StepFunction& kept : result) seen = seen || kept.name == function.name;
        if (seen) continue;
        StepFunction entry;
        entry.name = function.name;
        // Its comment block: the run of comment lines right above it (no marker lines, no
        // code line that ends in a comment).
        Function own = function;
        own.start = own.header;
        while (own.start > 0) {
            const size_t above = line_start(source, own.start - 1);
            const std::string line = trim(source.substr(above, own.start - above));
            const std::string code = trim(masked.substr(above, own.start - above));
            if (line.rfind("//", 0) != 0 || !code.empty() || line.rfind("//>", 0) == 0 ||
                line.rfind("//<", 0) == 0) {
                break;
            }
            own.start = above;
        }
        entry.where = own;
        entry.text = function_text(source, own);
        entry.code = code_only(entry.text);
        entry.changed = declares_change(source.substr(own.start, own.header - own.start), number);
        result.push_back(entry);
    }
    return result;
}

// The lesson functions of every step, and each step's parents: what the drift and copy
// checks below compare. `steps`: the step stems in order, with sources.
struct StepIndex {
    std::vector<std::vector<StepFunction>> functions;  // per step, in file order
    std::vector<std::vector<size_t>> parents;           // per step, from its "Builds on:"

    explicit StepIndex(const std::vector<std::pair<std::string, std::string>>& steps)
        : parents(step_parents(steps)) {
        for (const auto& [stem, source] : steps) {
            functions.push_back(
                step_functions(source, "steps/" + stem + ".cpp", stem.substr(0, 2)));
        }
    }
    // Step m's function `name`, or nullptr when step m has none.
    const StepFunction* find(size_t m, const std::string& name) const {
        for (const StepFunction& candidate : functions[m]) {
            if (candidate.name == name) return &candidate;
        }
        return nullptr;
    }
};

struct Drift {
    std::string function, earlier, later;  // "intersect_box", "13_free_camera", "11_jitter"
};

// Every function whose code differs from its copy in the step it is compared with (the
// nearest ancestor defining it), where the later step does not declare the change. `steps`:
// the step stems in order, with sources.
inline std::vector<Drift> find_drifts(
    const std::vector<std::pair<std::string, std::string>>& steps) {
    std::vector<Drift> drifts;
    const StepIndex index(steps);
    for (size_t n = 1; n < steps.size(); ++n) {
        for (const StepFunction& later : index.functions[n]) {
            if (later.changed) continue;
            const int m = compared_step(index.parents, n, [&](size_t m) {
                return index.find(m, later.name) != nullptr;
            });
            if (m >= 0 && index.find(size_t(m), later.name)->code != later.code) {
                drifts.push_back({later.name, steps[size_t(m)].first, steps[n].first});
            }
        }
    }
    return drifts;
}

// Every function that no ancestor of its step defines while an earlier step off its chain has
// the same code (`earlier`: the last such step): a copy that neither the drift check nor
// `make carry` can see until the step's "Builds on:" line names where it comes from.
inline std::vector<Drift> find_unlinked_copies(
    const std::vector<std::pair<std::string, std::string>>& steps) {
    std::vector<Drift> unlinked;
    const StepIndex index(steps);
    for (size_t n = 1; n < steps.size(); ++n) {
        for (const StepFunction& later : index.functions[n]) {
            const auto defines = [&](size_t m) { return index.find(m, later.name) != nullptr; };
            if (compared_step(index.parents, n, defines) >= 0) continue;
            for (size_t m = n; m-- > 0;) {
                const StepFunction* earlier = index.find(m, later.name);
                if (earlier && earlier->code == later.code) {
                    unlinked.push_back({later.name, steps[m].first, steps[n].first});
                    break;
                }
            }
        }
    }
    return unlinked;
}

// `make carry-lab FUNCTION=name FROM=NN`: step FROM's function `name` (its comment block,
// signature and body) copied into every later step compared with it by the rule above, and on
// into the steps compared with those, as long as they take it unchanged: a step that declares
// a change of its own keeps its version, and the steps compared with it follow that. A step
// whose ancestors reach the function by another step (step 18's from step 15, when step 16's
// is carried) is left alone. What happened to each step the function reached:
struct Carried {
    std::string step;     // the later step's stem
    std::string outcome;  // "carried", "same" (nothing to do), "changes it" (the chain ends)
    bool drifted = false; // carried: its code differed from the copy it is compared with
    std::string earlier;  // the stem of the step it is compared with
};

// Carries into `steps` (stems and sources, in order; the sources are rewritten in place).
// Throws InputError when step `from` (two digits) does not exist or does not define `name`.
inline std::vector<Carried> carry_forward(std::vector<std::pair<std::string, std::string>>& steps,
                                          const std::string& name, const std::string& from) {
    size_t first = steps.size();
    for (size_t n = 0; n < steps.size(); ++n) {
        if (steps[n].first.compare(0, 2, from) == 0 && steps[n].first.size() > 2) first = n;
    }
    if (first == steps.size()) throw InputError("no step " + from + " in steps/");
    // Each step's function `name` before the carry (has[n]: the step defines it).
    std::vector<StepFunction> before(steps.size());
    std::vector<bool> has(steps.size(), false);
    for (size_t n = 0; n < steps.size(); ++n) {
        const std::string& stem = steps[n].first;
        for (const StepFunction& function :
             step_functions(steps[n].second, "steps/" + stem + ".cpp", stem.substr(0, 2))) {
            if (function.name == name) {
                before[n] = function;
                has[n] = true;
            }
        }
    }
    if (!has[first]) {
        throw InputError("steps/" + steps[first].first + ".cpp defines no function " + name +
                         "() (main() is never carried)");
    }
    const std::vector<std::vector<size_t>> parents = step_parents(steps);
    const std::string& text = before[first].text;
    std::vector<bool> reached(steps.size(), false);  // holds step FROM's function after the carry
    reached[first] = true;
    std::vector<Carried> result;
    for (size_t n = first + 1; n < steps.size(); ++n) {
        if (!has[n]) continue;
        const int m = compared_step(parents, n, [&](size_t m) { return bool(has[m]); });
        if (m < 0 || !reached[size_t(m)]) continue;
        const StepFunction& later = before[n];
        if (later.changed) {
            result.push_back({steps[n].first, "changes it", false, steps[size_t(m)].first});
            continue;
        }
        Carried carried{steps[n].first, "same", false, steps[size_t(m)].first};
        if (later.text != text) {
            carried.outcome = "carried";
            carried.drifted = size_t(m) != first && later.code != before[size_t(m)].code;
            std::string& source = steps[n].second;
            source.replace(later.where.start, function_text(source, later.where).size(), text);
        }
        reached[n] = true;
        result.push_back(carried);
    }
    return result;
}

// The step stems of a lab's steps/ folder (steps/NN_name.cpp), in order, with their sources.
inline std::vector<std::pair<std::string, std::string>> read_steps(
    const std::filesystem::path& root) {
    std::vector<std::pair<std::string, std::string>> steps;
    for (const std::filesystem::path& path : files_under(root / "steps", ".cpp")) {
        if (is_step(path) && path.parent_path() == root / "steps") {
            steps.push_back({path.stem().string(), read_text(path.string())});
        }
    }
    return steps;
}

}  // namespace lesson
