// args.h: the command line every step shares, plus a step's own flags.
//
//   --volume PATH|phantom   --dims NX,NY,NZ  --endian little|big  --spacing SX,SY,SZ
//   --type uint8|int8|uint16|int16|float32
//   --view top|front|side|all  --out DIR  --no-window  --debug-pixel X,Y  --threads N  --help
//   --pfm  --repeat N   (for tests and measurements: float images, repeated timing)
// A step adds its own (--threshold, --slice, ...) before parse(). Any bad flag or number
// throws InputError naming the flag and what was expected.
#pragma once
#include <string>
#include <vector>
#include "volume.h"

namespace ctlab {

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
    int threads = 1;                  // resolved: --threads N, default all cores
    bool pfm = false;                 // --pfm: also write OUT/STEP_VIEW.pfm (float RGB)
    int repeat = 1;                   // --repeat N: render each view N times (timing)
    std::string window_script;        // tests only: events to inject into the preview window
    std::string preset;               // --preset NAME ("" = none)
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
    void add_string(const std::string& flag, std::string* target, const std::string& help);
    void add_switch(const std::string& flag, bool* target, const std::string& help);

    // Parses argv. --help prints the usage and exits with status 0.
    Options parse(int argc, char** argv);

    std::string usage() const;

private:
    Options parse_words(int argc, char** argv);
    std::vector<std::string> preset_words(const std::string& name) const;
    enum class Kind { integer, real, choice, text, on_off };
    struct Flag {
        std::string name;
        Kind kind;
        void* target;
        double min, max;
        std::vector<std::string> choices;
        std::string help;
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
