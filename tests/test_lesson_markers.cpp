// test_lesson_markers.cpp: the marker reader behind make student, make handouts and the
// handout test (tools/lesson_markers.h), on small sources with known answers.
#include <doctest/doctest.h>
#include <string>
#include <utility>
#include <vector>
#include "tools/lesson_markers.h"

namespace {

const std::string source =
    "#include \"common/ctlab.h\"\n"
    "//> lesson: lookup\n"
    "// A table.\n"
    "struct Table {\n"
    "    int size() const { return 3; }  // a member: not a lesson function\n"
    "};\n"
    "\n"
    "// Sums; a brace in a string \"{\" or a comment { must not count.\n"
    "template <class Sample>\n"
    "static float total(Sample sample, int count = 3, const char* label = \"}\") {\n"
    "    float sum = 0;  // }\n"
    "    for (int n = 0; n < count; ++n) sum += sample(n);\n"
    "    return sum + (label[0] == '}' ? 0 : 1);\n"
    "}\n"
    "//< lesson: lookup\n"
    "\n"
    "//> lesson: print\n"
    "static void print(const Table& table, int, const Table) {\n"
    "    std::printf(\"%d\\n\", table.size());\n"
    "}\n"
    "auto twice = [](int v) { return 2 * v; };\n"
    "//< lesson: print\n";

}  // namespace

TEST_CASE("regions are the lines between the markers") {
    const auto regions = lesson::find_regions(source, "test.cpp");
    REQUIRE(regions.size() == 2);
    CHECK(regions[0].name == "lookup");
    CHECK(regions[0].line == 2);
    CHECK(lesson::region_text(source, regions[0]).rfind("// A table.\n", 0) == 0);
    CHECK(lesson::region_text(source, regions[1]) ==
          "static void print(const Table& table, int, const Table) {\n"
          "    std::printf(\"%d\\n\", table.size());\n"
          "}\n"
          "auto twice = [](int v) { return 2 * v; };\n");
}

TEST_CASE("lesson functions: top level only, braces in strings and comments ignored") {
    const auto regions = lesson::find_regions(source, "test.cpp");
    const auto lookup = lesson::find_functions(source, regions[0], "test.cpp");
    REQUIRE(lookup.size() == 1);  // Table::size is inside a struct
    CHECK(lookup[0].name == "total");
    CHECK(lookup[0].return_type == "float");
    CHECK(lookup[0].is_template);
    CHECK(lookup[0].is_static);
    CHECK(lookup[0].parameters == std::vector<std::string>{"sample", "count", "label"});
    CHECK(source[lookup[0].body_open] == '{');
    CHECK(source.substr(lookup[0].body_close, 2) == "}\n");
    CHECK(lesson::function_text(source, lookup[0]).rfind("// Sums;", 0) == 0);

    const auto print = lesson::find_functions(source, regions[1], "test.cpp");
    REQUIRE(print.size() == 1);  // the lambda is a variable, not a function
    CHECK(print[0].name == "print");
    CHECK(print[0].return_type == "void");
    CHECK(print[0].parameters == std::vector<std::string>{"table"});  // the others are unnamed
}

TEST_CASE("masking keeps offsets and newlines, blanks comments and literals") {
    const std::string code = "int a = '{'; // {\nconst char* s = \"}\"; /* { */ int b = 1'000;\n";
    const std::string masked = lesson::mask_code(code);
    CHECK(masked.size() == code.size());
    CHECK(masked.find('{') == std::string::npos);
    CHECK(masked.find('}') == std::string::npos);
    CHECK(masked.find('\n') == code.find('\n'));
    CHECK(masked.find("int b = 1'000;") != std::string::npos);
}

TEST_CASE("bad markers are errors that name the file and line") {
    auto error_of = [](const std::string& text) {
        try {
            lesson::find_regions(text, "bad.cpp");
        } catch (const ctlab::InputError& error) {
            return std::string(error.what());
        }
        return std::string();
    };
    CHECK(error_of("//> lesson: a\n") == "bad.cpp:1: region 'a' is never closed (//< lesson: a)");
    CHECK(error_of("//< lesson: a\n") == "bad.cpp:1: 'a' closes no open region");
    CHECK(error_of("//> lesson: a\n//> lesson: b\n").rfind("bad.cpp:2: region 'b' opens", 0) == 0);
    CHECK(error_of("//> lesson: a\n//< lesson: b\n").rfind("bad.cpp:2: 'b' closes region 'a'", 0) ==
          0);
    CHECK(error_of("//> lesson: a\n//< lesson: a\n//> lesson: a\n//< lesson: a\n") ==
          "bad.cpp:3: region 'a' is used twice");
    CHECK(error_of("//> lesson: two words\n").rfind("bad.cpp:1: expected a marker name", 0) == 0);
}

