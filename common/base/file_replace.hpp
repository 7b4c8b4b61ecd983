// Writing a whole file so that a reader never sees half of it: the text goes to PATH.partial,
// which is then renamed over PATH (atomic on one file system). Used by every writer of palp's
// small text outputs (trajectories, marks, landmarks, reports, prep.json).
#pragma once

#include <string>
#include <string_view>

namespace palp {

// Writes `text` to `path` through `path`.partial; on any failure removes the partial file and
// throws Error naming `path` (and the system's reason where there is one).
void replace_file(const std::string& path, std::string_view text);

}  // namespace palp
