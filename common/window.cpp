// window.cpp: the SDL2 preview window (see window.h for the keys).
//
// Each image pixel is drawn as a block of scale_x by scale_y window pixels (whole numbers), so
// the head keeps its aspect (front and side rows are 2 units tall in CThead) and a click maps
// back to exactly one image pixel. Everything runs on the main thread, driven by SDL_WaitEvent.
#include "window.h"
#include <SDL.h>
#include <imgui.h>
#include <backends/imgui_impl_sdl.h>
#include <arpa/inet.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <sstream>
#include <memory>
#include <string>
#include <vector>
#include "error.h"
#include "image.h"
#include "panel.h"
#include "panel_draw.h"
#include "render.h"

namespace ctlab {

namespace {

constexpr int max_window_width = 1024;  // window pixels: the image's zoom is chosen to fit in
constexpr int max_window_height = 800;  // these (and in the display, beside the panels)
constexpr int decoration_allowance = 32;  // window pixels of the display kept for a title bar
constexpr int min_panel_height = 640;     // the control panel's height when the display allows
constexpr int min_image_room = 240;       // window pixels the image keeps beside a ray panel
constexpr double min_ray_scale = 0.25;    // the ray picture is never drawn smaller than this
constexpr Uint32 frame_ms = 16;           // the panel's frames while it is in use
constexpr int min_window_width = 240;   // window pixels: tiny images sit centred in this
constexpr int min_window_height = 120;
constexpr int max_zoom = 64;            // a 1 x 1 volume should not ask for a 800 x 800 block
constexpr int display_probe_ms = 2000;  // an X server that has not answered by then never will
// Part 2's orbit (Preview::orbit): a drag turns the camera, the wheel zooms it.
constexpr int drag_start_pixels = 3;      // window pixels a press must move to become a drag
constexpr double degrees_per_pixel = 0.5;  // of azimuth or elevation per window pixel dragged
constexpr double zoom_per_notch = 1.1;     // the wheel's zoom factor per notch
constexpr double preview_frame_ms = 40;    // while turning, aim at 25 frames a second
constexpr int max_preview_factor = 8;      // a preview has at least 1 in 8 x 8 of the pixels
constexpr Uint32 refine_after_ms = 150;    // the mouse still this long: render at full size

// Where the image sits in the window: pixel (x, y) covers window pixels
// [left + x*scale_x, left + (x+1)*scale_x) by [top + y*scale_y, top + (y+1)*scale_y).
struct Layout {
    int scale_x = 1, scale_y = 1;  // window pixels per image pixel, across and down
    int left = 0, top = 0;         // window position of the image's top-left corner

    int drawn_width(const Image& image) const { return image.width * scale_x; }
    int drawn_height(const Image& image) const { return image.height * scale_y; }
};

// The largest whole zoom at which the view fits max_window_*, with rows and columns stretched
// by their physical size (pixel_width, pixel_height) relative to the smaller of the two.
Layout fit_view(const View& view, int max_width, int max_height) {
    const bool sizes_valid = view.pixel_width > 0 && view.pixel_height > 0;  // false for NaN too
    const double smaller = sizes_valid ? std::min(view.pixel_width, view.pixel_height) : 1.0;
    const double aspect_x = sizes_valid ? view.pixel_width / smaller : 1.0;  // >= 1
    const double aspect_y = sizes_valid ? view.pixel_height / smaller : 1.0;
    const int width = std::max(1, view.width), height = std::max(1, view.height);
    const int limit_x = std::max(1, max_width / width);  // largest scale that fits
    const int limit_y = std::max(1, max_height / height);

    auto layout_at = [&](int zoom) {
        Layout layout;
        layout.scale_x = std::max(1, static_cast<int>(std::lround(zoom * aspect_x)));
        layout.scale_y = std::max(1, static_cast<int>(std::lround(zoom * aspect_y)));
        return layout;
    };
    int zoom = 1;
    while (zoom < max_zoom) {
        const Layout next = layout_at(zoom + 1);
        if (next.scale_x > limit_x || next.scale_y > limit_y) break;
        ++zoom;
    }
    Layout layout = layout_at(zoom);
    // A very uneven spacing may not fit even at zoom 1: give up some aspect, not the screen.
    layout.scale_x = std::min(layout.scale_x, limit_x);
    layout.scale_y = std::min(layout.scale_y, limit_y);
    return layout;
}


// --- Is anyone there? ---------------------------------------------------------------------
// SDL_Init opens the X display with Xlib, which waits for the server's first reply without a
// time limit: a server (or a stale ssh tunnel) that accepts the connection and never answers
// would hang the step after its PNGs. So first a connection of our own, abandoned after
// display_probe_ms: the 12-byte X11 setup request, and any reply at all (even "authorization
// required") proves the server alive.

enum class Probe { answered, silent, unknown };  // unknown: let SDL find out

// A connected socket to the X server DISPLAY names, or -1 (not a form we know: SDL decides).
// DISPLAY is [host]:number[.screen]; no host (or "unix") is the local socket.
int connect_display(const std::string& display, int timeout_ms) {
    const size_t colon = display.rfind(':');
    if (colon == std::string::npos || display.find('/') != std::string::npos) return -1;
    const std::string host = display.substr(0, colon);
    const int number = std::atoi(display.c_str() + colon + 1);
    if (number < 0 || number > 59535) return -1;
    int fd = -1;
    if (host.empty() || host == "unix") {
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0) return -1;
        sockaddr_un address {};
        address.sun_family = AF_UNIX;
        const std::string path = "/tmp/.X11-unix/X" + std::to_string(number);
        // Linux first tries the abstract name (a leading NUL), as Xlib does, then the file.
        std::memcpy(address.sun_path + 1, path.c_str(), path.size());
        const socklen_t abstract_size =
            socklen_t(offsetof(sockaddr_un, sun_path) + 1 + path.size());
        if (connect(fd, reinterpret_cast<sockaddr*>(&address), abstract_size) == 0) return fd;
        std::memset(address.sun_path, 0, sizeof address.sun_path);
        std::memcpy(address.sun_path, path.c_str(), path.size());
        if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0) return fd;
        close(fd);
        return -1;
    }
    addrinfo hints {}, *found = nullptr;
    hints.ai_socktype = SOCK_STREAM;
    const std::string port = std::to_string(6000 + number);
    if (getaddrinfo(host.c_str(), port.c_str(), &hints, &found) != 0) return -1;
    for (addrinfo* each = found; each && fd < 0; each = each->ai_next) {
        fd = socket(each->ai_family, each->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK,
                    each->ai_protocol);
        if (fd < 0) continue;
        if (connect(fd, each->ai_addr, each->ai_addrlen) == 0) break;
        pollfd wait = {fd, POLLOUT, 0};
        int error = 0;
        socklen_t size = sizeof error;
        if (errno == EINPROGRESS && poll(&wait, 1, timeout_ms) == 1 &&
            getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &size) == 0 && error == 0) {
            break;
        }
        close(fd);
        fd = -1;
    }
    freeaddrinfo(found);
    return fd;
}

