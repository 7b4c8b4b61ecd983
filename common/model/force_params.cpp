// The force model's parameters: names, defaults per model and tool, validation and setting by
// name (see force_model.hpp; the tick is in force_model.cpp).
#include <cmath>
#include <iterator>
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

namespace {

// The structure layers' parameters (structure_layers.hpp).
template <class Check, class In>
void validate_layers(const ForceParams& p, Check check, In in) {
  check(in(p.pulse_bpm, 0.0, 240.0), "pulse_bpm must be in [0, 240] (0: no pulse; default 72)");
  check(in(p.pulse_systolic_mmHg, 40.0, 300.0), "pulse_systolic_mmHg must be in [40, 300]");
  check(in(p.pulse_diastolic_mmHg, 20.0, 200.0) && p.pulse_diastolic_mmHg < p.pulse_systolic_mmHg,
        "pulse_diastolic_mmHg must be in [20, 200] and below pulse_systolic_mmHg");
  check(in(p.pulse_vessel_mm, 1.0, 40.0), "pulse_vessel_mm must be in [1, 40] mm");
  check(in(p.pad_mm, 2.0, 40.0), "pad_mm must be in [2, 40] mm");
  check(in(p.organ_reach_mm, 0.0, 60.0), "organ_reach_mm must be in [0, 60] mm");
  check(in(p.organ_k1, 0.0, 5.0), "organ_k1 must be in [0, 5] N/mm");
  check(in(p.organ_k3, 0.0, 0.1), "organ_k3 must be in [0, 0.1] N/mm^3");
  check(in(p.organ_fmax, 0.0, 20.0), "organ_fmax must be in [0, 20] N");
}

// The layers' parameters by name; false for a name that is not one of them.
bool set_layer_param(ForceParams& p, std::string_view name, double value) {
  double* const fields[] = {&p.pulse_bpm,
                            &p.pulse_systolic_mmHg,
                            &p.pulse_diastolic_mmHg,
                            &p.pulse_vessel_mm,
                            &p.pad_mm,
                            &p.organ_reach_mm,
                            &p.organ_k1,
                            &p.organ_k3,
                            &p.organ_fmax};
  const char* const names[] = {"pulse_bpm",
                               "pulse_systolic_mmHg",
                               "pulse_diastolic_mmHg",
                               "pulse_vessel_mm",
                               "pad_mm",
                               "organ_reach_mm",
                               "organ_k1",
                               "organ_k3",
                               "organ_fmax"};
  for (std::size_t i = 0; i < std::size(names); ++i) {
    if (name == names[i]) {
      *fields[i] = value;
      return true;
    }
  }
  return false;
}

}  // namespace

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
  validate_layers(p, check, in);
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
  } else if (!set_layer_param(p, name, value)) {
    throw UsageError("unknown force parameter '" + std::string(name) +
                     "' (known: c, k, bone_fmax, bone_flip, bone_enabled, grad_epsilon, "
                     "direction_epsilon, bone_mode, bone_k, model, mu, skin_fmax, bone_fade_mm, "
                     "bone_reach_mm, bone_along_normal, pulse_bpm, pulse_systolic_mmHg, "
                     "pulse_diastolic_mmHg, pulse_vessel_mm, pad_mm, organ_reach_mm, organ_k1, "
                     "organ_k3, organ_fmax)");
  }
  validate(p);
  params = p;
}

}  // namespace palp
