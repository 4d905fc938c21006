// args.h: the command line every step shares, plus a step's own flags.
//
//   --volume PATH|phantom   --dims NX,NY,NZ  --endian little|big  --spacing SX,SY,SZ
//   --type uint8|int8|uint16|int16|float32
//   --view top|front|side|all  --out DIR  --no-window  --debug-pixel X,Y  --threads N  --help
//   --pfm  --repeat N   (for tests and measurements: float images, repeated timing)
//   --work-map          (for make check: every ray's work counters, common/step.h)
// A step adds its own (--threshold, --slice, ...) before parse(). Any bad flag or number
// throws InputError naming the flag and what was expected.
#pragma once
#include <string>
#include <vector>
#include "volume.h"

namespace ctlab {

// A step's own flag as the window's control panel shows it (common/panel.cpp): one entry of
// the table Args::add_* builds, with its value after parsing.
enum class FlagKind { integer, real, choice, text, on_off };
struct FlagSpec {
    std::string name;                 // "--skin-opacity"
    FlagKind kind = FlagKind::text;
    double min = 0, max = 0;          // integer and real: the accepted range
    std::vector<std::string> choices; // choice: the accepted words
    std::string help;
    std::string value;                // as parsed, written as a command line would give it;
                                      // on_off: "1" when given, "" when not
    bool file_units = false;          // a value of the volume in its file's units (--threshold)
};

// --debug-pixel given again and again: at most this many pixels in one run (each writes a
// ray picture and its numbers per view, and a run's files are written all or none).
constexpr size_t max_debug_pixels = 64;

struct Options {
    std::string step;                 // e.g. "03_depth_shading": names the PNGs and the summary
    std::string volume;               // "" = data/CThead when present, else the phantom
    bool has_dims = false;            // --dims given: a generic raw file
    bool has_endian = false, has_spacing = false;
    RawFormat raw;                    // --dims, --endian, --spacing, --type
    bool has_type = false;
    // Flags whose values are in the volume file's own units (--threshold): converted into the
    // volume's int16 values by load_volume() through the volume's map (see ValueMap).
    struct FileUnitsFlag {
        std::string name;
        double value = 0;             // as given, in file units
        std::string text;             // as typed, for messages
        int* target = nullptr;        // the step's int, set by load_volume()
        int min = 0, max = 0;
    };
    std::vector<FileUnitsFlag> file_units;
    std::string view = "all";         // top, front, side or all
    std::string out = "out";          // folder for the PNGs
    bool no_window = false;
    bool has_debug_pixel = false;
    int debug_x = 0, debug_y = 0;     // image column and row (the first --debug-pixel)
    std::vector<std::pair<int, int>> debug_pixels;  // every --debug-pixel X,Y, in order
    bool ray_pictures = true;         // --no-ray-picture: the traces without their pictures
    bool trace_only = false;          // --trace-only: the traced rays alone, no whole render
    int threads = 1;                  // resolved: --threads N, default all cores
    bool pfm = false;                 // --pfm: also write OUT/STEP_VIEW.pfm (float RGB)
    bool work_map = false;            // --work-map: also write OUT/STEP_VIEW_work.txt
    int repeat = 1;                   // --repeat N: render each view N times (timing)
    std::string window_script;        // tests only: events to inject into the preview window
    std::string preset;               // --preset NAME ("" = none)
    std::string program;              // argv[0], as the window's command line shows it
    std::vector<FlagSpec> flags;      // the step's own flags and their values (the panel)
    std::vector<std::string> words;   // the command line after the program's name, as typed
                                      // (or as the window's panel rewrote it)
    bool rerun = false;               // run again by the window's panel: the window is open
};

class Args {
public:
    Args(std::string step, std::string summary);

    // A step's own flags. Values are checked against [min, max] when parsed.
    void add_int(const std::string& flag, int* target, int min, int max, const std::string& help);
    void add_double(const std::string& flag, double* target, double min, double max,
                    const std::string& help);
    void add_choice(const std::string& flag, std::string* target,
                    const std::vector<std::string>& choices, const std::string& help);
    // metavar: what --help shows after the flag for its value ("FILE", "WxH", ...).
    void add_string(const std::string& flag, std::string* target, const std::string& help,
                    const std::string& metavar = "FILE");
    void add_switch(const std::string& flag, bool* target, const std::string& help);

    // Parses argv. --help prints the usage and exits with status 0.
    Options parse(int argc, char** argv);

    std::string usage() const;

private:
    Options parse_words(int argc, char** argv);
    std::vector<std::string> preset_words(const std::string& name) const;
    using Kind = FlagKind;
    struct Flag {
        std::string name;
        Kind kind;
        void* target;
        double min, max;
        std::vector<std::string> choices;
        std::string help;
        std::string metavar = "";  // a text flag's value in --help
    };
    std::string step_, summary_;
    std::vector<Flag> flags_;
};

// The presets in data/presets (NAME.preset), sorted. A preset holds "--flag value" lines.
std::vector<std::string> preset_names();

// The preset after `current` in preset_names(), wrapping round ("" when there are none).
std::string next_preset(const std::string& current);

// The preview window's P key: the step runs again with another preset (guarded_main does it).
// request_preset() records the wish; switch_preset() makes Args::parse use that preset in place
// of the command line's --preset (the command line's other flags still win); "" goes back to
// the command line as typed. switched_preset(): the preset in use, "" when as typed.
void request_preset(const std::string& name);
bool take_preset_request(std::string* name);
void switch_preset(const std::string& name);
const std::string& switched_preset();

// The window's control panel: the step runs again (guarded_main) with `words` in place of the
// command line's (a widget moved: the panel rewrote one flag). request_rerun() records the
// wish, take_rerun_request() hands it over, switch_words() makes Args::parse use the words
// (and mark the Options as a rerun) until end_rerun().
void request_rerun(const std::vector<std::string>& words);
bool take_rerun_request(std::vector<std::string>* words);
void switch_words(const std::vector<std::string>& words);
void end_rerun();
bool rerunning();

// Strict number parsing: the whole text must be a number in [min, max]. Throw InputError
// "FLAG: expected WHAT, got 'TEXT'".
int parse_int(const std::string& flag, const std::string& text, int min, int max);

// --size WIDTHxHEIGHT: "512x384" -> 512, 384, each side 1 .. max_side; anything else is
// refused naming --size.
void parse_size(const std::string& text, int max_side, int* width, int* height);
double parse_double(const std::string& flag, const std::string& text, double min, double max);

// Loads what --volume names: the phantom, a CThead file, a raw file (--dims or a name like
// foot_256x256x256_uint8.raw), NIfTI, NRRD, MetaImage or a DICOM folder (common/formats.h).
// Converts the file-units flags (--threshold) into the volume's values.
// The default (no --volume) is data/CThead when present, else the phantom.
Volume load_volume(const Options& options);

}  // namespace ctlab
