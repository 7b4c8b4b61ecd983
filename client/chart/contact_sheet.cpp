// Contact sheets of PNG images: see contact_sheet.hpp.
#include "chart/contact_sheet.hpp"

#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkPNGWriter.h>
#include <vtkSmartPointer.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>

#include "base/errors.hpp"

namespace palp::chart {

namespace {
constexpr int kGutter = 6;
constexpr int kMaxSide = 1 << 14;  // pixels a side of the sheet
}  // namespace

void write_contact_sheet(const std::vector<std::string>& inputs, int columns,
                         const std::string& out) {
  if (inputs.empty()) throw UsageError("contact sheet: no images");
  if (columns < 1) throw UsageError("contact sheet: --columns must be >= 1");
  std::vector<vtkSmartPointer<vtkImageData>> images;
  int cell_w = 0, cell_h = 0;
  for (const std::string& path : inputs) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path + ": no such image");
    vtkNew<vtkPNGReader> reader;
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    int dims[3];
    image->GetDimensions(dims);
    const int comps = image->GetNumberOfScalarComponents();
    if (dims[0] < 1 || dims[1] < 1 || comps < 1 || image->GetScalarType() != VTK_UNSIGNED_CHAR)
      throw InputError(path + ": not an 8-bit PNG");
    auto copy = vtkSmartPointer<vtkImageData>::New();
    copy->DeepCopy(image);
    images.push_back(copy);
    cell_w = std::max(cell_w, dims[0]);
    cell_h = std::max(cell_h, dims[1]);
  }
  const int n = static_cast<int>(images.size());
  const int cols = std::min(columns, n), rows = (n + cols - 1) / cols;
  const long width = static_cast<long>(cols) * cell_w + static_cast<long>(cols + 1) * kGutter;
  const long height = static_cast<long>(rows) * cell_h + static_cast<long>(rows + 1) * kGutter;
  if (width > kMaxSide || height > kMaxSide)
    throw UsageError("contact sheet: " + std::to_string(width) + " x " + std::to_string(height) +
                     " pixels is more than " + std::to_string(kMaxSide) + " a side");
  vtkNew<vtkImageData> sheet;
  sheet->SetDimensions(static_cast<int>(width), static_cast<int>(height), 1);
  sheet->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  auto* dst = static_cast<std::uint8_t*>(sheet->GetScalarPointer());
  std::fill(dst, dst + width * height * 3, std::uint8_t{24});
  for (int t = 0; t < n; ++t) {
    vtkImageData* image = images[static_cast<std::size_t>(t)];
    int dims[3];
    image->GetDimensions(dims);
    const int comps = image->GetNumberOfScalarComponents();
    const auto* src = static_cast<const std::uint8_t*>(image->GetScalarPointer());
    // Row 0 of a VTK image is the bottom: the first tile goes to the sheet's top-left.
    const int col = t % cols, row = t / cols;
    const long x0 = kGutter + static_cast<long>(col) * (cell_w + kGutter);
    const long top = kGutter + static_cast<long>(row) * (cell_h + kGutter);
    const long y0 = height - top - dims[1];
    for (int y = 0; y < dims[1]; ++y)
      for (int x = 0; x < dims[0]; ++x) {
        const std::uint8_t* p = src + (static_cast<long>(y) * dims[0] + x) * comps;
        std::uint8_t* q = dst + ((y0 + y) * width + x0 + x) * 3;
        for (int c = 0; c < 3; ++c) q[c] = p[comps >= 3 ? c : 0];
      }
  }
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(out.c_str());
  writer->SetInputData(sheet);
  writer->Write();
  if (writer->GetErrorCode() != 0) throw Error(out + ": cannot be written");
}

}  // namespace palp::chart
