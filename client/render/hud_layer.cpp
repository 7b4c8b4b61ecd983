// The HUD's text actors (see hud_layer.hpp).
#include "render/hud_layer.hpp"

#include <vtkCoordinate.h>
#include <vtkTextProperty.h>

namespace palp::view {

HudLayer::HudLayer(vtkRenderer* renderer) {
  hud_->GetTextProperty()->SetFontFamilyToCourier();
  hud_->GetTextProperty()->SetFontSize(15);
  hud_->GetTextProperty()->SetColor(0.9, 0.95, 0.9);
  hud_->GetTextProperty()->SetVerticalJustificationToTop();
  hud_->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  hud_->GetPositionCoordinate()->SetValue(0.01, 0.985);
  renderer->AddActor2D(hud_);
  banner_->GetTextProperty()->SetFontSize(24);
  banner_->GetTextProperty()->SetBold(true);
  banner_->GetTextProperty()->SetColor(1.0, 1.0, 1.0);
  banner_->GetTextProperty()->SetBackgroundColor(0.75, 0.05, 0.05);
  banner_->GetTextProperty()->SetBackgroundOpacity(0.85);
  banner_->GetTextProperty()->SetJustificationToCentered();
  banner_->GetTextProperty()->SetVerticalJustificationToTop();
  banner_->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  banner_->GetPositionCoordinate()->SetValue(0.5, 0.97);
  renderer->AddActor2D(banner_);
  force_label_->GetTextProperty()->SetFontSize(14);
  force_label_->GetTextProperty()->SetColor(1.0, 0.85, 0.6);
  force_label_->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  force_label_->GetPositionCoordinate()->SetValue(0.62, 0.31);
  renderer->AddActor2D(force_label_);
}

void HudLayer::update(const LatestState& state, const HudInputs& inputs) {
  hud_string_ = hud_text(state, inputs);
  banner_string_ = banner_text(state);
  hud_->SetInput(hud_string_.c_str());
  banner_->SetInput(banner_string_.empty() ? " " : banner_string_.c_str());
  force_label_->SetInput(force_text(state).c_str());
}

void HudLayer::set_visible(bool visible) {
  hud_->SetVisibility(visible);
  banner_->SetVisibility(visible && !banner_string_.empty());
  force_label_->SetVisibility(visible);
}

}  // namespace palp::view