TEST_CASE("listings: found, refreshed, and errors for a missing marker") {
    const std::string markdown =
        "Text.\n<!-- listing: steps/x.cpp print -->\n```cpp\nold\n```\nMore.\n";
    const auto listings = lesson::find_listings(markdown, "h.md");
    REQUIRE(listings.size() == 1);
    CHECK(listings[0].path == "steps/x.cpp");
    CHECK(listings[0].marker == "print");
    CHECK(listings[0].function.empty());
    CHECK(listings[0].line == 2);
    CHECK(markdown.substr(listings[0].content_begin,
                          listings[0].content_end - listings[0].content_begin) == "old\n");
    const std::string refreshed =
        lesson::refresh_listings(markdown, listings, [&](const lesson::Listing& listing) {
            return lesson::listing_text(source, listing, "h.md");
        });
    CHECK(refreshed.find("```cpp\nstatic void print(") != std::string::npos);
    CHECK(refreshed.find("old") == std::string::npos);

    lesson::Listing missing = listings[0];
    missing.marker = "nowhere";
    CHECK_THROWS_WITH_AS(lesson::listing_text(source, missing, "h.md"),
                         "h.md:2: listing names marker 'nowhere', which steps/x.cpp does not have",
                         ctlab::InputError);
    CHECK_THROWS_AS(lesson::find_listings("<!-- listing: a.cpp m -->\nno fence\n", "h.md"),
                    ctlab::InputError);
}

TEST_CASE("answers: a lesson body is found whole or by a distinctive line, whitespace ignored") {
    const std::string step =
        "constexpr const char* step_name = \"02_x\";\n"
        "//> lesson: hit\n"
        "// The first sample above the threshold.\n"
        "static int hit(const int* values, int count, int threshold) {\n"
        "    for (int t = 0; t < count; ++t) {  // a loop header alone is no answer\n"
        "        if (values[t] > threshold) return t;\n"
        "        const int shared_with_main = count - 1;\n"
        "    }\n"
        "    return -1;\n"
        "}\n"
        "//< lesson: hit\n"
        "int main() {\n"
        "    const int count = 3;\n"
        "        const int shared_with_main = count - 1;\n"
        "    return shared_with_main;\n"
        "}\n";
    std::vector<std::string> elsewhere;
    const auto candidates = lesson::lesson_bodies(step, "steps/02_x.cpp", "02_x", elsewhere);
    const auto answers = lesson::distinctive_answers(candidates, elsewhere);
    std::vector<std::string> texts;
    for (const auto& answer : answers) texts.push_back(answer.text);
    // The whole body; the one distinctive line. Not the loop header (no answer), not the
    // line main() has too, not "return -1;" (too short to say anything), not the comment.
    REQUIRE(texts.size() == 2);
    CHECK(answers[0].whole_body);
    CHECK(answers[0].function == "hit");
    CHECK(texts[0].find("for (int t = 0; t < count; ++t) { // a loop header") == 0);
    CHECK(texts[1] == "if (values[t] > threshold) return t;");

    // Re-indented in a handout: the line is found, on its own line number.
    const std::string handout = "# Notes\n\n```cpp\nif (values[t] >   threshold)\n"
                                "  return t;\n```\n";
    const auto leaks = lesson::find_answers(handout, answers);
    REQUIRE(leaks.size() == 1);
    CHECK(leaks[0].line == 4);
    CHECK(leaks[0].answer->text == texts[1]);
    // The stub and the rest of the step hold no answer.
    CHECK(lesson::find_answers("static int hit(const int* values, int count, int threshold) {\n"
                               "    not_done(step_name, \"hit\", values, count, threshold);\n"
                               "    return {};\n}\n" + step.substr(step.find("int main")),
                               answers).empty());
}

