// The force chart (see force_chart.hpp).
#include "render/force_chart.hpp"

#include <vtkAxis.h>
#include <vtkBrush.h>
#include <vtkChartLegend.h>
#include <vtkFloatArray.h>
#include <vtkPlot.h>

#include <cstddef>

#include "base/vec.hpp"

namespace palp::view {

ForceChart::ForceChart(double seconds) : seconds_(seconds) {
  renderer_->SetLayer(1);
  renderer_->SetViewport(0.62, 0.0, 1.0, 0.3);
  renderer_->InteractiveOff();

  // Columns t, |f|, fx, fy, fz; one line for each force column.
  for (const char* name : {"t", "|f|", "fx", "fy", "fz"}) {
    vtkNew<vtkFloatArray> column;
    column->SetName(name);
    table_->AddColumn(column);
  }
  table_->SetNumberOfRows(2);
  for (vtkIdType r = 0; r < 2; ++r)
    for (vtkIdType c = 0; c < 5; ++c) table_->SetValue(r, c, vtkVariant(0.0f));
  const double line_colours[4][3] = {
      {255, 255, 255}, {255, 90, 90}, {90, 220, 90}, {110, 150, 255}};
  for (int c = 1; c <= 4; ++c) {
    vtkPlot* line = chart_->AddPlot(vtkChart::LINE);
    line->SetInputData(table_, 0, c);
    line->SetColor(line_colours[c - 1][0] / 255, line_colours[c - 1][1] / 255,
                   line_colours[c - 1][2] / 255);
    line->SetWidth(c == 1 ? 2.0f : 1.0f);
  }
  chart_->GetAxis(vtkAxis::BOTTOM)->SetTitle("t (s)");
  chart_->GetAxis(vtkAxis::LEFT)->SetTitle("N");
  chart_->SetShowLegend(true);
  // Top left: the newest samples are at the right edge, where a legend would hide them.
  chart_->GetLegend()->SetHorizontalAlignment(vtkChartLegend::LEFT);
  chart_->GetLegend()->SetVerticalAlignment(vtkChartLegend::TOP);
  chart_->GetBackgroundBrush()->SetColorF(0.1, 0.1, 0.12, 0.75);
  scene_->AddItem(chart_);
  actor_->SetScene(scene_);
  renderer_->AddActor(actor_);
  scene_->SetRenderer(renderer_);
}

void ForceChart::update(const std::vector<ForceSample>& history) {
  std::size_t first = 0;
  const double t_end = history.empty() ? 0.0 : history.back().t_s;
  while (first < history.size() && history[first].t_s < t_end - seconds_) ++first;
  const std::size_t rows = history.size() - first;
  if (rows < 2) {
    table_->SetNumberOfRows(2);
    for (vtkIdType r = 0; r < 2; ++r) {
      table_->SetValue(r, 0, vtkVariant(static_cast<float>(r - 1)));
      for (vtkIdType c = 1; c < 5; ++c) table_->SetValue(r, c, vtkVariant(0.0f));
    }
  } else {
    table_->SetNumberOfRows(static_cast<vtkIdType>(rows));
    auto* t = vtkFloatArray::SafeDownCast(table_->GetColumn(0));
    auto* fm = vtkFloatArray::SafeDownCast(table_->GetColumn(1));
    auto* fx = vtkFloatArray::SafeDownCast(table_->GetColumn(2));
    auto* fy = vtkFloatArray::SafeDownCast(table_->GetColumn(3));
    auto* fz = vtkFloatArray::SafeDownCast(table_->GetColumn(4));
    for (std::size_t r = 0; r < rows; ++r) {
      const ForceSample& s = history[first + r];
      const auto row = static_cast<vtkIdType>(r);
      t->SetValue(row, static_cast<float>(s.t_s - t_end));
      fm->SetValue(row, static_cast<float>(norm(s.force)));
      fx->SetValue(row, static_cast<float>(s.force.x));
      fy->SetValue(row, static_cast<float>(s.force.y));
      fz->SetValue(row, static_cast<float>(s.force.z));
    }
  }
  table_->Modified();
  chart_->RecalculateBounds();
  chart_->GetAxis(vtkAxis::BOTTOM)->SetRange(-seconds_, 0.0);
  chart_->GetAxis(vtkAxis::BOTTOM)->SetBehavior(vtkAxis::FIXED);
}

void ForceChart::set_visible(bool visible) {
  actor_->SetVisibility(visible);
  renderer_->SetDraw(visible);
}

}  // namespace palp::view
