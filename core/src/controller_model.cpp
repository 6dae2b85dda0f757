#include "hexa/core/controller_model.hpp"

namespace hexa {

ControllerModel ControllerModel::FromRig(const RigParams& rig, const LegControllerParams& params) {
  ControllerModel m;
  m.geometry = rig.geometry;
  m.platform = rig.platform;
  for (LegControllerModel& leg : m.legs) {
    leg.model = NominalLegModel::FromRig(rig);
    leg.params = params;
    leg.potentiometer = PotentiometerCalibrationParams{};
  }
  return m;
}

RigParams ControllerModel::SupervisorRig(const RigParams& rig) const {
  RigParams r = rig;
  r.geometry = geometry;
  r.platform = platform;
  return r;
}

}  // namespace hexa