TEST_CASE("code_only: the same code under other comments and layout is the same, strings count") {
    const std::string commented = "// The sum of a and b.\n"
                                  "static int add(int a, int b) {\n"
                                  "    return a + b;  // never overflows here\n"
                                  "}\n";
    const std::string bare = "static int add(int a, int b) { return a +  b; }\n";
    CHECK(lesson::code_only(commented) == lesson::code_only(bare));
    CHECK(lesson::code_only(bare) == "static int add(int a, int b) { return a + b; }");
    // What a string says is code: a trace line that changed is a changed function.
    CHECK(lesson::code_only("f(\"a // b\");  // c\n") == "f(\"a // b\");");
    CHECK(lesson::code_only("f(\"x\");\n") != lesson::code_only("f(\"y\");\n"));
    CHECK(lesson::code_only(bare) !=
          lesson::code_only("static int add(int a, int b) { return b; }"));
}

// --- Copies across steps (tools/lesson_markers.h "Copies across steps", make carry-lab) ------

namespace {

using Steps = std::vector<std::pair<std::string, std::string>>;

std::string step_source(const std::string& comment, const std::string& body) {
    return "#include <cmath>\n"
           "constexpr double margin = 1e-6;  // voxels: a code line that ends in a comment\n"
           "//> lesson: slab\n" + comment +
           "static double exit_t(double t) {\n" + body + "}\n"
           "//< lesson: slab\n"
           "int main() { return int(exit_t(1.0)); }\n";
}

std::string drift_names(const std::vector<lesson::Drift>& drifts) {
    std::string names;
    for (const lesson::Drift& drift : drifts) {
        names += drift.function + " " + drift.earlier + " " + drift.later + "\n";
    }
    return names;
}

}  // namespace

TEST_CASE("copies across steps: the same code passes, a drift names the function and the steps") {
    const std::string body = "    return t + 1;\n";
    Steps steps = {{"10_camera", step_source("// The exit.\n", body)},
                   {"11_jitter", step_source("// Step 10's exit, unchanged.\n", body)},
                   {"12_modes", step_source("", "    return t   +   1;  // layout aside\n")}};
    CHECK(lesson::find_drifts(steps).empty());  // comments and layout aside, main() ignored
    steps[2].second = step_source("", "    return t + 2;\n");
    CHECK(drift_names(lesson::find_drifts(steps)) == "exit_t 11_jitter 12_modes\n");
    // Declared as a change of this step: a new chain starts there.
    steps[2].second = step_source("// Changed in step 12: one more.\n", "    return t + 2;\n");
    CHECK(lesson::find_drifts(steps).empty());
    // The line carried on into step 13 names step 12: step 13 must equal step 12's.
    steps.push_back({"13_iso", step_source("// Changed in step 12: one more.\n", body)});
    CHECK(drift_names(lesson::find_drifts(steps)) == "exit_t 12_modes 13_iso\n");
    // "changed in step 1" is not step 12's, nor is "step 123".
    CHECK(lesson::declares_change("// changed in step 12: x\n", "12"));
    CHECK_FALSE(lesson::declares_change("// changed in step 123\n", "12"));
    CHECK_FALSE(lesson::declares_change("// changed in step 11\n", "12"));
}

TEST_CASE("carry-lab: a fix reaches the later copies, up to a step that changes the function") {
    const std::string old_body = "    return t + 1;\n", fixed = "    return t + 1.5;\n";
    Steps steps = {{"10_camera", step_source("// The exit, fixed.\n", fixed)},
                   {"11_jitter", step_source("// The exit.\n", old_body)},
                   {"12_modes", step_source("// The exit.\n", old_body)},
                   {"13_iso", step_source("// Changed in step 13: two.\n", "    return 2;\n")},
                   {"14_shadow", step_source("// Changed in step 13: two.\n", "    return 2;\n")}};
    const Steps before = steps;
    const std::vector<lesson::Carried> carried = lesson::carry_forward(steps, "exit_t", "10");
    REQUIRE(carried.size() == 3);
    CHECK(carried[0].step == "11_jitter");
    CHECK(carried[0].outcome == "carried");
    CHECK(carried[1].outcome == "carried");
    CHECK_FALSE(carried[1].drifted);
    CHECK(carried[2].step == "13_iso");
    CHECK(carried[2].outcome == "changes it");
    CHECK(steps[0].second == before[0].second);
    CHECK(steps[1].second == step_source("// The exit, fixed.\n", fixed));  // comments too
    CHECK(steps[2].second == step_source("// The exit, fixed.\n", fixed));
    CHECK(steps[3].second == before[3].second);
    CHECK(steps[4].second == before[4].second);
    CHECK(lesson::find_drifts(steps).empty());
    // Run again: nothing left to do.
    const std::vector<lesson::Carried> again = lesson::carry_forward(steps, "exit_t", "10");
    CHECK(again[0].outcome == "same");
    CHECK_THROWS_AS(lesson::carry_forward(steps, "main", "10"), lesson::InputError);
    CHECK_THROWS_AS(lesson::carry_forward(steps, "exit_t", "20"), lesson::InputError);
}

