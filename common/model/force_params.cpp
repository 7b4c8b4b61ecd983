// The force model's parameters: names, defaults per model and tool, validation and setting by
// name (see force_model.hpp; the tick is in force_model.cpp).
#include <cmath>
#include <string>

#include "base/errors.hpp"
#include "model/force_model.hpp"  // declares them

namespace palp {

BoneMode parse_bone_mode(std::string_view name) {
  if (name == "printed") return BoneMode::Printed;
  if (name == "robust") return BoneMode::Robust;
  throw UsageError("bone mode '" + std::string(name) + "' is not printed or robust");
}

const char* to_string(BoneMode mode) {
  return mode == BoneMode::Robust ? "robust" : "printed";
}

ModelKind parse_model_kind(std::string_view name) {
  if (name == "paper") return ModelKind::Paper;
  if (name == "palp") return ModelKind::Palp;
  throw UsageError("force model '" + std::string(name) + "' is not paper or palp");
}

const char* to_string(ModelKind kind) {
  return kind == ModelKind::Palp ? "palp" : "paper";
}

ForceParams default_params(ToolKind kind) {
  ForceParams p;
  if (kind == ToolKind::Probe) {
    p.c = 0.4;
    p.k = 0.3;
  } else {
    p.c = 2.0;
    p.k = 0.4;
  }
  return p;
}

ForceParams palp_params(ToolKind kind) {
  ForceParams p = default_params(kind);
  p.model = ModelKind::Palp;
  p.bone_mode = BoneMode::Robust;
  p.mu = kind == ToolKind::Probe ? 0.2 : 0.5;
  // The shortest reach that puts rib / space at 6 mm over 1.5 for finger:1 and finger:37 on the
  // torso phantom (docs/force_model.md, "Rib contrast"); paper keeps ForceParams' 8 mm, unused.
  p.bone_reach_mm = 9.0;
  return p;
}

ForceParams model_params(ModelKind kind, ToolKind tool) {
  return kind == ModelKind::Palp ? palp_params(tool) : default_params(tool);
}

void validate(const ForceParams& p) {
  // Physical ranges: every value that shapes the force is bounded, whichever way it comes in
  // (command line, config file, a controller's SetParameter).
  auto check = [](bool ok, const char* what) {
    if (!ok) throw UsageError(std::string("force parameter ") + what);
  };
  const auto in = [](double v, double lo, double hi) {
    return std::isfinite(v) && v >= lo && v <= hi;
  };
  check(in(p.c, 0.0, 20.0), "c must be in [0, 20] mm/N (fingertip 2, probe 0.4)");
  check(in(p.k, 0.0, 5.0), "k must be in [0, 5] N/mm (fingertip 0.4, probe 0.3)");
  check(in(p.bone_fmax, 0.0, 60.0), "bone_fmax must be in [0, 60] N (paper: 40)");
  check(in(p.bone_flip, 0.0, 10.0), "bone_flip must be in [0, 10] (paper: 4)");
  check(in(p.bone_k, 0.0, 100.0), "bone_k must be in [0, 100] N/mm (default 10)");
  check(p.bone_mode == BoneMode::Printed || p.bone_mode == BoneMode::Robust,
        "bone_mode must be printed (0) or robust (1)");
  check(std::isfinite(p.grad_epsilon) && p.grad_epsilon > 0.0 && p.grad_epsilon <= 0.1,
        "grad_epsilon must be in (0, 0.1]");
  check(
      std::isfinite(p.direction_epsilon) && p.direction_epsilon > 0.0 && p.direction_epsilon <= 0.1,
      "direction_epsilon must be in (0, 0.1]");
  check(p.model == ModelKind::Paper || p.model == ModelKind::Palp,
        "model must be paper (0) or palp (1)");
  check(in(p.mu, 0.0, 2.0), "mu must be in [0, 2] (finger on skin 0.3-0.8)");
  check(in(p.skin_fmax, 1.0, 200.0), "skin_fmax must be in [1, 200] N (default 30)");
  check(in(p.bone_fade_mm, 0.0, 30.0), "bone_fade_mm must be in [0, 30] mm (default 4)");
  check(in(p.bone_reach_mm, 1.0, 20.0), "bone_reach_mm must be in [1, 20] mm (printed law: 5)");
}

void set_param(ForceParams& params, std::string_view name, double value) {
  ForceParams p = params;
  if (name == "c")
    p.c = value;
  else if (name == "k")
    p.k = value;
  else if (name == "bone_fmax")
    p.bone_fmax = value;
  else if (name == "bone_flip")
    p.bone_flip = value;
  else if (name == "grad_epsilon")
    p.grad_epsilon = value;
  else if (name == "direction_epsilon")
    p.direction_epsilon = value;
  else if (name == "bone_k")
    p.bone_k = value;
  else if (name == "bone_mode") {
    if (value != 0.0 && value != 1.0)
      throw UsageError("force parameter bone_mode must be 0 (printed) or 1 (robust)");
    p.bone_mode = value != 0.0 ? BoneMode::Robust : BoneMode::Printed;
  } else if (name == "model") {
    if (value != 0.0 && value != 1.0)
      throw UsageError("force parameter model must be 0 (paper) or 1 (palp)");
    p.model = value != 0.0 ? ModelKind::Palp : ModelKind::Paper;
  } else if (name == "mu") {
    p.mu = value;
  } else if (name == "skin_fmax") {
    p.skin_fmax = value;
  } else if (name == "bone_fade_mm") {
    p.bone_fade_mm = value;
  } else if (name == "bone_reach_mm") {
    p.bone_reach_mm = value;
  } else if (name == "bone_along_normal") {
    if (value != 0.0 && value != 1.0)
      throw UsageError("force parameter bone_along_normal must be 0 or 1");
    p.bone_along_normal = value != 0.0;
  } else if (name == "bone_enabled") {
    if (value != 0.0 && value != 1.0)
      throw UsageError("force parameter bone_enabled must be 0 or 1");
    p.bone_enabled = value != 0.0;
  } else {
    throw UsageError("unknown force parameter '" + std::string(name) +
                     "' (known: c, k, bone_fmax, bone_flip, bone_enabled, grad_epsilon, "
                     "direction_epsilon, bone_mode, bone_k, model, mu, skin_fmax, bone_fade_mm, "
                     "bone_reach_mm, bone_along_normal)");
  }
  validate(p);
  params = p;
}

}  // namespace palp
