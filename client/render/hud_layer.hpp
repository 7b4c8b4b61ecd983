// The HUD's text actors: the text block (top left), the banner (top centre) and the force line.
#pragma once

#include <vtkNew.h>
#include <vtkRenderer.h>
#include <vtkTextActor.h>

#include <string>

#include "render/hud_text.hpp"

namespace palp::view {

class HudLayer {
 public:
  // Adds the text actors to `renderer` (over the scene, normalized viewport positions).
  explicit HudLayer(vtkRenderer* renderer);

  // Sets the texts from hud_text / banner_text / force_text.
  void update(const LatestState& state, const HudInputs& inputs);
  // Shows or hides them all (the banner only shows when it has text).
  void set_visible(bool visible);

  const std::string& hud_string() const { return hud_string_; }
  const std::string& banner_string() const { return banner_string_; }

 private:
  vtkNew<vtkTextActor> hud_;
  vtkNew<vtkTextActor> banner_;
  vtkNew<vtkTextActor> force_label_;
  std::string hud_string_, banner_string_;
};

}  // namespace palp::view