// --- Part 2 branches: copies follow the "Builds on:" chain, not the step numbers ----------

namespace {

// A step whose header builds on `base` ("" for no Builds-on line: the step before it).
std::string built_on(const std::string& base, const std::string& comment, const std::string& body) {
    return (base.empty() ? "" : "// Builds on:  " + base + " (what it takes).\n") +
           step_source(comment, body);
}

const std::string plain = "    return t + 1;\n", jittered = "    return t + 1 + 0.25;\n";
const std::string jitter_note = "// Changed in step 13: moved by the jitter.\n";

// 12 -> 13 (jitter) -> 14; 15 and 16 build on 12, 17 on 16, like the lab's part 2.
Steps branching_steps() {
    return {{"12_trilinear", built_on("", "// The exit.\n", plain)},
            {"13_jitter", built_on("12_trilinear", jitter_note, jittered)},
            {"14_blue_noise", built_on("13_jitter", jitter_note, jittered)},
            {"15_modes", built_on("12_trilinear", "// The exit.\n", plain)},
            {"16_iso", built_on("12_trilinear", "// The exit.\n", plain)},
            {"17_phong", built_on("16_iso", "// The exit.\n", plain)}};
}

}  // namespace

TEST_CASE("builds on: the step names of the header's line and its continuation, in order") {
    CHECK(lesson::builds_on("// x.cpp: a step.\n// Builds on:  12_trilinear (the camera).\n"
                            "// Handout:    handouts/x.md (not 13_jitter)\n") ==
          std::vector<std::string>{"12_trilinear"});
    // Step 30's: two steps, the second on the indented line that continues the first.
    CHECK(lesson::builds_on("// Builds on:  22_free_leaping (its leaping, step 31's trick)\n"
                            "//             and 15_projection_modes (MIP).\n"
                            "// Run:        make run STEP=30\n#include \"x\"\n// 09_empty\n") ==
          std::vector<std::string>{"22_free_leaping", "15_projection_modes"});
    CHECK(lesson::builds_on("// Builds on:  nothing: this is the first step.\n").empty());
    CHECK(lesson::builds_on("// Builds on: step 09's bricks, x09_a and 9_b are no names.\n").empty());
    CHECK(lesson::builds_on("int main() {}\n").empty());
}

TEST_CASE("step parents: the steps a header names, else the step numbered before") {
    Steps steps = branching_steps();
    steps.push_back({"18_clip", step_source("// The exit.\n", plain)});  // no line: after 17
    const auto parents = lesson::step_parents(steps);
    CHECK(parents[0].empty());  // the first step builds on none
    CHECK(parents[1] == std::vector<size_t>{0});
    CHECK(parents[2] == std::vector<size_t>{1});
    CHECK(parents[3] == std::vector<size_t>{0});  // 15 builds on 12, not on 14
    CHECK(parents[4] == std::vector<size_t>{0});
    CHECK(parents[5] == std::vector<size_t>{4});
    CHECK(parents[6] == std::vector<size_t>{5});
    // A step that is not in the tree, or a later one (no loops): an error naming both.
    steps[0].second = built_on("11_slab", "// The exit.\n", plain);
    CHECK_THROWS_WITH_AS(lesson::step_parents(steps),
                         "steps/12_trilinear.cpp: its \"Builds on:\" line names 11_slab, which "
                         "is not an earlier step in steps/",
                         ctlab::InputError);
    steps[0].second = built_on("15_modes", "// The exit.\n", plain);
    CHECK_THROWS_AS(lesson::step_parents(steps), ctlab::InputError);
}

