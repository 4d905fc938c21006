// run_step.h: the seam between the steps and the programs that test or measure them (the
// tests, make bench, make study, graders). They never compile a step's .cpp: they run its
// binary as a process and read what it writes, exactly as a student or instructor sees it:
//   - the exit status, stdout and stderr;
//   - the summary lines, one per view: "step=... view=... size=WxH time_ms=... samples=...";
//   - the --debug-pixel traces: "debug pixel x=X y=Y view=V ...", the sample lines, then
//     "pixel x=X y=Y rgb=(R, G, B) png=(...) samples=N";
//   - the pictures: OUT/NN_name_<view>.png, and with --pfm the float image OUT/NN_name_<view>.pfm.
// A lesson function may then change its name or signature freely: only the command line and
// what the program prints are an interface. Analytic volumes go to the steps as temporary raw
// files (int16 little-endian, --dims, --spacing).
//
// Compiled into build/libctlab_tools.a (for tests and tools), never into a step.
#pragma once
#include <map>
#include <string>
#include <vector>
#include "image.h"
#include "render.h"
#include "tools/process.h"
#include "volume.h"

namespace ctlab {

// One summary line as key -> value ("view" -> "front", "samples" -> "1234").
using Summary = std::map<std::string, std::string>;

// "key=value key=value ..." -> the map; words without '=' are ignored.
Summary parse_summary(const std::string& line);

// One --debug-pixel trace as printed by the step.
struct PixelTrace {
    std::string view;
    int x = 0, y = 0;
    std::string header;              // the "debug pixel ..." line
    std::vector<std::string> lines;  // the lines between header and result, indent removed
    Rgb rgb;                         // the traced ray's value, as printed (%.6f)
    int png[3] = {0, 0, 0};          // the same, quantised
    unsigned long long samples = 0;  // the samples= of the result line
    bool complete = false;           // the result line was found
    // The trace's records, read from the sidecar the step wrote beside its ray picture
    // (OUT/STEP_VIEW_ray_X_Y.txt; run_step reads it when the flags name --out): the machine
    // form to read numbers from, where `lines` are only the text as printed.
    std::vector<TraceRecord> records;
};

// What one run of a program gave (tools/process.h), its output parsed.
struct RunResult : ProcessResult {
    std::vector<Summary> summaries;    // the summary lines, in order (lines starting "step=")
    std::vector<PixelTrace> traces;    // the --debug-pixel traces, in order

    // The summary line of a view ("top", "front", "side"); throws when there is none.
    const Summary& summary(const std::string& view) const;
};

// Runs `program` with `args` (no shell; tools/process.h), stdin from /dev/null, stdout and
// stderr captured, killed after timeout_s seconds. Throws std::runtime_error only when it
// cannot start.
RunResult run_program(const std::string& program, const std::vector<std::string>& args,
                      double timeout_s = 120);

// The folder holding the running program's binary: build/ for build/ctlab_tests and
// build/bench, build-san/ for the sanitizer build. The steps are built beside it.
std::string build_folder();

// build_folder() + "/" + step, e.g. ".../build/03_depth_shading".
std::string step_binary(const std::string& step);

// Runs a step's binary with --no-window and these flags; summaries and traces parsed.
RunResult run_step(const std::string& step, const std::vector<std::string>& flags,
                   double timeout_s = 120);

// Whether a camera step looks along an axis only (its --help says --azimuth is "a multiple of
// 90": part 3's object-order step): the oblique cases of the bench, the gain and the tests are
// not its to render. Asked of the step's own binary, so that no list of steps is kept here.
bool looks_along_axes_only(const std::string& step);

// The summary numbers: value of `key` in a line as a number; throws when it is missing.
double summary_number(const Summary& summary, const std::string& key);
unsigned long long summary_count(const Summary& summary, const std::string& key);

// Reads a colour ("PF") or grey ("Pf") PFM, either byte order; rows turned back to top
// first. Throws InputError naming the file and the problem.
Image read_pfm(const std::string& path);

// OUT/STEP_VIEW.pfm and OUT/STEP_VIEW.png, as a step names them.
std::string step_output(const std::string& out, const std::string& step, const std::string& view,
                        const std::string& extension);

// Writes the volume's voxels as int16 little-endian, no header, i fastest, to `path`, and
// returns the flags that load it back: --volume PATH --dims NX,NY,NZ --spacing SX,SY,SZ.
std::vector<std::string> write_raw_volume(const Volume& volume, const std::string& path);

// A folder of its own under the system temp folder, removed with everything in it.
class TempFolder {
public:
    explicit TempFolder(const std::string& tag);
    // The same under `parent` (a folder that exists); "" is the system temp folder.
    TempFolder(const std::string& tag, const std::string& parent);
    ~TempFolder();
    TempFolder(const TempFolder&) = delete;
    TempFolder& operator=(const TempFolder&) = delete;
    std::string path() const { return path_; }
    std::string path(const std::string& name) const { return path_ + "/" + name; }
    // Writes a file of exactly these bytes and returns its path.
    std::string file(const std::string& name, const std::vector<unsigned char>& bytes) const;
    std::string text_file(const std::string& name, const std::string& text) const;

private:
    std::string path_;
};

}  // namespace ctlab
