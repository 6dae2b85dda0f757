// Rig overlays (config/src/rig_overlay.cpp, proto/rig_overlay.proto): parsing, merging in
// order, per-leg controller configurations, round trip through the validator, and every
// kind of defect reported with the overlay's file, line, field, value and limit.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "hexa/config/rig_config.hpp"

namespace {

using hexa::config::ConfigResult;
using hexa::config::LegOverride;
using hexa::config::RigOverlay;
using hexa::config::SystemConfig;

const std::string kTmpDir = HEXA_CONFIG_TEST_TMP_DIR;

SystemConfig Reference() {
  return hexa::config::LoadSystemConfigOrThrow(hexa::config::DefaultRigFile());
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = kTmpDir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// An overlay as hexa_identify writes one: leg 2 both directions, leg 5 one value.
RigOverlay Identified() {
  RigOverlay o;
  o.rig_name = "HexaTaar-R";
  o.provenance.method = "test";
  o.provenance.date = "2026-01-01T00:00:00Z";
  o.provenance.source_recording = "none.mcap";
  LegOverride& l2 = o.leg[1];
  l2.friction_extend.stribeck_velocity_m_s = 0.61;
  l2.friction_extend.viscous_n_s_m = 40.1;
  l2.friction_extend.static_n = 101.5;
  l2.friction_extend.coulomb_n = 58.25;
  l2.friction_retract.coulomb_n = 93.0;
  l2.friction_retract.static_n = 110.0;
  l2.polytropic_extend.inflow = 1.5;
  l2.polytropic_extend.outflow = 1.15;
  l2.polytropic_extend.volume = 1.29;
  l2.polytropic_retract.volume = 1.8;
  o.leg[4].gravity_load_n = 14.0;
  return o;
}

std::string OverlayText(const std::string& legs) {
  return "rig_name: \"HexaTaar-R\"\n"
         "provenance { method: \"hand\" date: \"2026-01-01\" }\n" +
         legs;
}

ConfigResult Apply(const std::string& text, const std::string& name = "o.textproto") {
  const auto parsed = hexa::config::ParseRigOverlay(text, name);
  if (!parsed.ok) {
    ConfigResult r;
    r.error = parsed.error;
    r.issues = parsed.issues;
    return r;
  }
  return hexa::config::ApplyRigOverlay(Reference(), parsed.overlay, text);
}

TEST(RigOverlay, RoundTripsThroughTheValidator) {
  const RigOverlay o = Identified();
  const std::string text = hexa::config::ToTextFormat(o);
  const auto parsed = hexa::config::ParseRigOverlay(text, "identified.textproto");
  ASSERT_TRUE(parsed.ok) << parsed.error;
  for (std::size_t i = 0; i < 6; ++i) {
    const LegOverride& a = o.leg[i];
    const LegOverride& b = parsed.overlay.leg[i];
    EXPECT_EQ(a.empty(), b.empty()) << "leg " << i + 1;
    EXPECT_EQ(a.friction_extend.coulomb_n, b.friction_extend.coulomb_n);
    EXPECT_EQ(a.friction_extend.stribeck_velocity_m_s, b.friction_extend.stribeck_velocity_m_s);
    EXPECT_EQ(a.friction_retract.static_n, b.friction_retract.static_n);
    EXPECT_EQ(a.friction_retract.viscous_n_s_m, b.friction_retract.viscous_n_s_m);  // both absent
    EXPECT_EQ(a.polytropic_extend.inflow, b.polytropic_extend.inflow);
    EXPECT_EQ(a.polytropic_retract.volume, b.polytropic_retract.volume);
    EXPECT_EQ(a.gravity_load_n, b.gravity_load_n);
  }
  EXPECT_EQ(parsed.overlay.provenance.source_recording, "none.mcap");
  const ConfigResult applied = hexa::config::ApplyRigOverlay(Reference(), parsed.overlay, text);
  ASSERT_TRUE(applied.ok) << applied.error;
  // And back to text: the same file.
  EXPECT_EQ(hexa::config::ToTextFormat(parsed.overlay), text);
}

TEST(RigOverlay, ControllersDifferPerLegAndThePlantRigIsUntouched) {
  const SystemConfig base = Reference();
  const ConfigResult r = hexa::config::ApplyRigOverlay(base, Identified());
  ASSERT_TRUE(r.ok) << r.error;
  const SystemConfig& c = r.config;
  // The plant's rig (what the plant simulates) is the rig file's.
  EXPECT_EQ(c.rig.friction.extend.coulomb_n, base.rig.friction.extend.coulomb_n);
  EXPECT_EQ(c.rig.polytropic.retract.volume, base.rig.polytropic.retract.volume);
  const auto leg1 = hexa::config::MakeLegControllerConfig(c, 1, hexa::LegControllerKind::kBsSmc);
  const auto leg2 = hexa::config::MakeLegControllerConfig(c, 2, hexa::LegControllerKind::kBsSmc);
  const auto leg5 = hexa::config::MakeLegControllerConfig(c, 5, hexa::LegControllerKind::kBsSmc);
  EXPECT_EQ(leg1.model.friction.extend.coulomb_n, base.rig.friction.extend.coulomb_n);
  EXPECT_EQ(leg2.model.friction.extend.coulomb_n, 58.25);
  EXPECT_EQ(leg2.model.friction.extend.stribeck_velocity_m_s, 0.61);
  EXPECT_EQ(leg2.model.friction.retract.coulomb_n, 93.0);
  // Fields the overlay does not write keep the rig file's values.
  EXPECT_EQ(leg2.model.friction.retract.viscous_n_s_m, base.rig.friction.retract.viscous_n_s_m);
  EXPECT_EQ(leg2.model.polytropic.extend.inflow, 1.5);
  EXPECT_EQ(leg2.model.polytropic.retract.inflow, base.rig.polytropic.retract.inflow);
  EXPECT_EQ(leg2.model.polytropic.retract.volume, 1.8);
  EXPECT_EQ(leg5.params.bssmc.gravity_load_n, 14.0);
  EXPECT_EQ(leg1.params.bssmc.gravity_load_n, base.leg_controller.bssmc.gravity_load_n);
  // Every configuration is one the controller accepts.
  EXPECT_NO_THROW(leg2.Validate());
}

TEST(RigOverlay, LaterOverlaysWinFieldByField) {
  const std::string first = WriteTemp(
      "first.textproto",
      OverlayText("leg { leg_id: 3 friction { extend { coulomb_n: 55 static_n: 90 } } }\n"));
  const std::string second = WriteTemp(
      "second.textproto", OverlayText("leg { leg_id: 3 friction { extend { coulomb_n: 60 } } }\n"));
  const ConfigResult r =
      hexa::config::LoadSystemConfig(hexa::config::DefaultRigFile(), {first, second});
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.config.overlays.size(), 2u);
  const auto leg3 = hexa::config::MakeLegControllerConfig(r.config, 3, hexa::LegControllerKind::kPi);
  EXPECT_EQ(leg3.model.friction.extend.coulomb_n, 60.0);  // second
  EXPECT_EQ(leg3.model.friction.extend.static_n, 90.0);   // first, not overwritten
}

TEST(RigOverlay, CalibrationReachesTheSupervisorAndTheLegController) {
  const SystemConfig base = Reference();
  const auto& a = base.rig.geometry.p_BA_B[3];
  const std::string text = OverlayText(
      "leg { leg_id: 4 p_BA_B_m { x: " + std::to_string(a.x() + 0.001) + " y: " +
      std::to_string(a.y()) + " z: " + std::to_string(a.z()) +
      " } potentiometer_offset_m: 0.0008 potentiometer_gain: 1.004 }\n");
  const ConfigResult r = Apply(text);
  ASSERT_TRUE(r.ok) << r.error;
  const hexa::RigParams sup = hexa::config::MakeSupervisorRig(r.config);
  EXPECT_NEAR(sup.geometry.p_BA_B[3].x(), a.x() + 0.001, 1e-6);
  EXPECT_EQ(sup.geometry.p_BA_B[2], base.rig.geometry.p_BA_B[2]);
  EXPECT_EQ(r.config.rig.geometry.p_BA_B[3], a);  // the plant's nominal is untouched
  const auto leg4 = hexa::config::MakeLegControllerConfig(r.config, 4, hexa::LegControllerKind::kBsSmc);
  EXPECT_EQ(leg4.potentiometer.offset_m, 0.0008);
  EXPECT_EQ(leg4.potentiometer.gain, 1.004);
  const auto leg1 = hexa::config::MakeLegControllerConfig(r.config, 1, hexa::LegControllerKind::kBsSmc);
  EXPECT_EQ(leg1.potentiometer.gain, 1.0);
}

// The platform block (with its payload, as hexa_calibrate estimates it) reaches the supervisor's
// rig (feed-forward) and each leg's coupling row W; the plant's rig keeps the rig file's.
TEST(RigOverlay, PlatformMassReachesTheSupervisorAndTheCoupledLegs) {
  SystemConfig base = Reference();
  base.leg_controller.coupled.enabled = true;
  const auto parsed = hexa::config::ParseRigOverlay(
      OverlayText("platform { mass_kg: 7.2 inertia_diag_kg_m2 { x: 0.1128 y: 0.1128 z: 0.228 } }\n"), "p.textproto");
  ASSERT_TRUE(parsed.ok) << parsed.error;
  const ConfigResult r = hexa::config::ApplyRigOverlay(base, parsed.overlay);
  ASSERT_TRUE(r.ok) << r.error;
  const hexa::RigParams sup = hexa::config::MakeSupervisorRig(r.config);
  EXPECT_EQ(sup.platform.mass_kg, 7.2);
  EXPECT_EQ(sup.platform.inertia_diag_kg_m2.z(), 0.228);
  EXPECT_EQ(r.config.rig.platform.mass_kg, 6.0);  // the plant's rig is untouched
  const auto with = hexa::config::MakeLegControllerConfig(r.config, 3, hexa::LegControllerKind::kBsSmc);
  const auto without = hexa::config::MakeLegControllerConfig(base, 3, hexa::LegControllerKind::kBsSmc);
  // W = M_ls / M: a heavier platform, a larger inertia seen by the leg.
  EXPECT_GT(with.coupling_row[2], without.coupling_row[2]);
  // Written and read back: the same overlay.
  const auto again = hexa::config::ParseRigOverlay(hexa::config::ToTextFormat(parsed.overlay), "again.textproto");
  ASSERT_TRUE(again.ok) << again.error;
  EXPECT_EQ(again.overlay.platform.mass_kg, 7.2);
  EXPECT_EQ(*again.overlay.platform.inertia_diag_kg_m2, parsed.overlay.platform.inertia_diag_kg_m2.value());
  EXPECT_NE(hexa::config::Summary(r.config).find("platform 7.2 kg"), std::string::npos);
}

struct Defect {
  const char* name;
  std::string legs;        // the leg blocks of the overlay (line 3 on)
  int line;                // expected line of the first issue
  const char* field;       // expected field path
  const char* message;     // substring of the message
};

TEST(RigOverlay, DefectsNameFileLineFieldValueAndLimit) {
  const std::vector<Defect> defects = {
      {"negative coulomb", "leg {\n leg_id: 2\n friction { extend { coulomb_n: -3 } } }\n", 5,
       // The rig file's rule for the parameter (core param_checks, one rule per parameter).
       "leg[leg_id=2].friction.extend.coulomb_n", "must be positive"},
      {"static below coulomb", "leg { leg_id: 1\n friction { retract {\n static_n: 10 } } }\n", 5,
       "leg[leg_id=1].friction.retract.static_n", "at least the Coulomb friction"},
      {"polytropic above 2", "leg { leg_id: 6\n polytropic { extend { volume: 2.5 } } }\n", 4,
       "leg[leg_id=6].polytropic.extend.volume", "out of range"},
      {"leg id out of range", "leg { leg_id: 7 gravity_load_n: 3 }\n", 3, "leg[0].leg_id",
       "leg id out of range"},
      {"leg twice", "leg { leg_id: 2 gravity_load_n: 3 }\nleg { leg_id: 2 gravity_load_n: 4 }\n", 4,
       "leg[1].leg_id", "two blocks"},
      {"no leg id", "leg { gravity_load_n: 3 }\n", 3, "leg[0].leg_id", "without leg_id"},
      {"partial vector", "leg { leg_id: 1\n p_PB_P_m { x: 0.2 } }\n", 4, "leg[leg_id=1].p_PB_P_m",
       "all three coordinates"},
      {"joint moved 5 cm", "leg { leg_id: 1\n p_PB_P_m { x: 0.3 y: 0.0 z: 0.0 } }\n", 4,
       "leg[leg_id=1].p_PB_P_m", "implausibly far"},
      {"gain", "leg { leg_id: 3\n potentiometer_gain: 1.5 }\n", 4, "leg[leg_id=3].potentiometer_gain",
       "out of range"},
      {"empty leg", "leg { leg_id: 3 }\n", 3, "leg[leg_id=3]", "changes nothing"},
      {"nan", "leg { leg_id: 3\n effective_mass_kg: nan }\n", 4, "leg[leg_id=3].effective_mass_kg", "finite"},
      {"unknown field", "leg { leg_id: 3\n coulomb_n: 4 }\n", 4, "leg.coulomb_n", "unknown field"},
      {"discharge", "leg { leg_id: 3\n discharge_coefficient: 1.2 }\n", 4,
       "leg[leg_id=3].discharge_coefficient", "out of range"},
      // The platform with its payload (whole platform): 0.5-2 x the rig file's 6 kg.
      {"platform mass", "platform {\n mass_kg: 60 }\n", 4, "platform.mass_kg", "implausibly far"},
      {"platform mass zero", "platform {\n mass_kg: 0 }\n", 4, "platform.mass_kg", "implausibly far"},
      {"platform inertia", "platform { mass_kg: 7.2\n inertia_diag_kg_m2 { x: 0.1 y: 0.1 z: 1.9 } }\n", 4,
       "platform.inertia_diag_kg_m2.z", "implausibly far"},
      {"platform partial inertia", "platform {\n inertia_diag_kg_m2 { x: 0.1 } }\n", 4,
       "platform.inertia_diag_kg_m2", "all three"},
      {"platform empty", "platform { }\n", 3, "platform", "changes nothing"},
      {"platform nan", "platform {\n mass_kg: nan }\n", 4, "platform.mass_kg", "finite"},
  };
  for (const Defect& d : defects) {
    const ConfigResult r = Apply(OverlayText(d.legs), "bad.textproto");
    ASSERT_FALSE(r.ok) << d.name;
    ASSERT_FALSE(r.issues.empty()) << d.name;
    const auto& i = r.issues.front();
    EXPECT_EQ(i.file, "bad.textproto") << d.name;
    EXPECT_EQ(i.line, d.line) << d.name << ": " << i.ToString();
    EXPECT_EQ(i.field, d.field) << d.name << ": " << i.ToString();
    EXPECT_NE(i.message.find(d.message), std::string::npos) << d.name << ": " << i.ToString();
    EXPECT_FALSE(i.limit.empty()) << d.name << ": " << i.ToString();
  }
}

TEST(RigOverlay, RequiresRigNameAndProvenanceAndTheRightRig) {
  auto r = Apply("leg { leg_id: 1 gravity_load_n: 3 }\n");
  ASSERT_FALSE(r.ok);
  EXPECT_NE(r.error.find("rig_name"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("provenance"), std::string::npos) << r.error;
  r = Apply("rig_name: \"Other\"\nprovenance { method: \"m\" date: \"d\" }\nleg { leg_id: 1 gravity_load_n: 3 }\n");
  ASSERT_FALSE(r.ok);
  ASSERT_EQ(r.issues.size(), 1u);
  EXPECT_EQ(r.issues[0].field, "rig_name");
  EXPECT_EQ(r.issues[0].line, 1);
  EXPECT_NE(r.error.find("different rig"), std::string::npos) << r.error;
  r = Apply("rig_name: \"HexaTaar-R\"\nprovenance { date: \"d\" }\n");
  ASSERT_FALSE(r.ok);
  EXPECT_EQ(r.issues[0].field, "provenance.method");
}

TEST(RigOverlay, MissingFileIsReported) {
  const ConfigResult r =
      hexa::config::LoadSystemConfig(hexa::config::DefaultRigFile(), {kTmpDir + "/does_not_exist.textproto"});
  ASSERT_FALSE(r.ok);
  EXPECT_NE(r.error.find("does_not_exist.textproto"), std::string::npos);
  EXPECT_NE(r.error.find("cannot open rig overlay"), std::string::npos);
}

}  // namespace

namespace {

TEST(RigOverlay, ShippedExampleLoads) {
  const std::string example = std::string(HEXA_CONFIG_TEST_DIR) + "/overlays/example.textproto";
  const ConfigResult r = hexa::config::LoadSystemConfig(hexa::config::DefaultRigFile(), {example});
  ASSERT_TRUE(r.ok) << r.error;
  const auto leg2 = hexa::config::MakeLegControllerConfig(r.config, 2, hexa::LegControllerKind::kBsSmc);
  EXPECT_EQ(leg2.model.friction.extend.coulomb_n, 59.0);
  EXPECT_EQ(leg2.model.polytropic.extend.volume, 1.29);
  const auto leg5 = hexa::config::MakeLegControllerConfig(r.config, 5, hexa::LegControllerKind::kBsSmc);
  EXPECT_EQ(leg5.params.bssmc.gravity_load_n, 15.5);
  EXPECT_NEAR(hexa::config::MakeSupervisorRig(r.config).geometry.p_BA_B[2].x(), -0.118207050164, 1e-15);
  EXPECT_NE(hexa::config::Summary(r.config).find("example.textproto (3 legs"), std::string::npos);
}

}  // namespace