Probe probe_display(const std::string& display) {
    const int fd = connect_display(display, display_probe_ms);
    if (fd < 0) return Probe::unknown;  // nobody listening: SDL_Init fails at once and says so
    // Byte order 'l' (little-endian), protocol 11.0, no authorization name or data.
    const unsigned char setup[12] = {'l', 0, 11, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    Probe result = Probe::silent;
    if (send(fd, setup, sizeof setup, MSG_NOSIGNAL) == ssize_t(sizeof setup)) {
        pollfd wait = {fd, POLLIN, 0};
        if (poll(&wait, 1, display_probe_ms) == 1) result = Probe::answered;
    } else {
        result = Probe::unknown;
    }
    close(fd);
    return result;
}

// --- The X server going away --------------------------------------------------------------
// Xlib's default handler prints its own lines ("XIO: fatal IO error 11 ...") and exits. Ours
// says it in ctlab's words. libX11 is loaded by SDL, so its handler is set through dlsym.
char lost_display_message[512];

int on_lost_display(void*) {
    const ssize_t ignored = write(STDERR_FILENO, lost_display_message,
                                  std::strlen(lost_display_message));
    (void)ignored;
    _exit(1);
}

void handle_lost_display(const std::string& step, const char* display) {
    std::snprintf(lost_display_message, sizeof lost_display_message,
                  "%s: error: lost the X display '%s' (the X server closed the connection); "
                  "the PNGs are written\n",
                  step.c_str(), printable(display ? display : "").c_str());
    void* x11 = dlopen("libX11.so.6", RTLD_LAZY | RTLD_NOLOAD);  // only if SDL loaded it
    if (!x11) return;
    using Handler = int (*)(void*);
    using SetHandler = Handler (*)(Handler);
    if (auto set = reinterpret_cast<SetHandler>(dlsym(x11, "XSetIOErrorHandler"))) {
        set(on_lost_display);
    }
    dlclose(x11);  // SDL still holds it: the library stays
}

// One injected event of --window-script, already turned into what SDL would deliver.
struct ScriptEvent {
    std::string text;     // the token as written, for error messages
    bool is_click = false;
    SDL_Keycode key = SDLK_UNKNOWN;
    SDL_Scancode scancode = SDL_SCANCODE_UNKNOWN;
    int x = 0, y = 0;     // click: image column and row
    // The orbit's mouse (part 2): "press", "move", "release" at image pixel x, y; "wheel"
    // by amount notches (up: closer); "wait" amount ms before the next event; "shot": the
    // window's pixels to a PNG (tests). "": none.
    std::string mouse;
    int amount = 0;
};

struct KeyName {
    const char* name;     // as written in the script and printed as "window: key=NAME"
    SDL_Keycode key;
    SDL_Scancode scancode;
};

const KeyName script_keys[] = {
    {"1", SDLK_1, SDL_SCANCODE_1},           {"2", SDLK_2, SDL_SCANCODE_2},
    {"3", SDLK_3, SDL_SCANCODE_3},           {"Up", SDLK_UP, SDL_SCANCODE_UP},
    {"Down", SDLK_DOWN, SDL_SCANCODE_DOWN},  {"plus", SDLK_KP_PLUS, SDL_SCANCODE_KP_PLUS},
    {"minus", SDLK_MINUS, SDL_SCANCODE_MINUS}, {"s", SDLK_s, SDL_SCANCODE_S},
    {"q", SDLK_q, SDL_SCANCODE_Q},           {"Escape", SDLK_ESCAPE, SDL_SCANCODE_ESCAPE},
    {"p", SDLK_p, SDL_SCANCODE_P},
};

// "key:2,key:Up,click:40:30,save,quit" -> events. Throws InputError on anything else.
std::vector<ScriptEvent> parse_script(const std::string& script) {
    std::vector<ScriptEvent> events;
    if (script.empty()) return events;
    const std::string expected =
        "--window-script: expected comma-separated key:1|2|3|Up|Down|plus|minus|s|q|Escape|p, "
        "click:X:Y, press:X:Y, move:X:Y, release:X:Y, wheel:N, wait:MS, save, shot, quit, "
        "set:NAME=VALUE, tf:..., or widgets, got '";
    size_t start = 0;
    while (start <= script.size()) {
        size_t comma = script.find(',', start);
        if (comma == std::string::npos) comma = script.size();
        ScriptEvent event;
        event.text = script.substr(start, comma - start);
        start = comma + 1;

        std::string key_name;
        if (event.text == "shot" || event.text == "widgets") {
            event.mouse = event.text;  // handled by the loop, like wait: no SDL event
            events.push_back(event);
            continue;
        }
        if (is_panel_event(event.text)) {  // the control panel's: set:NAME=VALUE, tf:...
            event.mouse = "panel";
            events.push_back(event);
            continue;
        }
        if (event.text == "save") key_name = "s";
        else if (event.text == "quit") key_name = "q";
        else if (event.text.rfind("key:", 0) == 0) key_name = event.text.substr(4);

        const size_t verb_end = event.text.find(':');
        const std::string verb = event.text.substr(0, verb_end);
        if (verb_end != std::string::npos &&
            (verb == "press" || verb == "move" || verb == "release")) {
            const std::string place = event.text.substr(verb_end + 1);
            const size_t second = place.find(':');
            if (second == std::string::npos) throw InputError(expected + event.text + "'");
            const int limit = 1 << 20;  // pixels: far beyond any image
            event.mouse = verb;
            event.x = parse_int("--window-script " + verb + " X", place.substr(0, second), 0,
                                limit);
            event.y = parse_int("--window-script " + verb + " Y", place.substr(second + 1), 0,
                                limit);
        } else if (verb_end != std::string::npos && (verb == "wheel" || verb == "wait")) {
            const int limit = verb == "wheel" ? 100 : 10000;  // notches; ms
            event.mouse = verb;
            event.amount = parse_int("--window-script " + verb, event.text.substr(verb_end + 1),
                                     verb == "wheel" ? -limit : 0, limit);
        } else if (event.text.rfind("click:", 0) == 0) {
            const std::string place = event.text.substr(6);
            const size_t colon = place.find(':');
            if (colon == std::string::npos) throw InputError(expected + event.text + "'");
            const int limit = 1 << 20;  // pixels: far beyond any image
            event.is_click = true;
            event.x = parse_int("--window-script click X", place.substr(0, colon), 0, limit);
            event.y = parse_int("--window-script click Y", place.substr(colon + 1), 0, limit);
        } else {
            for (const KeyName& known : script_keys) {
                if (key_name == known.name) {
                    event.key = known.key;
                    event.scancode = known.scancode;
                }
            }
            if (event.key == SDLK_UNKNOWN) throw InputError(expected + event.text + "'");
        }
        events.push_back(event);
    }
    return events;
}

// What a key does in the preview (several keys share a meaning).
enum class Action { none, view_top, view_front, view_side, knob_up, knob_down, save, quit,
                    next_preset };

Action action_of(SDL_Keycode key) {
    switch (key) {
        case SDLK_1: case SDLK_KP_1: return Action::view_top;
        case SDLK_2: case SDLK_KP_2: return Action::view_front;
        case SDLK_3: case SDLK_KP_3: return Action::view_side;
        // SDLK_EQUALS: the "+" key pressed without shift on most layouts.
        case SDLK_UP: case SDLK_PLUS: case SDLK_EQUALS: case SDLK_KP_PLUS: return Action::knob_up;
        case SDLK_DOWN: case SDLK_MINUS: case SDLK_KP_MINUS: return Action::knob_down;
        case SDLK_s: return Action::save;
        case SDLK_q: case SDLK_ESCAPE: return Action::quit;
        case SDLK_p: return Action::next_preset;
        default: return Action::none;
    }
}

// The name a key prints as: the script's name for it, so a log reads like the script.
std::string key_name(SDL_Keycode key) {
    switch (key) {
        case SDLK_KP_1: return "1";
        case SDLK_KP_2: return "2";
        case SDLK_KP_3: return "3";
        case SDLK_PLUS: case SDLK_EQUALS: case SDLK_KP_PLUS: return "plus";
        case SDLK_MINUS: case SDLK_KP_MINUS: return "minus";
        default: break;
    }
    for (const KeyName& known : script_keys) {
        if (known.key == key) return known.name;
    }
    return SDL_GetKeyName(key);
}

// Owns the SDL objects, so they are released on every way out (including exceptions). It
// outlives one show_preview() while the panel runs the step again (request_rerun): the
// window stays open, with what it showed.
struct Session {
    SDL_Window* window = nullptr;
    SDL_Renderer* renderer = nullptr;
    SDL_Texture* texture = nullptr;
    SDL_Texture* ray_texture = nullptr;  // the ray panel, once a click opened it
    int texture_width = 0, texture_height = 0;
    int max_texture_width = max_window_width, max_texture_height = max_window_height;  // pixels
    bool imgui = false;                  // ImGui's context and SDL backend are up
    std::unique_ptr<PanelDraw> panel_draw;
    PanelState panel;
    // What the window showed, kept across the panel's reruns.
    std::string step;
    int view = -1;                       // index into Preview::views; -1: as the run says
    bool has_ray = false;
    int ray_x = 0, ray_y = 0;
    double full_ms = 0;
    int shots = 0;
    bool coarse_next = false;            // the rerun was asked for by a slider still held
    std::string image_line;              // the last "window: image ..." line printed
    std::string command_line;            // the last "window: command ..." line printed

    ~Session() {
        panel_draw.reset();
        if (imgui) {
            ImGui_ImplSDL2_Shutdown();
            ImGui::DestroyContext();
        }
        if (texture) SDL_DestroyTexture(texture);
        if (ray_texture) SDL_DestroyTexture(ray_texture);
        if (renderer) SDL_DestroyRenderer(renderer);
        if (window) SDL_DestroyWindow(window);
        SDL_Quit();
    }
};

// The window between show_preview() calls of the panel's reruns; empty when closed.
std::unique_ptr<Session> open_session;

bool no_window() {
    std::fprintf(stderr, "note: no window (SDL: %s); the PNGs are written\n",
                 printable(SDL_GetError()).c_str());
    return false;
}

// The preview's state between events.
class PreviewWindow {
public:
    // Takes over what the window showed before the panel ran the step again.
    PreviewWindow(Preview& preview, Session& session) : preview_(preview), session_(session) {
        has_ray_ = session.has_ray;
        ray_x_ = session.ray_x;
        ray_y_ = session.ray_y;
        full_ms_ = session.full_ms;
        shots_ = session.shots;
    }

    // ... and hands it on, unless the session was closed first (quit, another preset): then
    // session_ is gone and there is nothing to hand on to (only its address is compared).
    ~PreviewWindow() {
        if (open_session.get() != &session_) return;
        session_.view = preview_.current;
        session_.has_ray = has_ray_;
        session_.ray_x = ray_x_;
        session_.ray_y = ray_y_;
        session_.full_ms = full_ms_;
        session_.shots = shots_;
    }

    const View& view() const { return preview_.views[preview_.current]; }

    // Renders the current view, uploads it and shows it, with the render time in the title.
    void render() {
        const std::string rendering = preview_.step + " | " + view().name + " | rendering...";
        SDL_SetWindowTitle(session_.window, rendering.c_str());
        Timer timer;
        Work work;
        image_ = preview_.render(view(), work);
        const double ms = timer.ms();
        full_ms_ = ms;
        coarse_from_panel_ = false;

        SDL_SetWindowTitle(session_.window, title(ms).c_str());
        session_.panel.status = status_text(work, ms, "");
        upload();
        if (has_ray_) show_ray(ray_x_, ray_y_);  // follows the knob and the view
        draw();
    }

    // The panel's live text: the view, its time, and the summary line's counters.
    std::string status_text(const Work& work, double ms, const std::string& preview) const {
        char text[160];
        std::snprintf(text, sizeof text, "%s %dx%d: %.1f ms%s\n", view().name.c_str(),
                      view().width, view().height, ms, preview.c_str());
        // The summary line's work counters (its settings are the widgets' values).
        std::istringstream words(preview_.summary ? preview_.summary(view(), work, ms) : "");
        std::string word, counters;
        while (words >> word) {
            for (const char* counter : {"samples=", "skipped=", "leapt=", "gradients=",
                                        "terminated=", "hits="}) {
                if (word.rfind(counter, 0) == 0) counters += (counters.empty() ? "" : "  ") + word;
            }
        }
        return text + counters;
    }

    // The first picture after the panel ran the step again: coarse while its slider is
    // held (as the orbit's previews), else at full size.
    void render_first(bool coarse) {
        if (!coarse || full_ms_ <= 0) {
            render();
            return;
        }
        coarse_from_panel_ = true;
        render_coarse();
    }

    // Switches to the view along `axis` (resizing the window to its zoom) and renders it.
    void show_view(ViewAxis axis) {
        for (size_t n = 0; n < preview_.views.size(); ++n) {
            if (preview_.views[n].axis != axis) continue;
            if (static_cast<int>(n) == preview_.current) return;  // already shown
            preview_.current = static_cast<int>(n);
            fit_window();
            render();
            return;
        }
        std::printf("window: this run has no such view\n");
    }

    // Sizes the window for the current view's zoom (before its first render), within the
    // display it is on: the control panel left, the image, the ray panel right when open. A
    // view wider or taller than its room (or the texture limit) is shown shrunk by whole
    // factors: every shrink_x-th column and shrink_y-th row. A ray picture that does not fit
    // beside the smallest image is drawn scaled down.
    void fit_window() {
        SDL_Rect display = {0, 0, max_window_width + panel_width, max_window_height};
        const int index = std::max(0, SDL_GetWindowDisplayIndex(session_.window));
        if (SDL_GetDisplayUsableBounds(index, &display) != 0 || display.w <= 0) {
            display = {0, 0, max_window_width + panel_width, max_window_height};
        }
        const int room_x = std::max(1, display.w - panel_width);
        const int room_y = std::max(1, display.h - decoration_allowance);
        ray_scale_ = 1;
        if (has_ray_ && ray_.width > 0 && ray_.height > 0) {
            ray_scale_ = std::min({1.0, double(room_x - min_image_room) / ray_.width,
                                   double(room_y) / ray_.height});
            ray_scale_ = std::max(ray_scale_, min_ray_scale);
        }
        const int ray_width = has_ray_ ? int(std::lround(ray_.width * ray_scale_)) : 0;
        const int ray_height = has_ray_ ? int(std::lround(ray_.height * ray_scale_)) : 0;

        const View& full = view();
        const int limit_x = std::max(1, std::min({max_window_width, room_x - ray_width,
                                                  session_.max_texture_width}));
        const int limit_y = std::max(1, std::min({max_window_height, room_y,
                                                  session_.max_texture_height}));
        shrink_x_ = std::max(1, (full.width + limit_x - 1) / limit_x);
        shrink_y_ = std::max(1, (full.height + limit_y - 1) / limit_y);
        View shown = full;
        shown.width = (full.width + shrink_x_ - 1) / shrink_x_;
        shown.height = (full.height + shrink_y_ - 1) / shrink_y_;
        shown.pixel_width = full.pixel_width * shrink_x_;
        shown.pixel_height = full.pixel_height * shrink_y_;
        layout_ = fit_view(shown, limit_x, limit_y);
        int width = panel_width + std::max(min_window_width, shown.width * layout_.scale_x) +
                    ray_width;
        int height = std::max({min_window_height, shown.height * layout_.scale_y, ray_height,
                               std::min(min_panel_height, room_y)});
        width = std::min(width, display.w);
        height = std::min(height, room_y);
        SDL_SetWindowSize(session_.window, width, height);
        // Keep the whole window on the display (it grew from where it was).
        int x = 0, y = 0;
        SDL_GetWindowPosition(session_.window, &x, &y);
        const int kept_x = std::clamp(x, display.x, display.x + display.w - width);
        const int kept_y = std::clamp(y, display.y, display.y + std::max(0, room_y - height));
        if (kept_x != x || kept_y != y) SDL_SetWindowPosition(session_.window, kept_x, kept_y);
        std::printf("window: size %dx%d at %d,%d on a %dx%d display\n", width, height, kept_x,
                    kept_y, display.w, display.h);
        std::fflush(stdout);
    }

    // The ray panel for pixel (x, y) of the current view: drawn anew (after a click, a knob
    // change or a view switch), the window widened to hold it. A pixel outside the view
    // closes it.
    void show_ray(int x, int y) {
        if (!preview_.ray_panel) return;
        if (x >= view().width || y >= view().height) {
            has_ray_ = false;
            std::printf("window: ray panel closed (pixel %d,%d is outside the %s view)\n", x, y,
                        view().name.c_str());
            return;
        }
        std::string marks;
        ray_ = preview_.ray_panel(view(), x, y, &marks);
        const bool opening = !has_ray_;
        has_ray_ = true, ray_x_ = x, ray_y_ = y;
        if (session_.ray_texture) SDL_DestroyTexture(session_.ray_texture);
        session_.ray_texture = SDL_CreateTexture(session_.renderer, SDL_PIXELFORMAT_RGB24,
                                                 SDL_TEXTUREACCESS_STATIC, ray_.width,
                                                 ray_.height);
        if (!session_.ray_texture) {
            throw std::runtime_error(std::string("SDL_CreateTexture: ") + SDL_GetError());
        }
        std::vector<unsigned char> bytes(ray_.pixels.size() * 3);
        for (size_t n = 0; n < ray_.pixels.size(); ++n) {
            bytes[3 * n + 0] = to_byte(ray_.pixels[n].r);
            bytes[3 * n + 1] = to_byte(ray_.pixels[n].g);
            bytes[3 * n + 2] = to_byte(ray_.pixels[n].b);
        }
        SDL_UpdateTexture(session_.ray_texture, nullptr, bytes.data(), ray_.width * 3);
        if (opening || ray_.width != ray_width_fitted_ || ray_.height != ray_height_fitted_) {
            ray_width_fitted_ = ray_.width;
            ray_height_fitted_ = ray_.height;
            fit_window();
        }
        std::printf("window: ray panel x=%d y=%d view=%s %dx%d%s%s\n", x, y, view().name.c_str(),
                    ray_.width, ray_.height, marks.empty() ? "" : " ", marks.c_str());
        std::fflush(stdout);
    }

    void change_knob(int steps) {
        if (preview_.knob.name.empty() || !preview_.knob.adjust) return;  // this step has none
        preview_.knob.adjust(view(), steps);
        std::printf("window: %s=%s\n", preview_.knob.name.c_str(),
                    preview_.knob.value ? preview_.knob.value().c_str() : "?");
        std::fflush(stdout);
        if (preview_.knob.value) remember_flag("--" + preview_.knob.name, preview_.knob.value());
        render();
        print_command();
    }

    // --- The orbit (part 2): drag to turn, wheel to zoom, a coarse preview while it moves ---
    bool orbits() const { return preview_.orbit.turn && preview_.orbit.zoom; }

    // The left button down: without an orbit, a click at once. With one, the start of a drag,
    // or a click when the button comes up before the mouse has moved drag_start_pixels.
    void press(int wx, int wy) {
        if (!orbits()) {
            click(wx, wy);
            return;
        }
        refine();  // a click traces the picture as it is now, at full size
        pressed_ = true;
        dragging_ = false;
        press_x_ = last_x_ = wx;
        press_y_ = last_y_ = wy;
    }

    // Dragging right turns the head to the right (the camera to its left: azimuth down);
    // dragging down shows more of the crown (elevation up). Applied by preview().
    void move(int wx, int wy) {
        if (!pressed_) return;
        if (!dragging_ && std::abs(wx - press_x_) + std::abs(wy - press_y_) < drag_start_pixels) {
            return;
        }
        dragging_ = true;
        turn_azimuth_ -= (wx - last_x_) * degrees_per_pixel;
        turn_elevation_ += (wy - last_y_) * degrees_per_pixel;
        last_x_ = wx;
        last_y_ = wy;
        moved_ = true;
    }

    void release() {
        if (!pressed_) return;
        pressed_ = false;
        if (dragging_) {
            dragging_ = false;
            refine();
        } else {
            click(press_x_, press_y_);
        }
    }

    void wheel(int notches) {
        if (!orbits() || notches == 0) return;
        zoom_factor_ *= std::pow(zoom_per_notch, notches);
        moved_ = true;
    }

    // What the mouse did since the last frame, applied to the camera, and a coarse preview
    // of it: 1 in factor x factor pixels, the texture stretched over the full picture.
    void preview() {
        if (!moved_) return;
        apply_orbit();
        render_coarse();
    }

    // A coarse picture of the view: 1 in factor x factor pixels, the texture stretched over
    // the full picture; the full size follows (refine) when the mouse or slider is let go.
    void render_coarse() {
        const int factor = preview_factor();
        View coarse = view();
        coarse.width = (coarse.width + factor - 1) / factor;
        coarse.height = (coarse.height + factor - 1) / factor;
        coarse.pixel_width *= factor;  // the same field, in fewer and larger pixels
        coarse.pixel_height *= factor;
        Timer timer;
        Work work;
        const Image image = preview_.render_preview ? preview_.render_preview(coarse, work)
                                                    : preview_.render(coarse, work);
        const double ms = timer.ms();
        ++previews_;
        preview_width_ = image.width;
        preview_height_ = image.height;
        char text[96];
        std::snprintf(text, sizeof text, " | preview %dx%d | %.1f ms", image.width, image.height,
                      ms);
        const std::string title = preview_.step + " | " + view().name + " | " +
                                  (orbits() ? preview_.orbit.value() + text : text + 3);
        SDL_SetWindowTitle(session_.window, title.c_str());
        session_.panel.status = status_text(work, ms, " (preview " +
                                            std::to_string(image.width) + "x" +
                                            std::to_string(image.height) + ")");
        upload_texture(image);
        draw();
        refine_due_ = true;
        refine_at_ = SDL_GetTicks() + refine_after_ms;
    }

    // After previews: the camera as it is now, at full size (prints its summary line).
    // A move not yet previewed (the release came in the same batch of events) counts too.
    void refine() {
        if (moved_) {
            apply_orbit();
            refine_due_ = true;
        }
        if (!refine_due_) return;
        if (coarse_from_panel_ && ImGui::IsAnyItemActive()) {  // the slider is still held
            refine_at_ = SDL_GetTicks() + refine_after_ms;
            return;
        }
        refine_due_ = false;
        if (!coarse_from_panel_) {
            std::printf("window: orbit %s (%d previews at %dx%d)\n",
                        preview_.orbit.value().c_str(), previews_, preview_width_,
                        preview_height_);
            std::fflush(stdout);
            // The camera's flags follow the mouse, so the command line shows this camera.
            std::istringstream fields(preview_.orbit.value());
            std::string field;
            while (fields >> field) {
                const size_t equals = field.find('=');
                if (equals != std::string::npos) {
                    remember_flag("--" + field.substr(0, equals), field.substr(equals + 1));
                }
            }
        }
        previews_ = 0;
        render();
        if (!coarse_from_panel_) print_command();
    }

    // "window: command ...": the command line the panel shows, when it changed.
    void print_command() {
        const std::string command = panel_command(preview_);
        if (command == session_.command_line) return;
        session_.command_line = command;
        std::printf("window: command %s\n", command.c_str());
        std::fflush(stdout);
    }

    // The step changed a flag's value itself (a key, the orbit): the command line follows.
    void remember_flag(std::string flag, const std::string& value) {
        std::replace(flag.begin(), flag.end(), '_', '-');  // a knob's name: skin_opacity
        for (FlagSpec& spec : preview_.flags) {
            if (spec.name != flag) continue;
            try {
                preview_.words = panel_set_flag(preview_, flag, value);
                spec.value = value;
            } catch (const InputError&) {
                // A value the command line would not take (none today): leave the words.
            }
        }
    }

    // One frame of the control panel: what it asks for is kept for take_actions().
    void panel_frame(int height) {
        ImGui_ImplSDL2_NewFrame();
        // The mouse where SDL's own events put it: ImGui 1.86's backend asks X for the global
        // position, which SDL caches from raw input that some servers (Xvfb with xdotool)
        // never send, so a held slider would not follow the mouse.
        int mouse_x = 0, mouse_y = 0;
        const Uint32 buttons = SDL_GetMouseState(&mouse_x, &mouse_y);
        if (SDL_GetMouseFocus() == session_.window || buttons != 0) {
            ImGui::GetIO().MousePos = ImVec2(float(mouse_x), float(mouse_y));
        }
        ImGui::NewFrame();
        PanelActions actions;
        draw_panel(preview_, session_.panel, height, &actions);
        ImGui::Render();
        if (actions.set || actions.view >= 0 || !actions.preset.empty() || !actions.note.empty()) {
            actions_ = actions;
            has_actions_ = true;
        }
    }

    bool take_actions(PanelActions* actions) {
        if (!has_actions_) return false;
        *actions = actions_;
        has_actions_ = false;
        return true;
    }

    // Milliseconds until refine() is due, the mouse still since the last preview for
    // refine_after_ms (button held or not; a release refines at once); -1: nothing to refine.
    int ms_until_refine() const {
        if (!refine_due_) return -1;
        const Uint32 now = SDL_GetTicks();
        return SDL_TICKS_PASSED(now, refine_at_) ? 0 : int(refine_at_ - now);
    }

    void save() {
        const std::string path = preview_.save_path(view());
        try {
            write_png(image_, path);
            std::printf("saved %s\n", path.c_str());
        } catch (const std::exception& error) {
            std::fprintf(stderr, "note: not saved: %s\n", error.what());  // keep the window
        }
    }

    // A left click at window position (wx, wy): the trace of the pixel under it, if any.
    void click(int wx, int wy) {
        const int dx = wx - layout_.left, dy = wy - layout_.top;
        // Floor division by hand: dx / scale_x rounds -1 up to pixel 0.
        const int shown_x = dx < 0 ? -1 : dx / layout_.scale_x;
        const int shown_y = dy < 0 ? -1 : dy / layout_.scale_y;
        if (shown_x < 0 || shown_y < 0 || shown_x >= shown_.width || shown_y >= shown_.height) {
            std::printf("window: click outside the image\n");
            return;
        }
        const int x = shown_x * shrink_x_, y = shown_y * shrink_y_;  // the pixel shown there
        std::printf("window: click x=%d y=%d\n", x, y);
        std::fflush(stdout);
        if (preview_.trace) preview_.trace(view(), x, y);
        show_ray(x, y);
        draw();
    }

    // Window position of the centre of image pixel (x, y): where an injected click lands.
    void window_position(int x, int y, int* wx, int* wy) const {
        *wx = layout_.left + x / shrink_x_ * layout_.scale_x + layout_.scale_x / 2;
        *wy = layout_.top + y / shrink_y_ * layout_.scale_y + layout_.scale_y / 2;
    }

    // Repaints the last image, centred in the window as it is now (after a resize, too).
    void draw() {
        paint();
        SDL_RenderPresent(session_.renderer);
    }

    // --window-script's shot (tests): the window's pixels as drawn, to the view's PNG path
    // with _window_N before .png (N = 1, 2, ...), and one line saying where the ray panel
    // sits in it: "window: shot PATH WxH panel=X,Y,W,H" (panel=none when closed).
    void shot() {
        paint();  // read before presenting: the frame just drawn, whatever the driver keeps
        int width = 0, height = 0;
        SDL_GetRendererOutputSize(session_.renderer, &width, &height);
        std::vector<unsigned char> bytes(size_t(width) * height * 3);
        const bool read = SDL_RenderReadPixels(session_.renderer, nullptr, SDL_PIXELFORMAT_RGB24,
                                               bytes.data(), width * 3) == 0;
        SDL_RenderPresent(session_.renderer);
        if (!read) {
            std::fprintf(stderr, "note: no shot: %s\n", printable(SDL_GetError()).c_str());
            return;
        }
        Image picture(width, height);
        for (size_t n = 0; n < picture.pixels.size(); ++n) {
            picture.pixels[n] = {bytes[3 * n] / 255.0f, bytes[3 * n + 1] / 255.0f,
                                 bytes[3 * n + 2] / 255.0f};
        }
        std::string path = preview_.save_path(view());
        const std::string png = ".png";
        if (path.size() > png.size() && path.compare(path.size() - png.size(), png.size(), png) == 0) {
            path.erase(path.size() - png.size());
        }
        path += "_window_" + std::to_string(++shots_) + png;
        try {
            write_png(picture, path);
        } catch (const std::exception& error) {
            std::fprintf(stderr, "note: no shot: %s\n", error.what());
            return;
        }
        // The image as the window shows it: one window pixel per image pixel (the centre of
        // its block), so that a test can compare it with the headless PNG.
        std::string image_path;
        if (!preview_is_showing()) {
            Image shown_image(shown_.width, shown_.height);
            for (int y = 0; y < shown_.height; ++y) {
                for (int x = 0; x < shown_.width; ++x) {
                    const int wx = layout_.left + x * layout_.scale_x + layout_.scale_x / 2;
                    const int wy = layout_.top + y * layout_.scale_y + layout_.scale_y / 2;
                    if (wx < width && wy < height) shown_image.at(x, y) = picture.at(wx, wy);
                }
            }
            image_path = path.substr(0, path.size() - png.size()) + "_image" + png;
            try {
                write_png(shown_image, image_path);
            } catch (const std::exception& error) {
                std::fprintf(stderr, "note: no shot: %s\n", error.what());
                image_path.clear();
            }
        }
        if (!image_path.empty()) std::printf("window: shot image %s\n", image_path.c_str());
        std::printf("window: shot %s %dx%d panel=", path.c_str(), width, height);
        if (has_ray_) {
            std::printf("%d,%d,%d,%d\n", panel_left(width), panel_top(height), ray_drawn_width(),
                        ray_drawn_height());
        } else {
            std::printf("none\n");
        }
    }

    // A coarse preview is on screen (the full picture is still to come).
    bool preview_is_showing() const { return refine_due_; }

    // The panel's widgets and where they are (--window-script's widgets: tests aim at them).
    void print_widgets() const {
        for (const auto& [name, rect] : session_.panel.rects) {
            std::printf("window: widget %s %d,%d,%d,%d\n", name.c_str(), rect[0], rect[1],
                        rect[2], rect[3]);
        }
        if (!session_.panel.counts.empty()) {  // the editor's histogram: values left to right
            std::printf("window: histogram values %d to %d\n", session_.panel.lowest,
                        session_.panel.lowest +
                            session_.panel.bin_width * int(session_.panel.counts.size()));
        }
        std::fflush(stdout);
    }

    int ray_drawn_width() const { return int(std::lround(ray_.width * ray_scale_)); }
    int ray_drawn_height() const { return int(std::lround(ray_.height * ray_scale_)); }
    int panel_left(int window_width) const { return window_width - ray_drawn_width(); }
    int panel_top(int window_height) const {
        return std::max(0, (window_height - ray_drawn_height()) / 2);
    }

    // draw() without presenting the frame.
    void paint() {
        int window_width = 0, window_height = 0;
        SDL_GetWindowSize(session_.window, &window_width, &window_height);
        const int ray_width = has_ray_ ? ray_drawn_width() : 0;  // the ray panel, right
        const int room = window_width - panel_width - ray_width;  // the image's, between
        layout_.left = panel_width + std::max(0, (room - layout_.drawn_width(shown_)) / 2);
        layout_.top = std::max(0, (window_height - layout_.drawn_height(shown_)) / 2);
        // Where the image is, when it moved: its left, top, window pixels per image pixel
        // and image pixels per shown pixel (tests aim at it and compare it with the PNG).
        char where[160];
        std::snprintf(where, sizeof where, "window: image %d,%d scale %d,%d shrink %d,%d of %s "
                      "%dx%d\n", layout_.left, layout_.top, layout_.scale_x, layout_.scale_y,
                      shrink_x_, shrink_y_, view().name.c_str(), view().width, view().height);
        if (where != session_.image_line) {
            session_.image_line = where;
            std::fputs(where, stdout);
            std::fflush(stdout);
        }

        const Uint8 margin_grey = 40;  // dark surround, so the image's own black edge shows
        SDL_SetRenderDrawColor(session_.renderer, margin_grey, margin_grey, margin_grey, 255);
        SDL_RenderClear(session_.renderer);
        const SDL_Rect target = {layout_.left, layout_.top, layout_.drawn_width(shown_),
                                 layout_.drawn_height(shown_)};
        SDL_RenderCopy(session_.renderer, session_.texture, nullptr, &target);
        if (has_ray_ && session_.ray_texture) {
            const SDL_Rect panel = {panel_left(window_width), panel_top(window_height),
                                    ray_drawn_width(), ray_drawn_height()};
            SDL_RenderCopy(session_.renderer, session_.ray_texture, nullptr, &panel);
            int wx = 0, wy = 0;  // the traced pixel, marked on the image
            window_position(ray_x_, ray_y_, &wx, &wy);
            constexpr int arm = 6;
            SDL_SetRenderDrawColor(session_.renderer, 230, 0, 0, 255);
            SDL_RenderDrawLine(session_.renderer, wx - arm, wy, wx - 2, wy);
            SDL_RenderDrawLine(session_.renderer, wx + 2, wy, wx + arm, wy);
            SDL_RenderDrawLine(session_.renderer, wx, wy - arm, wx, wy - 2);
            SDL_RenderDrawLine(session_.renderer, wx, wy + 2, wx, wy + arm);
        }
        panel_frame(window_height);  // the control panel over the left
        session_.panel_draw->draw(ImGui::GetDrawData());
    }

private:
    // Hands the mouse's turn and zoom since the last frame to the step's camera.
    void apply_orbit() {
        preview_.orbit.turn(turn_azimuth_, turn_elevation_);
        if (zoom_factor_ != 1) preview_.orbit.zoom(zoom_factor_);
        turn_azimuth_ = turn_elevation_ = 0;
        zoom_factor_ = 1;
        moved_ = false;
    }

    // The smallest power of two (at least 2) at which 1 in factor x factor pixels would have
    // rendered within preview_frame_ms, by the last full render's time.
    int preview_factor() const {
        int factor = 2;
        while (factor < max_preview_factor && full_ms_ / (factor * factor) > preview_frame_ms) {
            factor *= 2;
        }
        return factor;
    }

    // "05_interpolated_hits | front | threshold=400 | 12.3 ms"
    std::string title(double ms) const {
        std::string text = preview_.step + " | " + view().name;
        if (orbits() && preview_.orbit.value) text += " | " + preview_.orbit.value();
        if (!preview_.knob.name.empty() && preview_.knob.value) {
            text += " | " + preview_.knob.name + "=" + preview_.knob.value();
        }
        char time[32];
        std::snprintf(time, sizeof time, " | %.1f ms", ms);
        return text + time;
    }

    // Copies the float image, shrunk as fit_window() chose, into the RGB24 texture (made anew
    // when the size changes).
    void upload() {
        shown_ = Image((image_.width + shrink_x_ - 1) / shrink_x_,
                       (image_.height + shrink_y_ - 1) / shrink_y_);
        for (int y = 0; y < shown_.height; ++y) {
            for (int x = 0; x < shown_.width; ++x) {
                shown_.at(x, y) = image_.at(x * shrink_x_, y * shrink_y_);
            }
        }
        upload_texture(shown_);
    }

    // Puts `image` into the RGB24 texture (made anew when the size changes). draw() stretches
    // it over the shown picture's place: a coarse preview fills the same rectangle.
    void upload_texture(const Image& image) {
        if (!session_.texture || session_.texture_width != image.width ||
            session_.texture_height != image.height) {
            if (session_.texture) SDL_DestroyTexture(session_.texture);
            session_.texture = SDL_CreateTexture(session_.renderer, SDL_PIXELFORMAT_RGB24,
                                                 SDL_TEXTUREACCESS_STATIC, image.width,
                                                 image.height);
            if (!session_.texture) {
                throw std::runtime_error(std::string("SDL_CreateTexture: ") + SDL_GetError());
            }
            session_.texture_width = image.width;
            session_.texture_height = image.height;
        }
        std::vector<unsigned char> bytes(image.pixels.size() * 3);
        for (size_t n = 0; n < image.pixels.size(); ++n) {
            bytes[3 * n + 0] = to_byte(image.pixels[n].r);
            bytes[3 * n + 1] = to_byte(image.pixels[n].g);
            bytes[3 * n + 2] = to_byte(image.pixels[n].b);
        }
        SDL_UpdateTexture(session_.texture, nullptr, bytes.data(), image.width * 3);
    }

    Preview& preview_;
    Session& session_;
    Layout layout_;
    Image image_;                         // the view as rendered (and saved by S)
    Image shown_;                         // what the texture holds: image_ shrunk
    int shrink_x_ = 1, shrink_y_ = 1;     // image pixels per shown pixel, across and down
    bool has_ray_ = false;                // a click opened the ray panel
    int ray_x_ = 0, ray_y_ = 0;           // its pixel
    Image ray_;                           // its picture
    double full_ms_ = 0;                  // the last full render's time
    // The orbit's mouse: the press, the drag, and what it asks of the camera not yet applied.
    bool pressed_ = false, dragging_ = false, moved_ = false;
    int press_x_ = 0, press_y_ = 0, last_x_ = 0, last_y_ = 0;  // window pixels
    double turn_azimuth_ = 0, turn_elevation_ = 0, zoom_factor_ = 1;
    bool refine_due_ = false;             // a preview is showing: render at full size soon
    Uint32 refine_at_ = 0;                // SDL ticks when (unless the button is held)
    int previews_ = 0, preview_width_ = 0, preview_height_ = 0;  // since the last full render
    int shots_ = 0;                       // --window-script shots written
    double ray_scale_ = 1;                // the ray picture's size on screen: it fits
    int ray_width_fitted_ = 0, ray_height_fitted_ = 0;  // the ray picture fit_window() saw
    bool coarse_from_panel_ = false;      // the coarse picture is the panel's, not the orbit's
    PanelActions actions_;                // what the panel's last frame asked for
    bool has_actions_ = false;
};

// Pushes script event `event` as the SDL event a user would cause, followed by `next_marker`:
// the marker comes out of the queue only after the event has been handled, so the next
// event is pushed only then and the order is the script's.
void push_script_event(const ScriptEvent& script, const PreviewWindow& preview,
                       Uint32 window_id, Uint32 next_marker) {
    SDL_Event event;
    SDL_zero(event);
    if (script.is_click || script.mouse == "press" || script.mouse == "release") {
        const bool down = script.mouse != "release";
        event.type = down ? SDL_MOUSEBUTTONDOWN : SDL_MOUSEBUTTONUP;
        event.button.windowID = window_id;
        event.button.button = SDL_BUTTON_LEFT;
        event.button.state = down ? SDL_PRESSED : SDL_RELEASED;
        event.button.clicks = 1;
        preview.window_position(script.x, script.y, &event.button.x, &event.button.y);
    } else if (script.mouse == "move") {
        event.type = SDL_MOUSEMOTION;
        event.motion.windowID = window_id;
        event.motion.state = SDL_BUTTON_LMASK;
        preview.window_position(script.x, script.y, &event.motion.x, &event.motion.y);
    } else if (script.mouse == "wheel") {
        event.type = SDL_MOUSEWHEEL;
        event.wheel.windowID = window_id;
        event.wheel.y = script.amount;
        event.wheel.direction = SDL_MOUSEWHEEL_NORMAL;
    } else {
        event.type = SDL_KEYDOWN;
        event.key.windowID = window_id;
        event.key.state = SDL_PRESSED;
        event.key.keysym.sym = script.key;
        event.key.keysym.scancode = script.scancode;
    }
    event.common.timestamp = SDL_GetTicks();
    SDL_PushEvent(&event);
    if (script.is_click) {  // and up again: a window that orbits traces on the release
        event.type = SDL_MOUSEBUTTONUP;
        event.button.state = SDL_RELEASED;
        SDL_PushEvent(&event);
    }

    SDL_Event marker;
    SDL_zero(marker);
    marker.type = next_marker;
    SDL_PushEvent(&marker);
}

// Opens the window (SDL, the renderer, ImGui): false, with one note, when none can be.
bool open_window(Preview& preview) {
    const char* display = std::getenv("DISPLAY");
    const char* requested_driver = std::getenv("SDL_VIDEODRIVER");
    const bool x11_expected = display && *display &&
                              (!requested_driver || std::string(requested_driver) == "x11");
    if (x11_expected && probe_display(display) == Probe::silent) {
        SDL_SetError("the X display '%s' accepted a connection but did not answer in %d s",
                     printable(display).c_str(), display_probe_ms / 1000);
        return no_window();
    }

    // Ctrl-C and SIGTERM end the program at once, as they did before the window: SDL would
    // turn them into an SDL_QUIT event that a busy or hung event loop never reads.
    SDL_SetHint(SDL_HINT_NO_SIGNAL_HANDLERS, "1");
    SDL_SetHint(SDL_HINT_RENDER_SCALE_QUALITY, "nearest");  // zoomed pixels stay square blocks
    // On X11, SDL drops a click that arrives just as the window gains focus: here it traces.
    SDL_SetHint(SDL_HINT_MOUSE_FOCUS_CLICKTHROUGH, "1");
    if (SDL_Init(SDL_INIT_VIDEO) != 0) {
        no_window();
        SDL_Quit();
        return false;
    }
    auto session = std::make_unique<Session>();  // its destructor cleans up (and SDL_Quit)
    // When no display answers, SDL quietly falls back to drivers that show nothing; a
    // window nobody can see would then wait forever for a key. Only allowed when asked for.
    const std::string driver = SDL_GetCurrentVideoDriver() ? SDL_GetCurrentVideoDriver() : "";
    const char* requested = std::getenv("SDL_VIDEODRIVER");
    if ((driver == "offscreen" || driver == "dummy") && !(requested && driver == requested)) {
        SDL_SetError("no display answered, only the invisible '%s' driver", driver.c_str());
        return no_window();
    }
    // Created small and centred; fit_window() sizes it for the view and keeps it on screen.
    session->window = SDL_CreateWindow(preview.step.c_str(), SDL_WINDOWPOS_CENTERED,
                                       SDL_WINDOWPOS_CENTERED, panel_width + min_window_width,
                                       min_panel_height / 2, SDL_WINDOW_RESIZABLE);
    if (!session->window) return no_window();
    session->renderer = SDL_CreateRenderer(session->window, -1, SDL_RENDERER_ACCELERATED);
    if (!session->renderer) {
        // No GPU (Xvfb, remote X): SDL's own software renderer always works.
        session->renderer = SDL_CreateRenderer(session->window, -1, SDL_RENDERER_SOFTWARE);
    }
    if (!session->renderer) return no_window();
    if (driver == "x11") handle_lost_display(preview.step, display);
    SDL_RendererInfo info;
    if (SDL_GetRendererInfo(session->renderer, &info) == 0) {
        std::printf("window: renderer %s\n", info.name ? info.name : "?");  // opengl, software
        std::fflush(stdout);
        if (info.max_texture_width > 0) session->max_texture_width = info.max_texture_width;
        if (info.max_texture_height > 0) session->max_texture_height = info.max_texture_height;
    }
    // The control panel: ImGui with its SDL input backend, drawn by PanelDraw.
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini written into the working folder
    ImGui::GetIO().BackendFlags |= ImGuiBackendFlags_RendererHasVtxOffset;
    ImGui::StyleColorsDark();
    ImGui_ImplSDL2_InitForSDLRenderer(session->window);
    session->imgui = true;
    session->panel_draw = std::make_unique<PanelDraw>(session->renderer);
    session->step = preview.step;
    open_session = std::move(session);
    return true;
}

}  // namespace

