#pragma once

#include <memory>
#include <vector>

#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/registration/registrar.h"
#include "fluoro_tracker/sim/trial_simulator.h"

namespace fluoro_tracker {
namespace test_support {

// A simulated trial's implants as the registrar's bones: the femoral component (bone 0) and the
// tibial tray (bone 1), image weight 1.
inline std::vector<registration::BoneModel> simulatedKneeBones(const sim::TrialSimulator& sim) {
  return {
      {"femur", std::make_shared<imaging::SilhouetteModel>(sim.implants().femoral_component), 1.0},
      {"tibia", std::make_shared<imaging::SilhouetteModel>(sim.implants().tibial_tray), 1.0}};
}

// A registrar for a simulated trial's knee: the femoral component (bone 0) and tibial tray
// (bone 1), joined by the knee (on the trial's side) with contact of the femoral component on the
// insert and the default ligament bounds (what the automatic search needs to place one bone from
// the other).
inline std::shared_ptr<const registration::Registrar> simulatedKneeRegistrar(
    const sim::TrialSimulator& sim,
    const registration::RegistrationSettings& settings = registration::RegistrationSettings(),
    const constraints::ContactSettings& contact = constraints::ContactSettings()) {
  registration::JointModel knee;
  knee.name = "knee";
  knee.parent = 0;
  knee.child = 1;
  knee.side = sim.settings().side;
  knee.contact = std::make_shared<constraints::ArticularContact>(
      sim.implants().femoral_component, sim.implants().tibial_insert, contact);
  return std::make_shared<registration::Registrar>(simulatedKneeBones(sim), settings,
                                                   std::vector<registration::JointModel>{knee});
}

}  // namespace test_support
}  // namespace fluoro_tracker
