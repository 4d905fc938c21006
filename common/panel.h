// panel.h: the preview window's control panel (Dear ImGui), left of the image.
//
// Every flag of the step's own table (Args::add_*) is a widget, so a new flag shows up by
// itself: a slider for a number, a combo for a choice, a checkbox for a switch, a text field
// for text. Moving one asks the step to run again with the command line rewritten (coarse
// while a slider is held, full size when it is let go). Below: the transfer-function editor
// over the volume's histogram (steps with --tf), the live summary counters, and the command
// line that reproduces the picture. --window-script's set:NAME=VALUE and tf:... events go
// through the same functions as the widgets (panel_set_flag, the tf_* edits).
#pragma once
#include <string>
#include <vector>
#include "args.h"
#include "transfer_function.h"
#include "volume.h"

namespace ctlab {

struct Preview;

// What a frame of the panel asks the window to do.
struct PanelActions {
    bool set = false;          // run the step again with `words`
    std::vector<std::string> words;
    bool coarse = false;       // ... as a coarse preview (a slider is still held)
    std::string changed;       // "--threshold=600": what changed, for the log
    int view = -1;             // show this view (index into Preview::views)
    std::string preset;        // switch to this preset (as the P key does)
    std::string note;          // a line to print ("window: ...")
};

// The panel's state between frames, kept while the window stays open across reruns.
struct PanelState {
    // The transfer-function editor: its own copy of the table, the file it writes.
    TransferFunction tf;
    bool tf_edited = false;    // tf differs from what the step loaded: the editor's copy wins
    std::string tf_path;       // where edits are saved (--tf then names it)
    int selected = 0;          // the range whose colour and opacity the editor shows
    int dragging_end = -1;     // 2*range + (0: from, 1: to) being dragged on the histogram
    bool drag_shared = false;  // ... which its neighbour shared when grabbed
    // The histogram of the volume values: counts per bin over [lowest, lowest + bins*width).
    std::string histogram_of;  // the volume's name and size it belongs to
    std::vector<double> counts;
    int lowest = 0, bin_width = 1;
    std::vector<std::string> text_fields;  // the text flags' edit buffers, by flag index
    std::vector<bool> text_typing;         // ... and which one is being typed in
    std::string note;          // the last message (an error the rerun reported)
    std::string status;        // the last render: "front 256x226, 12.3 ms" and its counters
    // Widgets' screen rectangles (window pixels), for tests: "--threshold" -> x, y, w, h.
    std::vector<std::pair<std::string, std::vector<int>>> rects;
};

// The panel's width in window pixels (the image and the ray panel sit right of it).
constexpr int panel_width = 340;

// Draws the panel into the current ImGui frame, full window height at the left.
void draw_panel(const Preview& preview, PanelState& state, int height, PanelActions* actions);

// The words with flag NAME (with or without "--") set to VALUE (a switch: "1" on, "" off), as
// a widget would set it. Throws InputError for a flag the step does not have or a bad value
// (checked as the command line would be).
std::vector<std::string> panel_set_flag(const Preview& preview, const std::string& name,
                                        const std::string& value);

// The command line that reproduces the current picture: program and words, quoted for sh;
// --window-script left out.
std::string panel_command(const Preview& preview);

// The editor's edits (the widgets and the script's tf:N:FIELD=VALUE use these). Each keeps the
// ranges half open, sorted, never overlapping; a boundary two ranges share moves for both
// (unless move_shared is false: a drag that grabbed a free end), a free end stops at its
// neighbour.
void tf_set_from(TransferFunction& tf, int range, int value, bool move_shared = true);
void tf_set_to(TransferFunction& tf, int range, int value, bool move_shared = true);
void tf_set_opacity(TransferFunction& tf, int range, double opacity);
void tf_set_colour(TransferFunction& tf, int range, float r, float g, float b);
// A new range in the widest gap within [low, high) (half its width, centred), or the
// selected range split in two when there is no gap; returns its index.
int tf_add_range(TransferFunction& tf, int low, int high, int selected);
void tf_remove_range(TransferFunction& tf, int range);

// The editor's table (state.tf) saved to state.tf_path and the words with --tf naming it
// (--skin-opacity dropped: the file holds the opacity). Throws InputError when not written.
std::vector<std::string> panel_save_tf(const Preview& preview, PanelState& state);

// One --window-script event for the panel: "set:NAME=VALUE" or "tf:N:from=V", "tf:N:to=V",
// "tf:N:opacity=A", "tf:N:colour=RRGGBB", "tf:add", "tf:remove:N", "tf:path=FILE" (no commas:
// they separate the script's events). Fills actions as the widget would. Throws InputError on
// a bad event.
void panel_script_event(const Preview& preview, PanelState& state, const std::string& event,
                        PanelActions* actions);

// True when `event` has the form of a panel event (checked before the window opens).
bool is_panel_event(const std::string& event);

}  // namespace ctlab