void check_window_script(const Options& options) { parse_script(options.window_script); }

// window_wanted() is the steps' own (window_module.cpp): it decides whether to open this.

bool window_open() { return open_session != nullptr; }

void window_note(const std::string& note) {
    if (open_session) open_session->panel.note = note;
}

bool show_preview(const Options& options, Preview& preview) {
    const std::vector<ScriptEvent> script = parse_script(options.window_script);
    if (preview.views.empty()) return false;
    if (open_session && open_session->step != preview.step) open_session.reset();
    const bool rerun = open_session != nullptr;  // the panel ran the step again
    if (!rerun && !open_window(preview)) return false;
    Session& session = *open_session;
    if (rerun && session.view >= 0) preview.current = session.view;
    preview.current = std::clamp(preview.current, 0, static_cast<int>(preview.views.size()) - 1);
    const bool coarse = session.coarse_next;
    session.coarse_next = false;

    PreviewWindow window(preview, session);
    window.fit_window();
    window.render_first(coarse);
    window.print_command();

    const Uint32 window_id = SDL_GetWindowID(session.window);
    static Uint32 next_marker = static_cast<Uint32>(-1);  // "push the next script event"
    if (next_marker == static_cast<Uint32>(-1)) next_marker = SDL_RegisterEvents(1);
    // The script goes on where it was when P or the panel ran the step again.
    static size_t script_done = 0;
    size_t& next_script = script_done;
    bool script_waits = false;  // a wait:MS event holds the script until script_resumes
    Uint32 script_resumes = 0;
    auto push_marker = [&] {
        SDL_Event marker;
        SDL_zero(marker);
        marker.type = next_marker;
        SDL_PushEvent(&marker);
    };
    // A rerun's marker is already in the queue (pushed after the event that caused it).
    if (!rerun && !script.empty() && next_marker != static_cast<Uint32>(-1)) push_marker();
    int frames_due = 2;  // the panel's first frames: ImGui lays itself out in the first
    int mouse_x = -1;    // window x of the mouse's last event (the wheel's goes there)

    // The panel's actions of the last frame: true when the step must run again (the window
    // stays open) or quit to switch presets.
    auto handle_actions = [&]() -> bool {
        PanelActions actions;
        if (!window.take_actions(&actions)) return false;
        if (!actions.note.empty()) {
            std::printf("window: %s\n", printable(actions.note).c_str());
            session.panel.note = actions.note;
        }
        if (actions.view >= 0 && actions.view != preview.current) {
            window.show_view(preview.views[actions.view].axis);
        }
        if (!actions.preset.empty()) {
            request_preset(actions.preset);
            open_session.reset();  // the step runs again with it, in a new window (as P)
            return true;
        }
        if (actions.set) {
            std::printf("window: set %s%s\n", printable(actions.changed).c_str(),
                        actions.coarse ? " (preview)" : "");
            std::fflush(stdout);
            session.panel.note.clear();
            session.coarse_next = actions.coarse;
            request_rerun(actions.words);
            return true;
        }
        return false;
    };

    SDL_Event event;
    for (;;) {
        // Wait for an event, or until a preview is due for its full render, a scripted
        // wait is over or the panel needs a frame, whichever comes first.
        int wait_ms = window.ms_until_refine();
        if (script_waits) {
            const Uint32 now = SDL_GetTicks();
            const int script_ms = SDL_TICKS_PASSED(now, script_resumes)
                                      ? 0 : int(script_resumes - now);
            wait_ms = wait_ms < 0 ? script_ms : std::min(wait_ms, script_ms);
        }
        if (frames_due > 0 || ImGui::IsAnyItemActive()) {
            wait_ms = wait_ms < 0 ? int(frame_ms) : std::min(wait_ms, int(frame_ms));
        }
        if (wait_ms < 0) {
            if (!SDL_WaitEvent(&event)) break;
        } else if (!SDL_WaitEventTimeout(&event, std::max(wait_ms, 1))) {
            if (window.ms_until_refine() == 0) window.refine();
            if (script_waits && SDL_TICKS_PASSED(SDL_GetTicks(), script_resumes)) {
                script_waits = false;
                push_marker();
            }
            if (frames_due > 0 || ImGui::IsAnyItemActive()) {
                if (frames_due > 0) --frames_due;
                window.draw();
                if (handle_actions()) return true;
            }
            continue;
        }
        if (event.type == SDL_QUIT) break;
        // The panel sees every input; the image gets the mouse right of the panel and the
        // keys unless a text field of the panel is being typed in.
        ImGui_ImplSDL2_ProcessEvent(&event);
        bool to_panel = false;
        if (event.type == SDL_MOUSEBUTTONDOWN || event.type == SDL_MOUSEBUTTONUP) {
            to_panel = event.button.x < panel_width;
            mouse_x = event.button.x;
            frames_due = 2;
        } else if (event.type == SDL_MOUSEMOTION) {
            to_panel = event.motion.x < panel_width;
            mouse_x = event.motion.x;
            frames_due = std::max(frames_due, 1);
        } else if (event.type == SDL_MOUSEWHEEL) {
            to_panel = mouse_x >= 0 && mouse_x < panel_width;  // where the mouse last was
            frames_due = 2;
        } else if (event.type == SDL_KEYDOWN || event.type == SDL_KEYUP ||
                   event.type == SDL_TEXTINPUT) {
            to_panel = ImGui::GetIO().WantTextInput;
            frames_due = 2;
        }
        if (event.type == next_marker) {
            if (next_script < script.size() && script[next_script].mouse == "shot") {
                ++next_script;
                window.shot();
                push_marker();
            } else if (next_script < script.size() && script[next_script].mouse == "widgets") {
                ++next_script;
                window.draw();
                window.print_widgets();
                push_marker();
            } else if (next_script < script.size() && script[next_script].mouse == "panel") {
                // set:NAME=VALUE and tf:...: as the widget would (common/panel.h).
                const ScriptEvent& panel_event = script[next_script++];
                push_marker();  // taken by the next show_preview after the rerun
                PanelActions actions;
                try {
                    panel_script_event(preview, session.panel, panel_event.text, &actions);
                } catch (const InputError& error) {
                    std::printf("window: %s\n", printable(error.what()).c_str());
                    std::fflush(stdout);
                    continue;
                }
                std::printf("window: set %s\n", printable(actions.changed).c_str());
                std::fflush(stdout);
                session.coarse_next = false;
                request_rerun(actions.words);
                return true;
            } else if (next_script < script.size() && script[next_script].mouse == "wait") {
                script_waits = true;
                script_resumes = SDL_GetTicks() + Uint32(script[next_script++].amount);
            } else if (next_script < script.size()) {
                push_script_event(script[next_script++], window, window_id, next_marker);
            }
        } else if (event.type == SDL_WINDOWEVENT) {
            if (event.window.event == SDL_WINDOWEVENT_CLOSE) break;
            if (event.window.event == SDL_WINDOWEVENT_EXPOSED ||
                event.window.event == SDL_WINDOWEVENT_SIZE_CHANGED) {
                window.draw();
            }
        } else if (to_panel) {
            // The panel's: drawn with the next frame.
        } else if (event.type == SDL_MOUSEBUTTONDOWN && event.button.button == SDL_BUTTON_LEFT) {
            window.press(event.button.x, event.button.y);
        } else if (event.type == SDL_MOUSEBUTTONUP && event.button.button == SDL_BUTTON_LEFT) {
            window.release();
        } else if (event.type == SDL_MOUSEMOTION) {
            window.move(event.motion.x, event.motion.y);
        } else if (event.type == SDL_MOUSEWHEEL) {
            const int notches = event.wheel.direction == SDL_MOUSEWHEEL_FLIPPED ? -event.wheel.y
                                                                                : event.wheel.y;
            window.wheel(notches);
        } else if (event.type == SDL_KEYDOWN) {
            const Action action = action_of(event.key.keysym.sym);
            const bool repeatable = action == Action::knob_up || action == Action::knob_down;
            if (action == Action::none || (event.key.repeat && !repeatable)) continue;
            std::printf("window: key=%s\n", key_name(event.key.keysym.sym).c_str());
            std::fflush(stdout);
            switch (action) {
                case Action::view_top: window.show_view(ViewAxis::top); break;
                case Action::view_front: window.show_view(ViewAxis::front); break;
                case Action::view_side: window.show_view(ViewAxis::side); break;
                case Action::knob_up: window.change_knob(+1); break;
                case Action::knob_down: window.change_knob(-1); break;
                case Action::save: window.save(); break;
                case Action::quit: open_session.reset(); return true;
                case Action::next_preset: {
                    // The step runs again with it (guarded_main), in a new window.
                    const std::string next = next_preset(options.preset);
                    if (next.empty()) {
                        std::printf("window: no presets in data/presets\n");
                        break;
                    }
                    request_preset(next);
                    open_session.reset();
                    return true;
                }
                case Action::none: break;
            }
        }
        // The mouse's moves are gathered while a frame renders; one preview for all of them,
        // once none is left in the queue (SDL_MOUSEMOTION .. SDL_MOUSEWHEEL: buttons too).
        if (SDL_PeepEvents(nullptr, 0, SDL_PEEKEVENT, SDL_MOUSEMOTION, SDL_MOUSEWHEEL) <= 0) {
            window.preview();
        }
        // The panel's frame once the queue is empty.
        if (frames_due > 0 && SDL_PeepEvents(nullptr, 0, SDL_PEEKEVENT, SDL_FIRSTEVENT,
                                             SDL_LASTEVENT) <= 0) {
            --frames_due;
            window.draw();
        }
        if (handle_actions()) return true;
        std::fflush(stdout);
    }
    open_session.reset();
    return true;
}

}  // namespace ctlab
