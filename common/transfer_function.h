// transfer_function.h: reading a transfer function file (data/tf/*.tf) into a list of ranges.
//
// Only the boring part lives here: the text format, its checks and its error messages. Turning
// the ranges into a lookup table is the lesson of step 07 (and stays in the steps).
// The format is described at the top of data/tf/classic.tf.
#pragma once
#include <string>
#include <vector>
#include "volume.h"

namespace ctlab {

// Colour and opacity of one CT value.
struct Rgba {
    float r = 0, g = 0, b = 0;  // colour, 0..1
    float a = 0;                // opacity alpha, 0..1, for one unit of length (spacing 1)
};

// The CT values a range can cover: every int16. A range's TO is exclusive, so TO = 32768
// reaches the top value 32767.
constexpr int lowest_ct_value = -32768;
constexpr int ct_value_end = 32768;  // one past the highest int16

struct TfRange {
    int from = 0, to = 0;  // volume values from <= value < to (half open); CT values for CT
    double file_from = 0, file_to = 0;  // FROM and TO as the file gives them (file units)
    bool ramp = false;     // false: `start` everywhere; true: linear from `start` at from to
                           // `end` at to
    Rgba start, end;       // end == start for a constant range
    std::string label;     // optional name, e.g. "skin": how the command line refers to it
    int line = 0;          // where the range is in its file, for messages
};

struct TransferFunction {
    std::string source;           // the file it came from, or "built-in-classic"
    std::vector<TfRange> ranges;  // sorted by `from`, never overlapping; gaps are transparent
};

// The default --tf, relative to the working folder (like data/CThead).
constexpr const char* classic_tf_path = "data/tf/classic.tf";

// Parses the text of a .tf file. Every problem throws InputError "SOURCE:LINE: what was wrong".
// FROM and TO are values in the volume file's own units, turned into the volume's int16
// values through `map` (volume.map), as --threshold is:
// - the identity (CT, and any file of whole numbers that fit int16): FROM and TO must be whole
//   numbers from -32768 to 32768 and are taken as they are;
// - a shift (whole numbers beyond int16, e.g. uint16 above 32767): exact, FROM becomes the
//   smallest volume value whose file value is at least FROM;
// - a scale (floats, scaled NIfTI): rounded like the samples were when the volume was loaded,
//   so a sample equal to FROM in the file lands in the range, as it would in int16.
// Either may clamp to the int16 values, and a range narrower than one volume step may become
// empty (from == to); the order of the ranges is kept.
TransferFunction parse_transfer_function(const std::string& text, const std::string& source,
                                         const ValueMap& map = ValueMap{});

// Reads and parses a file, for a volume whose values relate to its file's by `map` (see
// parse_transfer_function). An empty path means the default: data/tf/classic.tf when present,
// else the built-in classic table (the same ranges, for runs from another folder). A map that
// is not the identity prints one line "units: --tf PATH (file units) [F, T) = [f, t) ...".
TransferFunction load_transfer_function(const std::string& path,
                                        const ValueMap& map = ValueMap{});

// The text of a .tf file holding these ranges (the window's editor saves it): FROM and TO in
// the volume file's units through `map` (whole numbers for the identity), every number with
// the digits that read back to the same value, a header naming `title`. Empty ranges are left
// out. parse_transfer_function() of it gives the same ranges.
std::string transfer_function_text(const TransferFunction& tf, const ValueMap& map,
                                   const std::string& title);

// The classic table (skin and bone) without any file; a test checks it equals classic.tf.
TransferFunction classic_transfer_function();

// The range with this label, or nullptr when there is none.
const TfRange* find_range(const TransferFunction& tf, const std::string& label);

// Sets the opacity (0..1) of the range with this label, at both ends of a ramp. Throws
// InputError "FLAG: SOURCE has no range labelled LABEL" when there is no such range.
void set_opacity(TransferFunction& tf, const std::string& label, double opacity,
                 const std::string& flag);

}  // namespace ctlab