TEST_CASE("branches: a step is compared with its nearest ancestor, never with a sibling") {
    Steps steps = branching_steps();
    // 13 changes the function and 14 keeps 13's; 15, 16 and 17 keep 12's: no drift, although
    // 15's copy differs from 14's, the step numbered just before it.
    CHECK(lesson::find_drifts(steps).empty());
    // 15 given 13's jittered body without saying so: a drift against 12, not against 14.
    steps[3].second = built_on("12_trilinear", "// The exit.\n", jittered);
    CHECK(drift_names(lesson::find_drifts(steps)) == "exit_t 12_trilinear 15_modes\n");
    // 17 follows 16 (its parent), and 16 follows 12.
    steps[3].second = built_on("12_trilinear", "// The exit.\n", plain);
    steps[5].second = built_on("16_iso", "// The exit.\n", "    return t;\n");
    CHECK(drift_names(lesson::find_drifts(steps)) == "exit_t 16_iso 17_phong\n");
    // A step that builds on two: the nearest that has the function, the first named on a tie.
    Steps two = {{"01_a", step_source("", plain)},
                 {"02_b", step_source("", "    return 0;\n")},
                 {"03_c", built_on("01_a", "", plain) + "// Also uses 02_b.\n"},
                 {"04_d", "// Builds on:  03_c (most)\n//             and 02_b (its exit).\n" +
                              step_source("", "    return 0;\n")}};
    // 02_b has no Builds-on line: it follows 01_a, and differs from it.
    CHECK(drift_names(lesson::find_drifts(two)) == "exit_t 01_a 02_b\n"
                                                   "exit_t 03_c 04_d\n");
    const auto parents = lesson::step_parents(two);
    CHECK(parents[3] == std::vector<size_t>{2, 1});
    CHECK(lesson::compared_step(parents, 3, [](size_t) { return true; }) == 2);
    CHECK(lesson::compared_step(parents, 3, [](size_t m) { return m != 2; }) == 1);
    CHECK(lesson::compared_step(parents, 3, [](size_t m) { return m == 0; }) == 0);
    CHECK(lesson::compared_step(parents, 0, [](size_t) { return true; }) == -1);
}

TEST_CASE("carry-lab on branches: a fix reaches the steps whose chain takes it unchanged") {
    const std::string fixed = "    return t + 1.5;\n";
    Steps steps = branching_steps();
    steps[0].second = step_source("// The exit, fixed.\n", fixed);
    const Steps before = steps;
    const std::vector<lesson::Carried> carried = lesson::carry_forward(steps, "exit_t", "12");
    // 13 changes it (14 follows 13: untouched, not listed); 15, 16 and 17 (through 16) take it.
    REQUIRE(carried.size() == 4);
    CHECK(carried[0].step == "13_jitter");
    CHECK(carried[0].outcome == "changes it");
    CHECK(carried[1].step == "15_modes");
    CHECK(carried[1].outcome == "carried");
    CHECK(carried[1].earlier == "12_trilinear");
    CHECK(carried[2].step == "16_iso");
    CHECK(carried[3].step == "17_phong");
    CHECK(carried[3].outcome == "carried");
    CHECK(carried[3].earlier == "16_iso");
    CHECK_FALSE(carried[3].drifted);
    CHECK(steps[1].second == before[1].second);
    CHECK(steps[2].second == before[2].second);
    for (size_t n : {3, 4, 5}) {
        CHECK(steps[n].second.find("// The exit, fixed.\nstatic double exit_t(double t) {\n" +
                                   fixed + "}\n") != std::string::npos);
        CHECK(steps[n].second.rfind("// Builds on:  ", 0) == 0);  // the header stays
    }
    CHECK(lesson::find_drifts(steps).empty());

    // A fix to 13's jittered version reaches 14 only, never 15 (a sibling's copy).
    Steps jitter = branching_steps();
    jitter[1].second = built_on("12_trilinear", jitter_note, "    return t + 1 + 0.5;\n");
    const Steps unfixed = jitter;
    const auto into = lesson::carry_forward(jitter, "exit_t", "13");
    REQUIRE(into.size() == 1);
    CHECK(into[0].step == "14_blue_noise");
    CHECK(into[0].outcome == "carried");
    CHECK(jitter[2].second == built_on("13_jitter", jitter_note, "    return t + 1 + 0.5;\n"));
    for (size_t n : {0, 3, 4, 5}) CHECK(jitter[n].second == unfixed[n].second);
}

