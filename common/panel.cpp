// panel.cpp: the preview window's control panel (see panel.h).
#include "panel.h"
#include <SDL.h>
#include <imgui.h>
#include <imgui_stdlib.h>
#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include "error.h"
#include "output_files.h"
#include "window.h"

namespace ctlab {

namespace {

constexpr int histogram_bins = 256;       // bars over the volume's values
constexpr float histogram_height = 130;   // window pixels
constexpr float grab_pixels = 6;          // a range's end is grabbed this close to it
constexpr int drag_steps = 2000;          // a drag widget crosses its range in this many px

// "--skin-opacity" for "skin-opacity", "--skin-opacity" or "skin_opacity".
std::string flag_name(std::string name) {
    for (char& c : name) {
        if (c == '_') c = '-';
    }
    return name.rfind("--", 0) == 0 ? name : "--" + name;
}

const FlagSpec* find_flag(const Preview& preview, const std::string& name) {
    for (const FlagSpec& flag : preview.flags) {
        if (flag.name == name) return &flag;
    }
    return nullptr;
}

// A double as the command line would give it: the shortest text that reads back the same.
std::string real_text(double value) {
    char text[40];
    for (int digits = 3; digits <= 17; ++digits) {
        std::snprintf(text, sizeof text, "%.*g", digits, value);
        if (std::strtod(text, nullptr) == value) break;
    }
    return text;
}

// The words without any occurrence of `flag` ("--flag value", "--flag=value", or "--flag"
// alone for a switch).
std::vector<std::string> without_flag(const std::vector<std::string>& words,
                                      const std::string& flag, bool takes_value) {
    std::vector<std::string> kept;
    for (size_t n = 0; n < words.size(); ++n) {
        if (words[n] == flag) {
            if (takes_value) ++n;
            continue;
        }
        if (words[n].rfind(flag + "=", 0) == 0) continue;
        kept.push_back(words[n]);
    }
    return kept;
}

// A word as sh reads it back: plain when safe, else in single quotes.
std::string quoted(const std::string& word) {
    bool plain = !word.empty();
    for (char c : word) {
        plain = plain && (std::isalnum(static_cast<unsigned char>(c)) ||
                          std::string("_./,=:+-@%").find(c) != std::string::npos);
    }
    if (plain) return word;
    std::string text = "'";
    for (char c : word) text += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return text + "'";
}

// The volume's histogram, once per volume: counts of values in bins of equal width.
void update_histogram(const Volume& volume, PanelState& state) {
    const std::string key = volume.name + " " + std::to_string(volume.nx) + "x" +
                            std::to_string(volume.ny) + "x" + std::to_string(volume.nz);
    if (state.histogram_of == key) return;
    state.histogram_of = key;
    const int span = int(volume.max_value) - int(volume.min_value) + 1;
    state.lowest = volume.min_value;
    state.bin_width = std::max(1, (span + histogram_bins - 1) / histogram_bins);
    state.counts.assign(histogram_bins, 0.0);
    for (int k = 0; k < volume.nz; ++k) {
        for (int j = 0; j < volume.ny; ++j) {
            for (int i = 0; i < volume.nx; ++i) {
                const int bin = (volume.at(i, j, k) - state.lowest) / state.bin_width;
                state.counts[std::clamp(bin, 0, histogram_bins - 1)] += 1;
            }
        }
    }
}

void check_range(const TransferFunction& tf, int range) {
    if (range < 0 || range >= int(tf.ranges.size())) {
        throw InputError("tf: no range " + std::to_string(range) + " (the table has " +
                         std::to_string(tf.ranges.size()) + ")");
    }
}

}  // namespace

// --- Flags ---------------------------------------------------------------------------------

std::vector<std::string> panel_set_flag(const Preview& preview, const std::string& name,
                                        const std::string& value) {
    const std::string flag = flag_name(name);
    const FlagSpec* spec = find_flag(preview, flag);
    if (!spec) throw InputError("set: this step has no flag " + flag);
    // The same checks as the command line's, so a bad value never reaches a rerun.
    switch (spec->kind) {
        case FlagKind::integer:
            if (spec->file_units) parse_double(flag, value, -1e30, 1e30);
            else parse_int(flag, value, int(spec->min), int(spec->max));
            break;
        case FlagKind::real: parse_double(flag, value, spec->min, spec->max); break;
        case FlagKind::choice:
            if (std::find(spec->choices.begin(), spec->choices.end(), value) ==
                spec->choices.end()) {
                throw InputError(flag + ": not one of its choices: '" + value + "'");
            }
            break;
        case FlagKind::on_off:
            if (value != "1" && value != "0" && !value.empty()) {
                throw InputError(flag + ": a switch is 1 (on) or 0 (off), got '" + value + "'");
            }
            break;
        case FlagKind::text:
            if (value.empty()) throw InputError(flag + ": expected a value");
            break;
    }
    std::vector<std::string> words =
        without_flag(preview.words, flag, spec->kind != FlagKind::on_off);
    if (spec->kind == FlagKind::on_off) {
        if (value == "1") words.push_back(flag);
    } else {
        words.push_back(flag);
        words.push_back(value);
    }
    return words;
}

std::string panel_command(const Preview& preview) {
    std::string text = quoted(preview.program.empty() ? "build/" + preview.step
                                                      : preview.program);
    const std::vector<std::string> words = without_flag(preview.words, "--window-script", true);
    for (const std::string& word : words) text += " " + quoted(word);
    return text;
}

// --- The transfer-function editor's edits ---------------------------------------------------

void tf_set_from(TransferFunction& tf, int range, int value, bool move_shared) {
    check_range(tf, range);
    TfRange& self = tf.ranges[range];
    TfRange* before = range > 0 ? &tf.ranges[range - 1] : nullptr;
    // A shared boundary moves for both ranges; a free end stops at its neighbour.
    const bool joined = move_shared && before && before->to == self.from;
    const int low = before ? (joined ? before->from + 1 : before->to) : lowest_ct_value;
    self.from = std::clamp(value, low, self.to - 1);
    if (joined) before->to = self.from;
}

void tf_set_to(TransferFunction& tf, int range, int value, bool move_shared) {
    check_range(tf, range);
    TfRange& self = tf.ranges[range];
    TfRange* after = range + 1 < int(tf.ranges.size()) ? &tf.ranges[range + 1] : nullptr;
    const bool joined = move_shared && after && after->from == self.to;
    const int high = after ? (joined ? after->to - 1 : after->from) : ct_value_end;
    self.to = std::clamp(value, self.from + 1, high);
    if (joined) after->from = self.to;
}

void tf_set_opacity(TransferFunction& tf, int range, double opacity) {
    check_range(tf, range);
    const float a = float(std::clamp(opacity, 0.0, 1.0));
    tf.ranges[range].start.a = tf.ranges[range].end.a = a;
}

void tf_set_colour(TransferFunction& tf, int range, float r, float g, float b) {
    check_range(tf, range);
    for (Rgba* colour : {&tf.ranges[range].start, &tf.ranges[range].end}) {
        colour->r = std::clamp(r, 0.0f, 1.0f);
        colour->g = std::clamp(g, 0.0f, 1.0f);
        colour->b = std::clamp(b, 0.0f, 1.0f);
    }
}

int tf_add_range(TransferFunction& tf, int low, int high, int selected) {
    // The widest gap within [low, high): before the first range, between two, after the last.
    int best_from = 0, best_to = 0, best_at = 0;
    int cursor = low;
    for (int n = 0; n <= int(tf.ranges.size()); ++n) {
        const int gap_end = n < int(tf.ranges.size()) ? std::min(tf.ranges[n].from, high) : high;
        if (gap_end - cursor > best_to - best_from) {
            best_from = cursor, best_to = gap_end, best_at = n;
        }
        if (n < int(tf.ranges.size())) cursor = std::max(cursor, tf.ranges[n].to);
    }
    TfRange added;
    added.start = added.end = {0.9f, 0.3f, 0.2f, 0.2f};
    if (best_to - best_from >= 4) {
        const int quarter = (best_to - best_from) / 4;
        added.from = best_from + quarter;
        added.to = best_to - quarter;
        tf.ranges.insert(tf.ranges.begin() + best_at, added);
        return best_at;
    }
    // No room: split the selected range in two at its middle.
    if (tf.ranges.empty()) return -1;
    selected = std::clamp(selected, 0, int(tf.ranges.size()) - 1);
    TfRange& whole = tf.ranges[selected];
    if (whole.to - whole.from < 2) return -1;
    added = whole;
    added.label.clear();  // labels stay unique
    added.from = whole.from + (whole.to - whole.from) / 2;
    whole.to = added.from;
    tf.ranges.insert(tf.ranges.begin() + selected + 1, added);
    return selected + 1;
}

void tf_remove_range(TransferFunction& tf, int range) {
    check_range(tf, range);
    tf.ranges.erase(tf.ranges.begin() + range);
}

std::vector<std::string> panel_save_tf(const Preview& preview, PanelState& state) {
    if (state.tf_path.empty()) state.tf_path = preview.out + "/" + preview.step + ".tf";
    const ValueMap map = preview.volume ? preview.volume->map : ValueMap{};
    const std::string text = transfer_function_text(
        state.tf, map, state.tf_path + ": made in the window's editor (" + preview.step + ")");
    write_output_file(state.tf_path, [&](std::FILE* file) {
        return std::fwrite(text.data(), 1, text.size(), file) == text.size();
    });
    state.tf_edited = true;
    std::vector<std::string> words = without_flag(preview.words, "--skin-opacity", true);
    words = without_flag(words, "--tf", true);
    words.push_back("--tf");
    words.push_back(state.tf_path);
    return words;
}

// --- Script events -------------------------------------------------------------------------

bool is_panel_event(const std::string& event) {
    return event.rfind("set:", 0) == 0 || event.rfind("tf:", 0) == 0;
}

void panel_script_event(const Preview& preview, PanelState& state, const std::string& event,
                        PanelActions* actions) {
    if (event.rfind("set:", 0) == 0) {
        const size_t equals = event.find('=');
        if (equals == std::string::npos || equals == 4) {
            throw InputError("--window-script: expected set:NAME=VALUE, got '" + event + "'");
        }
        const std::string name = flag_name(event.substr(4, equals - 4));
        const std::string value = event.substr(equals + 1);
        actions->words = panel_set_flag(preview, name, value);
        actions->set = true;
        actions->changed = name + "=" + value;
        return;
    }
    if (!preview.transfer_function) throw InputError("tf: this step has no transfer function");
    state.tf = *preview.transfer_function;
    const std::string body = event.substr(3);
    if (body == "add") {
        const int low = preview.volume ? preview.volume->min_value : lowest_ct_value;
        const int high = preview.volume ? preview.volume->max_value + 1 : ct_value_end;
        state.selected = tf_add_range(state.tf, low, high, state.selected);
    } else if (body.rfind("remove:", 0) == 0) {
        tf_remove_range(state.tf, parse_int("tf:remove", body.substr(7), 0, INT_MAX));
    } else if (body.rfind("path=", 0) == 0) {
        state.tf_path = body.substr(5);
    } else {
        // tf:N:FIELD=VALUE
        const size_t colon = body.find(':'), equals = body.find('=');
        if (colon == std::string::npos || equals == std::string::npos || equals < colon) {
            throw InputError("--window-script: expected tf:N:FIELD=VALUE, tf:add, tf:remove:N "
                             "or tf:path=FILE, got '" + event + "'");
        }
        const int range = parse_int("tf", body.substr(0, colon), 0, INT_MAX);
        const std::string field = body.substr(colon + 1, equals - colon - 1);
        const std::string value = body.substr(equals + 1);
        if (field == "from") {
            tf_set_from(state.tf, range,
                        parse_int("tf:from", value, lowest_ct_value, ct_value_end));
        } else if (field == "to") {
            tf_set_to(state.tf, range, parse_int("tf:to", value, lowest_ct_value, ct_value_end));
        } else if (field == "opacity") {
            tf_set_opacity(state.tf, range, parse_double("tf:opacity", value, 0, 1));
        } else if (field == "colour" && value.size() == 6 &&
                   value.find_first_not_of("0123456789abcdefABCDEF") == std::string::npos) {
            const long rgb = std::strtol(value.c_str(), nullptr, 16);
            tf_set_colour(state.tf, range, ((rgb >> 16) & 255) / 255.0f,
                          ((rgb >> 8) & 255) / 255.0f, (rgb & 255) / 255.0f);
        } else {
            throw InputError("--window-script: tf fields are from, to, opacity, colour=RRGGBB; "
                             "got '" + event + "'");
        }
        state.selected = range;
    }
    actions->words = panel_save_tf(preview, state);
    actions->set = true;
    actions->changed = "--tf=" + state.tf_path;
}

// --- Drawing -------------------------------------------------------------------------------

namespace {

// Records the last widget's rectangle under `name` (tests find the widgets by it).
void remember_rect(PanelState& state, const std::string& name) {
    const ImVec2 low = ImGui::GetItemRectMin(), high = ImGui::GetItemRectMax();
    state.rects.push_back({name, {int(low.x), int(low.y), int(high.x - low.x),
                                  int(high.y - low.y)}});
}

// A widget changed `flag` to `value`: while it is still held, a coarse rerun.
void widget_set(const Preview& preview, const std::string& flag, const std::string& value,
                bool held, PanelActions* actions) {
    try {
        actions->words = panel_set_flag(preview, flag, value);
        actions->set = true;
        actions->coarse = held;
        actions->changed = flag + "=" + value;
    } catch (const InputError& error) {
        actions->note = error.what();
    }
}

void flag_widget(const Preview& preview, PanelState& state, size_t index,
                 PanelActions* actions) {
    const FlagSpec& flag = preview.flags[index];
    const std::string label = flag.name.substr(2);
    ImGui::PushID(flag.name.c_str());
    ImGui::SetNextItemWidth(-130);
    const char* label_text = label.c_str();
    switch (flag.kind) {
        case FlagKind::integer: {
            if (flag.file_units && preview.volume && !preview.volume->map.identity()) {
                // A float or scaled volume: the value in the file's units, not whole.
                double value = std::atof(flag.value.c_str());
                const double low = preview.volume->map.to_file(preview.volume->min_value);
                const double high = preview.volume->map.to_file(preview.volume->max_value);
                const bool changed = ImGui::SliderScalar(label_text, ImGuiDataType_Double,
                                                         &value, &low, &high, "%.4g");
                const std::string text = real_text(value);
                if (changed) widget_set(preview, flag.name, text, ImGui::IsItemActive(), actions);
                if (ImGui::IsItemDeactivatedAfterEdit()) {
                    widget_set(preview, flag.name, text, false, actions);
                }
                break;
            }
            int value = std::atoi(flag.value.c_str());
            int low = int(flag.min), high = int(flag.max);
            if (flag.file_units && preview.volume) {  // the volume's own values
                low = int(std::floor(preview.volume->map.to_file(preview.volume->min_value)));
                high = int(std::ceil(preview.volume->map.to_file(preview.volume->max_value)));
            }
            bool changed;
            if (flag.file_units || double(high) - low <= drag_steps) {
                changed = ImGui::SliderInt(label_text, &value, low, high);
            } else {
                const float speed = float((double(high) - low) / drag_steps);
                changed = ImGui::DragInt(label_text, &value, speed, low, high);
            }
            const std::string text = std::to_string(value);
            if (changed) widget_set(preview, flag.name, text, ImGui::IsItemActive(), actions);
            if (ImGui::IsItemDeactivatedAfterEdit()) {
                widget_set(preview, flag.name, text, false, actions);
            }
            break;
        }
        case FlagKind::real: {
            double value = std::atof(flag.value.c_str());
            const double low = flag.min, high = flag.max;
            ImGuiSliderFlags flags = ImGuiSliderFlags_AlwaysClamp;
            if (low > 0 && high / low >= 100) flags |= ImGuiSliderFlags_Logarithmic;
            // A default outside the range means "not set" (--skin-opacity -1: as the file).
            const char* format = value < low || value > high ? "(not set)" : "%.4g";
            const bool changed = ImGui::SliderScalar(label_text, ImGuiDataType_Double, &value,
                                                     &low, &high, format, flags);
            const std::string text = real_text(value);
            if (changed) widget_set(preview, flag.name, text, ImGui::IsItemActive(), actions);
            if (ImGui::IsItemDeactivatedAfterEdit()) {
                widget_set(preview, flag.name, text, false, actions);
            }
            break;
        }
        case FlagKind::choice: {
            if (ImGui::BeginCombo(label_text, flag.value.c_str())) {
                for (const std::string& choice : flag.choices) {
                    if (ImGui::Selectable(choice.c_str(), choice == flag.value) &&
                        choice != flag.value) {
                        widget_set(preview, flag.name, choice, false, actions);
                    }
                }
                ImGui::EndCombo();
            }
            break;
        }
        case FlagKind::on_off: {
            bool on = !flag.value.empty();
            if (ImGui::Checkbox(label_text, &on)) {
                widget_set(preview, flag.name, on ? "1" : "0", false, actions);
            }
            break;
        }
        case FlagKind::text: {
            if (state.text_fields.size() < preview.flags.size()) {
                state.text_fields.resize(preview.flags.size());
            }
            if (state.text_typing.size() < preview.flags.size()) {
                state.text_typing.resize(preview.flags.size());
            }
            std::string& field = state.text_fields[index];
            if (!state.text_typing[index]) field = flag.value;  // not being typed in
            if (ImGui::InputText(label_text, &field, ImGuiInputTextFlags_EnterReturnsTrue)) {
                widget_set(preview, flag.name, field, false, actions);
            }
            state.text_typing[index] = ImGui::IsItemActive();
            break;
        }
    }
    remember_rect(state, flag.name);
    if (ImGui::IsItemHovered() && !flag.help.empty()) ImGui::SetTooltip("%s", flag.help.c_str());
    ImGui::PopID();
}

// An edit of the editor's table: saved, and the step run again with --tf naming the file.
void tf_edited(const Preview& preview, PanelState& state, bool held, PanelActions* actions) {
    try {
        actions->words = panel_save_tf(preview, state);
        actions->set = true;
        actions->coarse = held;
        actions->changed = "--tf=" + state.tf_path;
    } catch (const InputError& error) {
        actions->note = error.what();
    }
}

ImU32 colour_of(const Rgba& colour, float alpha) {
    return IM_COL32(int(colour.r * 255), int(colour.g * 255), int(colour.b * 255),
                    int(alpha * 255));
}

// The histogram (log scale) with the table's ranges over it; the ends of the ranges drag.
void tf_editor(const Preview& preview, PanelState& state, PanelActions* actions) {
    const Volume& volume = *preview.volume;
    update_histogram(volume, state);
    const float width = ImGui::GetContentRegionAvail().x;
    const ImVec2 origin = ImGui::GetCursorScreenPos();
    ImGui::InvisibleButton("histogram", ImVec2(width, histogram_height));
    remember_rect(state, "histogram");
    const bool active = ImGui::IsItemActive();
    ImDrawList* draw = ImGui::GetWindowDrawList();
    const double low = state.lowest;
    const double high = state.lowest + double(state.bin_width) * histogram_bins;
    auto x_of = [&](double value) {
        return origin.x + float(std::clamp((value - low) / (high - low), 0.0, 1.0)) * width;
    };
    auto value_of = [&](float x) {
        return int(std::lround(low + (x - origin.x) / width * (high - low)));
    };
    const float bottom = origin.y + histogram_height;
    draw->AddRectFilled(origin, ImVec2(origin.x + width, bottom), IM_COL32(24, 24, 28, 255));
    // Bars: log(1 + count) against the largest, so the few bone voxels still show.
    const double largest = std::log1p(*std::max_element(state.counts.begin(), state.counts.end()));
    std::vector<ImVec2> outline;
    for (int bin = 0; bin < histogram_bins; ++bin) {
        const float height = largest > 0 ? float(std::log1p(state.counts[bin]) / largest) : 0;
        const float left = x_of(low + double(bin) * state.bin_width);
        const float right = x_of(low + double(bin + 1) * state.bin_width);
        const float top = bottom - height * histogram_height;
        draw->AddRectFilled(ImVec2(left, top), ImVec2(std::max(right, left + 1), bottom),
                            IM_COL32(90, 90, 100, 255));
        outline.push_back(ImVec2(left, top));
        outline.push_back(ImVec2(right, top));
    }
    // The ranges: their colour, as high as their opacity; the selected one outlined.
    for (size_t n = 0; n < state.tf.ranges.size(); ++n) {
        const TfRange& range = state.tf.ranges[n];
        const float left = x_of(range.from), right = x_of(range.to);
        if (right <= left) continue;
        const float top_start = bottom - range.start.a * histogram_height;
        const float top_end = bottom - range.end.a * histogram_height;
        draw->AddQuadFilled(ImVec2(left, bottom), ImVec2(left, top_start),
                            ImVec2(right, top_end), ImVec2(right, bottom),
                            colour_of(range.start, 0.4f));
        const ImU32 edge = int(n) == state.selected ? IM_COL32(255, 255, 0, 255)
                                                     : IM_COL32(255, 255, 255, 200);
        draw->AddLine(ImVec2(left, origin.y), ImVec2(left, bottom), edge, 2);
        draw->AddLine(ImVec2(right, origin.y), ImVec2(right, bottom), edge, 2);
    }
    // The histogram's outline over the ranges' colours.
    draw->AddPolyline(outline.data(), int(outline.size()), IM_COL32(80, 200, 255, 255), 0, 1.5f);
    // Grab the end nearest the mouse (within grab_pixels); a press elsewhere selects a range.
    const float mouse_x = ImGui::GetIO().MousePos.x;
    if (ImGui::IsItemActivated()) {
        state.dragging_end = -1;
        float nearest = grab_pixels;
        for (size_t n = 0; n < state.tf.ranges.size(); ++n) {
            for (int end = 0; end < 2; ++end) {
                const float x = x_of(end ? state.tf.ranges[n].to : state.tf.ranges[n].from);
                if (std::fabs(x - mouse_x) <= nearest) {
                    nearest = std::fabs(x - mouse_x);
                    state.dragging_end = int(2 * n) + end;
                }
            }
            if (state.dragging_end < 0 && x_of(state.tf.ranges[n].from) <= mouse_x &&
                mouse_x < x_of(state.tf.ranges[n].to)) {
                state.selected = int(n);
            }
        }
        if (state.dragging_end >= 0) {
            // Shared or free is decided when the end is grabbed: a free end dragged onto its
            // neighbour stops there and does not push it along.
            const int n = state.dragging_end / 2;
            const auto& ranges = state.tf.ranges;
            state.selected = n;
            const bool upper = state.dragging_end % 2;
            state.drag_shared = upper ? n + 1 < int(ranges.size()) &&
                                            ranges[n + 1].from == ranges[n].to
                                      : n > 0 && ranges[n - 1].to == ranges[n].from;
        }
    }
    if (active && state.dragging_end >= 0 && ImGui::GetIO().MouseDelta.x != 0) {
        const int range = state.dragging_end / 2;
        if (state.dragging_end % 2) {
            tf_set_to(state.tf, range, value_of(mouse_x), state.drag_shared);
        } else {
            tf_set_from(state.tf, range, value_of(mouse_x), state.drag_shared);
        }
        tf_edited(preview, state, true, actions);
    }
    if (ImGui::IsItemDeactivated() && state.dragging_end >= 0) {
        state.dragging_end = -1;
        tf_edited(preview, state, false, actions);
    }
    ImGui::TextDisabled("values %d .. %d, counts on a log scale", int(volume.min_value),
                        int(volume.max_value));

    // The ranges as a list; the selected one's numbers, colour and opacity below.
    for (size_t n = 0; n < state.tf.ranges.size(); ++n) {
        const TfRange& range = state.tf.ranges[n];
        char text[96];
        std::snprintf(text, sizeof text, "%zu: [%d, %d) %s", n, range.from, range.to,
                      range.label.c_str());
        ImGui::PushID(int(n));
        ImGui::ColorButton("##swatch", ImVec4(range.start.r, range.start.g, range.start.b, 1),
                           ImGuiColorEditFlags_NoTooltip, ImVec2(12, 12));
        ImGui::SameLine();
        if (ImGui::Selectable(text, int(n) == state.selected)) state.selected = int(n);
        ImGui::PopID();
    }
    if (!state.tf.ranges.empty()) {
        state.selected = std::clamp(state.selected, 0, int(state.tf.ranges.size()) - 1);
        TfRange& range = state.tf.ranges[state.selected];
        int ends[2] = {range.from, range.to};
        ImGui::SetNextItemWidth(-130);
        if (ImGui::InputInt2("from, to", ends)) {}
        remember_rect(state, "tf-ends");
        if (ImGui::IsItemDeactivatedAfterEdit()) {
            tf_set_from(state.tf, state.selected, ends[0]);
            tf_set_to(state.tf, state.selected, ends[1]);
            tf_edited(preview, state, false, actions);
        }
        float colour[3] = {range.start.r, range.start.g, range.start.b};
        ImGui::SetNextItemWidth(-130);
        if (ImGui::ColorEdit3("colour", colour)) {
            tf_set_colour(state.tf, state.selected, colour[0], colour[1], colour[2]);
            tf_edited(preview, state, ImGui::IsItemActive(), actions);
        }
        remember_rect(state, "tf-colour");
        float opacity = range.start.a;
        ImGui::SetNextItemWidth(-130);
        const bool moved = ImGui::SliderFloat("opacity", &opacity, 0, 1, "%.3f");
        remember_rect(state, "tf-opacity");
        if (moved) {
            tf_set_opacity(state.tf, state.selected, opacity);
            tf_edited(preview, state, ImGui::IsItemActive(), actions);
        }
        if (ImGui::IsItemDeactivatedAfterEdit()) tf_edited(preview, state, false, actions);
    }
    if (ImGui::Button("Add range")) {
        state.selected = tf_add_range(state.tf, volume.min_value, volume.max_value + 1,
                                      state.selected);
        tf_edited(preview, state, false, actions);
    }
    ImGui::SameLine();
    if (ImGui::Button("Remove") && !state.tf.ranges.empty()) {
        tf_remove_range(state.tf, state.selected);
        tf_edited(preview, state, false, actions);
    }
    if (state.tf_path.empty()) state.tf_path = preview.out + "/" + preview.step + ".tf";
    ImGui::SetNextItemWidth(-130);
    ImGui::InputText("saved to", &state.tf_path);
    ImGui::SameLine();
    if (ImGui::Button("Save")) tf_edited(preview, state, false, actions);
}

}  // namespace

void draw_panel(const Preview& preview, PanelState& state, int height, PanelActions* actions) {
    state.rects.clear();
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(float(panel_width), float(height)));
    ImGui::Begin("Controls", nullptr,
                 ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize |
                     ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_NoSavedSettings |
                     ImGuiWindowFlags_NoTitleBar);
    ImGui::TextUnformatted(preview.step.c_str());
    ImGui::TextWrapped("%s", state.status.c_str());
    if (!state.note.empty()) ImGui::TextColored(ImVec4(1, 0.5f, 0.4f, 1), "%s", state.note.c_str());
    // The command line that renders this picture, ready to copy.
    const std::string command = panel_command(preview);
    ImGui::Separator();
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(0.6f, 0.85f, 1.0f, 1));
    ImGui::TextWrapped("%s", command.c_str());
    ImGui::PopStyleColor();
    if (ImGui::Button("Copy command line")) SDL_SetClipboardText(command.c_str());
    remember_rect(state, "copy");
    ImGui::Separator();

    if (preview.views.size() > 1) {
        for (size_t n = 0; n < preview.views.size(); ++n) {
            if (n > 0) ImGui::SameLine();
            if (ImGui::RadioButton(preview.views[n].name.c_str(), int(n) == preview.current)) {
                actions->view = int(n);
            }
        }
    }
    const std::vector<std::string> presets = preset_names();
    if (!presets.empty()) {
        ImGui::SetNextItemWidth(-130);
        const std::string shown = switched_preset().empty() ? "(as typed)" : switched_preset();
        if (ImGui::BeginCombo("preset", shown.c_str())) {
            for (const std::string& name : presets) {
                if (ImGui::Selectable(name.c_str(), name == switched_preset())) {
                    actions->preset = name;
                }
            }
            ImGui::EndCombo();
        }
    }

    if (ImGui::CollapsingHeader("Settings", ImGuiTreeNodeFlags_DefaultOpen)) {
        for (size_t n = 0; n < preview.flags.size(); ++n) {
            // The editor below is --tf's widget.
            if (preview.flags[n].name == "--tf" && preview.transfer_function) continue;
            flag_widget(preview, state, n, actions);
        }
    }
    if (preview.transfer_function && preview.volume) {
        if (state.dragging_end < 0) state.tf = *preview.transfer_function;  // the step's own
        if (ImGui::CollapsingHeader("Transfer function", ImGuiTreeNodeFlags_DefaultOpen)) {
            tf_editor(preview, state, actions);
        }
    }
    ImGui::End();
}

}  // namespace ctlab
