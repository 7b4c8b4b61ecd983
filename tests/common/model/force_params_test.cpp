// The force model's parameters (force_params.cpp): defaults per tool, setting by name, and the
// ranges that refuse an absurd force.
#include <gtest/gtest.h>

#include <cmath>

#include "base/errors.hpp"
#include "model/force_model.hpp"

namespace palp {
namespace {

TEST(ForceParams, DefaultsSettingByNameAndValidation) {
  EXPECT_EQ(default_params(ToolKind::Finger).c, 2.0);
  EXPECT_EQ(default_params(ToolKind::Finger).k, 0.4);
  EXPECT_EQ(default_params(ToolKind::TwoFinger).c, 2.0);
  EXPECT_EQ(default_params(ToolKind::Probe).c, 0.4);
  EXPECT_EQ(default_params(ToolKind::Probe).k, 0.3);
  EXPECT_EQ(default_params(ToolKind::Finger).bone_fmax, 40.0);
  EXPECT_EQ(default_params(ToolKind::Finger).bone_flip, 4.0);
  ForceParams p;
  set_param(p, "c", 1.5);
  set_param(p, "k", 0.2);
  EXPECT_EQ(p.c, 1.5);
  EXPECT_EQ(p.k, 0.2);
  EXPECT_THROW(set_param(p, "nu", 1.0), UsageError);  // unknown
  EXPECT_THROW(set_param(p, "mu", 2.5), UsageError);  // out of range
  EXPECT_THROW(set_param(p, "model", 2.0), UsageError);
  EXPECT_THROW(set_param(p, "skin_fmax", 0.5), UsageError);
  EXPECT_THROW(set_param(p, "bone_fade_mm", 31.0), UsageError);
  set_param(p, "model", 1.0);
  EXPECT_EQ(p.model, ModelKind::Palp);
  EXPECT_THROW(set_param(p, "c", -1.0), UsageError);
  EXPECT_THROW(set_param(p, "k", std::nan("")), UsageError);
  EXPECT_THROW(set_param(p, "grad_epsilon", 0.0), UsageError);
  EXPECT_THROW(set_param(p, "bone_enabled", 0.5), UsageError);
  // Physical ranges: a parameter that would shape an absurd force is refused.
  EXPECT_THROW(set_param(p, "k", 50.0), UsageError);
  EXPECT_THROW(set_param(p, "c", 1e6), UsageError);
  EXPECT_THROW(set_param(p, "bone_fmax", 400.0), UsageError);
  EXPECT_THROW(set_param(p, "bone_k", 1e4), UsageError);
  EXPECT_NO_THROW(set_param(p, "bone_fmax", 60.0));
  EXPECT_EQ(p.c, 1.5);  // a refused override leaves the parameters as they were
}

TEST(ForceParams, NamesOfModesAndModels) {
  EXPECT_EQ(parse_bone_mode("printed"), BoneMode::Printed);
  EXPECT_EQ(parse_bone_mode("robust"), BoneMode::Robust);
  EXPECT_THROW(parse_bone_mode("soft"), UsageError);
  EXPECT_EQ(parse_model_kind(to_string(ModelKind::Palp)), ModelKind::Palp);
  EXPECT_EQ(parse_model_kind(to_string(ModelKind::Paper)), ModelKind::Paper);
  EXPECT_EQ(model_params(ModelKind::Paper, ToolKind::Finger).c, default_params(ToolKind::Finger).c);
  EXPECT_EQ(model_params(ModelKind::Palp, ToolKind::Finger).model, ModelKind::Palp);
}

}  // namespace
}  // namespace palp