TEST_CASE("unlinked copies: the same code off the chain asks the header to name its step") {
    const std::string other = "static int other() { return 2; }\n";
    Steps steps = {{"08_lit", other},
                   {"09_bricks", built_on("08_lit", "", plain)},
                   {"10_camera", "// Builds on:  08_lit.\n" + other},
                   {"12_leap", built_on("10_camera", "", plain)}};
    // 12's exit_t is 09's, but 12 builds on 10, 10 on 08, and neither has it: nothing compares
    // them (nor would make carry bring it), so the copy is reported.
    CHECK(lesson::find_drifts(steps).empty());
    CHECK(drift_names(lesson::find_unlinked_copies(steps)) == "exit_t 09_bricks 12_leap\n");
    // Naming 09 too links it: no longer reported, and now compared.
    steps[3].second = "// Builds on:  10_camera (the camera) and\n//             09_bricks (exit_t).\n" +
                      step_source("", plain);
    CHECK(lesson::find_unlinked_copies(steps).empty());
    CHECK(lesson::find_drifts(steps).empty());
    steps[3].second = "// Builds on:  10_camera (the camera) and\n//             09_bricks (exit_t).\n" +
                      step_source("", jittered);
    CHECK(drift_names(lesson::find_drifts(steps)) == "exit_t 09_bricks 12_leap\n");
    // A function of its own, found in no earlier step: new, nothing reported.
    steps[3].second = built_on("10_camera", "", "    return 3 * t;\n");
    CHECK(lesson::find_unlinked_copies(steps).empty());
}

// The lab's own part 2: step 18's compositing is step 15's (byte for byte, and so compared and
// carried), while 16's is jittered: comparing 18 with the step numbered before it would fail.
TEST_CASE("the lab's branches: 18, 19 and 25 take their functions from step 15") {
    const Steps steps = lesson::read_steps(".");
    const auto index = [&](const std::string& prefix) {
        for (size_t n = 0; n < steps.size(); ++n) {
            if (steps[n].first.compare(0, prefix.size(), prefix) == 0) return n;
        }
        FAIL("no step " << prefix);
        return size_t(0);
    };
    const auto function = [&](size_t n, const std::string& name) {
        for (const lesson::StepFunction& found :
             lesson::step_functions(steps[n].second, steps[n].first, steps[n].first.substr(0, 2))) {
            if (found.name == name) return found;
        }
        FAIL(steps[n].first << " has no " << name << "()");
        return lesson::StepFunction{};
    };
    const auto parents = lesson::step_parents(steps);
    const size_t twelve = index("15_"), thirteen = index("16_"), fourteen = index("17_");
    const std::string composite = "composite_front_to_back";
    CHECK(function(thirteen, composite).code != function(twelve, composite).code);
    CHECK(function(fourteen, composite).code == function(thirteen, composite).code);
    for (const char* step : {"18_", "19_", "20_"}) {
        const size_t n = index(step);
        const auto defines = [&](size_t m) {
            for (const auto& found : lesson::step_functions(steps[m].second, steps[m].first,
                                                            steps[m].first.substr(0, 2))) {
                if (found.name == composite) return true;
            }
            return false;
        };
        const int from = lesson::compared_step(parents, n, defines);
        REQUIRE(from >= 0);
        CHECK(steps[size_t(from)].first == (step == std::string("20_") ? steps[index("19_")].first
                                                                      : steps[twelve].first));
        // Step 15's, comments and all: nothing says "changed" where nothing changed.
        CHECK(function(n, composite).text == function(twelve, composite).text);
        CHECK_FALSE(function(n, composite).changed);
    }
    CHECK(parents[index("18_")] == std::vector<size_t>{twelve});
    CHECK(parents[index("25_")] == std::vector<size_t>{twelve, index("11_")});
}

// The rule on the lab itself: every function a later step holds is the earlier step's code,
// or the later step says "changed in step NN". `make carry-lab FUNCTION=name FROM=NN` fixes
// a drift that was a fix made in one step only.
TEST_CASE("the lab's steps: no copy of a function has drifted from the step it builds on") {
    const Steps steps = lesson::read_steps(".");
    REQUIRE(steps.size() >= 10);
    for (const lesson::Drift& drift : lesson::find_drifts(steps)) {
        const std::string message =
            "steps/" + drift.later + ".cpp: " + drift.function + "() differs from steps/" +
            drift.earlier + ".cpp's, and its comments do not say \"changed in step " +
            drift.later.substr(0, 2) + ": why\" (or: make carry-lab FUNCTION=" + drift.function +
            " FROM=" + drift.earlier.substr(0, 2) + ")";
        FAIL_CHECK(message);
    }
    // A copy no ancestor holds: the header's Builds-on line must name the step it comes from.
    for (const lesson::Drift& copy : lesson::find_unlinked_copies(steps)) {
        const std::string message =
            "steps/" + copy.later + ".cpp: " + copy.function + "() is steps/" + copy.earlier +
            ".cpp's, but no step its \"Builds on:\" line leads to has it: name " +
            copy.earlier + " there";
        FAIL_CHECK(message);
    }
}
