// panel_draw.cpp: Dear ImGui's triangles drawn with SDL_Renderer (SDL_RenderGeometryRaw), the
// renderer the preview window already uses: no OpenGL, so the panel works the same on a
// desktop, over ssh and on a virtual X display (Xvfb), where SDL falls back to software.
#include "panel_draw.h"
#include <imgui.h>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace ctlab {

PanelDraw::PanelDraw(SDL_Renderer* renderer) : renderer_(renderer) {
    // The font atlas as one RGBA texture; ImGui refers to it by this pointer.
    ImGuiIO& io = ImGui::GetIO();
    unsigned char* pixels = nullptr;
    int width = 0, height = 0;
    io.Fonts->GetTexDataAsRGBA32(&pixels, &width, &height);
    font_ = SDL_CreateTexture(renderer_, SDL_PIXELFORMAT_ABGR8888, SDL_TEXTUREACCESS_STATIC,
                              width, height);
    if (!font_) throw std::runtime_error(std::string("SDL_CreateTexture: ") + SDL_GetError());
    SDL_UpdateTexture(font_, nullptr, pixels, width * 4);  // bytes R, G, B, A in memory
    SDL_SetTextureBlendMode(font_, SDL_BLENDMODE_BLEND);
    SDL_SetTextureScaleMode(font_, SDL_ScaleModeLinear);
    io.Fonts->SetTexID(static_cast<ImTextureID>(font_));
}

PanelDraw::~PanelDraw() {
    ImGui::GetIO().Fonts->SetTexID(nullptr);
    if (font_) SDL_DestroyTexture(font_);
}

void PanelDraw::draw(ImDrawData* data) {
    if (!data) return;
    SDL_Rect old_clip;
    const bool was_clipped = SDL_RenderIsClipEnabled(renderer_);
    SDL_RenderGetClipRect(renderer_, &old_clip);
    for (int list = 0; list < data->CmdListsCount; ++list) {
        const ImDrawList* commands = data->CmdLists[list];
        const ImDrawVert* vertices = commands->VtxBuffer.Data;
        const ImDrawIdx* indices = commands->IdxBuffer.Data;
        for (const ImDrawCmd& command : commands->CmdBuffer) {
            if (command.UserCallback) {
                command.UserCallback(commands, &command);
                continue;
            }
            // ImGui's clip rectangle (window pixels, as floats) as SDL's whole pixels.
            const ImVec2 origin = data->DisplayPos;
            const int left = int(command.ClipRect.x - origin.x);
            const int top = int(command.ClipRect.y - origin.y);
            const int right = int(command.ClipRect.z - origin.x);
            const int bottom = int(command.ClipRect.w - origin.y);
            if (right <= left || bottom <= top) continue;
            const SDL_Rect clip = {left, top, right - left, bottom - top};
            SDL_RenderSetClipRect(renderer_, &clip);

            // Positions, colours and texture coordinates interleaved in ImDrawVert.
            const ImDrawVert* first = vertices + command.VtxOffset;
            const int stride = int(sizeof(ImDrawVert));
            const float* xy = reinterpret_cast<const float*>(
                reinterpret_cast<const char*>(first) + offsetof(ImDrawVert, pos));
            const float* uv = reinterpret_cast<const float*>(
                reinterpret_cast<const char*>(first) + offsetof(ImDrawVert, uv));
            const SDL_Color* colour = reinterpret_cast<const SDL_Color*>(
                reinterpret_cast<const char*>(first) + offsetof(ImDrawVert, col));
            SDL_RenderGeometryRaw(renderer_, static_cast<SDL_Texture*>(command.GetTexID()),
                                  xy, stride, colour, stride, uv, stride,
                                  commands->VtxBuffer.Size - int(command.VtxOffset),
                                  indices + command.IdxOffset, int(command.ElemCount),
                                  int(sizeof(ImDrawIdx)));
        }
    }
    SDL_RenderSetClipRect(renderer_, was_clipped ? &old_clip : nullptr);
}

}  // namespace ctlab
