// A contact sheet: PNG images laid out in a grid on one PNG, so a sequence of screenshots can be
// judged at a glance (deploy/view_sequence.sh). Off screen, no display needed.
#pragma once

#include <string>
#include <vector>

namespace palp::chart {

// Reads `inputs` (PNG, RGB or RGBA, any sizes), places them row by row `columns` to a row in
// cells the size of the largest, with a 6-pixel dark gutter, and writes `out`. InputError for a
// file that cannot be read, UsageError for no inputs or columns < 1, Error when writing fails.
void write_contact_sheet(const std::vector<std::string>& inputs, int columns,
                         const std::string& out);

}  // namespace palp::chart
