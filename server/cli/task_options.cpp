#include "cli/task_options.hpp"

#include <algorithm>
#include <cmath>

#include "anatomy/landmarks.hpp"
#include "base/errors.hpp"

namespace palp::cli {

training::TaskSpec parse_task_spec(const std::string& name, const Args& args) {
  using training::TaskKind;
  training::TaskSpec spec;
  const auto kind = training::parse_task_kind(name);
  if (!kind) throw UsageError("unknown task '" + name + "' (ptcd, lumbar or femoral)");
  spec.kind = *kind;
  if (const auto side = args.get("side")) {
    const auto parsed = anatomy::parse_side(*side);
    if (!parsed) throw UsageError("--side is right or left, got '" + *side + "'");
    spec.side = *parsed;
  }
  const double space = args.number("space", 9.0);
  if (space != std::floor(space)) throw UsageError("--space needs a whole number");
  spec.space = static_cast<int>(std::clamp(space, -1.0, 99.0));
  if (const auto interspace = args.get("interspace")) spec.interspace = *interspace;
  if (args.has("space") && spec.kind != TaskKind::ptcd) throw UsageError("--space is for ptcd");
  if (args.has("interspace") && spec.kind != TaskKind::lumbar)
    throw UsageError("--interspace is for lumbar");
  if (args.has("side") && spec.kind == TaskKind::lumbar)
    throw UsageError("--side is for ptcd and femoral (lumbar is on the midline)");
  validate(spec);
  return spec;
}

}  // namespace palp::cli
