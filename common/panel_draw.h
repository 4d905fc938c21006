// panel_draw.h: draws the control panel's Dear ImGui frame with the window's SDL_Renderer.
#pragma once
#include <SDL.h>

struct ImDrawData;

namespace ctlab {

// Owns the font texture; ImGui's context must exist before and after it.
class PanelDraw {
public:
    explicit PanelDraw(SDL_Renderer* renderer);
    ~PanelDraw();
    PanelDraw(const PanelDraw&) = delete;
    PanelDraw& operator=(const PanelDraw&) = delete;

    // ImGui::GetDrawData() after ImGui::Render(), drawn over what the renderer holds.
    void draw(ImDrawData* data);

private:
    SDL_Renderer* renderer_;
    SDL_Texture* font_ = nullptr;
};

}  // namespace ctlab
