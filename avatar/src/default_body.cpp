// Mimic's built-in adult body as authored: about 1.67 m, average proportions, 90-odd primitives
// (the built-in body is this with the fitted overrides of body_overrides.h applied).
//
// Authored in world coordinates of the zero posture (T-pose, root 0.89 m above the floor) and
// converted to joint frames, which are parallel to the world there. Left-side primitives are
// mirrored to the right. Muscles (deltoid, biceps, triceps, forearm, pectoral, gluteal,
// quadriceps, hamstring, calf) deform with their reference DOF.
#include <cmath>
#include <initializer_list>

#include <glm/gtx/norm.hpp>

#include "mimic/avatar/body_model.h"

namespace mimic::avatar {

namespace {

constexpr float kRootHeight_m = 0.89f;

struct Author {
  BodyModel model;
  rig::Skeleton skeleton;
  std::vector<rig::RigidTransform> world;

  explicit Author(rig::SkeletonDesc desc) : skeleton(*rig::Skeleton::build(desc)) {
    model.skeleton = std::move(desc);
    rig::Pose p = skeleton.zero_pose();
    p.root_position_m = {0, kRootHeight_m, 0};
    world.resize(skeleton.joint_count());
    rig::forward_kinematics(skeleton, p, world);
  }

  glm::vec3 local(const std::string& joint, glm::vec3 world_point) const {
    return world[skeleton.find_joint(joint)].inverse().apply(world_point);
  }

  Primitive& add(const std::string& name, const std::string& joint, glm::vec3 center_world, glm::vec3 axes,
                 GroupMask groups, float influence = 1.5f, glm::vec3 orientation_deg = glm::vec3(0)) {
    Primitive p;
    p.name = name;
    p.joint = joint;
    p.state.center_m = local(joint, center_world);
    p.state.semi_axes_m = axes;
    p.state.orientation_rad = glm::radians(orientation_deg);
    p.groups = groups;
    p.influence = influence;
    model.primitives.push_back(p);
    return model.primitives.back();
  }

  Primitive& hard(const std::string& name, const std::string& joint, glm::vec3 center_world, glm::vec3 axes,
                  GroupMask groups) {
    Primitive& p = add(name, joint, center_world, axes, groups);
    p.kind = PrimitiveKind::ellipsoid;
    return p;
  }

  Primitive& rigid(const std::string& name, const std::string& joint, RigidPart part, glm::vec3 center_world,
                   glm::vec3 axes, float influence = 1.5f, glm::vec3 orientation_deg = glm::vec3(0)) {
    Primitive& p = add(name, joint, center_world, axes, 0, influence, orientation_deg);
    p.part = part;
    return p;
  }

  // Deformation given as world-space states of the zero posture, like the primitive itself.
  void muscle(Primitive& p, const std::string& dof, glm::vec3 min_axes, glm::vec3 min_center_world, glm::vec3 max_axes,
              glm::vec3 max_center_world, Falloff f = Falloff::linear) {
    Deformation d;
    d.dof = dof;
    d.falloff = f;
    d.at_min = p.state;
    d.at_min.semi_axes_m = min_axes;
    d.at_min.center_m = local(p.joint, min_center_world);
    d.at_max = p.state;
    d.at_max.semi_axes_m = max_axes;
    d.at_max.center_m = local(p.joint, max_center_world);
    p.deformation = d;
  }
};

GroupMask G(std::initializer_list<Group> gs) {
  GroupMask m = 0;
  for (Group g : gs) m |= group_bit(g);
  return m;
}

// The pelvis, hips and gluteals.
void add_pelvis_and_hips(Author& a) {
  using enum Group;
  // --- pelvis and hips -------------------------------------------------------------------
  a.add("pelvis_core", "pelvis", {0, 0.905f, 0.025f}, {0.135f, 0.085f, 0.095f}, G({hip, lower_torso}));
  a.add("lower_abdomen", "pelvis", {0, 0.95f, 0.07f}, {0.11f, 0.065f, 0.07f}, G({hip, lower_torso}));
  a.add("pubis", "pelvis", {0, 0.835f, 0.045f}, {0.06f, 0.045f, 0.055f}, G({hip}));
  {
    Primitive& g = a.add("l_gluteal", "pelvis", {0.072f, 0.855f, -0.045f}, {0.08f, 0.09f, 0.07f},
                         G({hip, lower_torso, left_upper_leg}));
    // Extension (hip_flexion < 0) bunches the gluteus, flexion stretches it flat.
    a.muscle(g, "l_hip_flexion", {0.08f, 0.095f, 0.078f}, {0.072f, 0.86f, -0.05f}, {0.085f, 0.08f, 0.06f},
             {0.075f, 0.85f, -0.04f});
  }
  a.add("l_hip_side", "pelvis", {0.125f, 0.875f, 0.01f}, {0.055f, 0.075f, 0.075f},
        G({hip, lower_torso, left_upper_leg}));
}

// Abdomen, lower back, waist.
void add_abdomen_and_lower_back(Author& a) {
  using enum Group;
  // --- abdomen and lower back ---------------------------------------------------------------
  a.add("abdomen", "spine_lower", {0, 1.0f, 0.06f}, {0.115f, 0.085f, 0.08f}, G({lower_torso}));
  a.add("lower_back", "spine_lower", {0, 1.0f, -0.005f}, {0.105f, 0.085f, 0.05f}, G({lower_torso}));
  a.add("l_oblique", "spine_lower", {0.085f, 0.98f, 0.025f}, {0.05f, 0.08f, 0.065f}, G({lower_torso}));
  a.add("waist", "spine_mid", {0, 1.095f, 0.05f}, {0.11f, 0.07f, 0.085f}, G({lower_torso, upper_torso}));
  a.add("l_lat_lower", "spine_mid", {0.07f, 1.115f, -0.005f}, {0.055f, 0.075f, 0.045f}, G({lower_torso, upper_torso}));
}

// Chest, upper back, the left shoulder girdle.
void add_chest_back_shoulders(Author& a) {
  using enum Group;
  // --- chest, back, shoulders -----------------------------------------------------------------
  a.add("rib_cage", "spine_mid", {0, 1.19f, 0.05f}, {0.125f, 0.11f, 0.095f}, G({upper_torso}));
  {
    Primitive& p = a.add("l_pectoral", "spine_upper", {0.065f, 1.265f, 0.1f}, {0.075f, 0.06f, 0.04f},
                         G({upper_torso, left_shoulder}));
    // Horizontal flexion bunches the pectoral; pulling the arm back flattens it.
    a.muscle(p, "l_shoulder_flexion", {0.08f, 0.055f, 0.03f}, {0.068f, 1.265f, 0.095f}, {0.065f, 0.065f, 0.05f},
             {0.06f, 1.265f, 0.105f});
  }
  a.add("upper_chest", "spine_upper", {0, 1.31f, 0.05f}, {0.12f, 0.065f, 0.075f}, G({upper_torso}));
  a.add("upper_back", "spine_upper", {0, 1.28f, -0.01f}, {0.115f, 0.09f, 0.05f}, G({upper_torso}));
  a.add("l_scapula", "spine_upper", {0.08f, 1.3f, -0.03f}, {0.06f, 0.07f, 0.035f}, G({upper_torso, left_shoulder}));
  a.add("l_lat", "spine_upper", {0.11f, 1.24f, -0.015f}, {0.05f, 0.07f, 0.05f}, G({upper_torso, left_shoulder}));
  a.add("l_trapezius", "spine_upper", {0.07f, 1.37f, -0.01f}, {0.08f, 0.035f, 0.05f}, G({upper_torso, left_shoulder}),
        1.5f, {0, 0, -18});
  a.add("l_clavicle_ridge", "l_clavicle", {0.1f, 1.355f, 0.035f}, {0.07f, 0.025f, 0.03f},
        G({upper_torso, left_shoulder}));
}

// The neck, from its base to the skull.
void add_neck(Author& a) {
  using enum Group;
  // --- neck -------------------------------------------------------------------------------------
  a.add("neck_base", "neck", {0, 1.4f, 0.0f}, {0.07f, 0.05f, 0.06f}, G({upper_torso}));
  a.add("neck_mid", "neck", {0, 1.45f, 0.01f}, {0.055f, 0.05f, 0.055f}, G({upper_torso}));
  a.add("neck_top", "neck_upper", {0, 1.5f, 0.015f}, {0.05f, 0.04f, 0.05f}, G({upper_torso}));
}

// The left arm, shoulder to wrist, with its muscles.
void add_left_arm(Author& a) {
  using enum Group;
  // --- arm (left; mirrored below) -------------------------------------------------------------
  a.add("l_shoulder_cap", "l_shoulder", {0.17f, 1.36f, 0.0f}, {0.05f, 0.045f, 0.05f},
        G({left_shoulder, left_upper_arm}));
  {
    Primitive& p = a.add("l_deltoid", "l_shoulder", {0.2f, 1.345f, 0.0f}, {0.075f, 0.055f, 0.055f},
                         G({left_shoulder, left_upper_arm}));
    // Raising the arm shortens and thickens the deltoid; lowering it stretches it.
    a.muscle(p, "l_shoulder_abduction", {0.08f, 0.05f, 0.05f}, {0.205f, 1.343f, 0.0f}, {0.06f, 0.066f, 0.062f},
             {0.19f, 1.35f, 0.0f});
  }
  a.add("l_armpit", "l_shoulder", {0.16f, 1.305f, 0.0f}, {0.04f, 0.035f, 0.045f}, G({left_shoulder, left_upper_arm}));
  a.add("l_humerus", "l_shoulder", {0.28f, 1.341f, 0.0f}, {0.11f, 0.031f, 0.031f}, G({left_upper_arm}));
  {
    Primitive& p =
        a.add("l_biceps", "l_shoulder", {0.29f, 1.341f, 0.018f}, {0.08f, 0.029f, 0.028f}, G({left_upper_arm}));
    a.muscle(p, "l_elbow_flexion", {0.082f, 0.028f, 0.027f}, {0.29f, 1.341f, 0.018f}, {0.06f, 0.035f, 0.041f},
             {0.28f, 1.341f, 0.03f}, Falloff::parabolic);
  }
  {
    Primitive& p =
        a.add("l_triceps", "l_shoulder", {0.28f, 1.345f, -0.015f}, {0.09f, 0.031f, 0.029f}, G({left_upper_arm}));
    a.muscle(p, "l_elbow_flexion", {0.085f, 0.033f, 0.032f}, {0.28f, 1.345f, -0.017f}, {0.1f, 0.028f, 0.025f},
             {0.285f, 1.345f, -0.013f});
  }
  a.add("l_elbow", "l_elbow", {0.4f, 1.341f, 0.0f}, {0.035f, 0.031f, 0.031f}, G({left_upper_arm, left_lower_arm}));
  {
    Primitive& p =
        a.add("l_forearm_muscles", "l_elbow", {0.47f, 1.338f, 0.005f}, {0.075f, 0.034f, 0.037f}, G({left_lower_arm}));
    a.muscle(p, "l_elbow_flexion", {0.076f, 0.033f, 0.036f}, {0.47f, 1.338f, 0.005f}, {0.068f, 0.037f, 0.041f},
             {0.465f, 1.338f, 0.008f});
  }
  a.add("l_forearm_lower", "l_elbow", {0.56f, 1.341f, 0.0f}, {0.065f, 0.02f, 0.029f}, G({left_lower_arm}));
  a.add("l_wrist_pad", "l_wrist", {0.622f, 1.341f, 0.0f}, {0.025f, 0.017f, 0.026f}, G({left_lower_arm}));
}

// A finger or thumb as a chain of phalanges from its base joint (world, zero posture), each
// an ellipsoid along its bone: length, radius, and the bone's direction as flexion towards the
// palm (−Y for a hand lying along +X, palm down; each joint's flexion adds to the last) and
// spread towards the thumb (+Z). Ellipsoids overlap their neighbours by kKnuckle_m at each joint.
struct Phalanx {
  float length_m, radius_m, flexion_deg;
};
void finger(Author& a, const std::string& name, RigidPart part, glm::vec3 base_world, float spread_deg,
            std::initializer_list<Phalanx> bones, float influence = 1.3f) {
  constexpr float kKnuckle_m = 0.004f;
  float flex = 0;
  int k = 0;
  for (const Phalanx& b : bones) {
    flex += b.flexion_deg;
    const float t = glm::radians(flex), s = glm::radians(spread_deg);
    const glm::vec3 dir(std::cos(t) * std::cos(s), -std::sin(t), std::cos(t) * std::sin(s));
    // Rz·Ry carries the primitive's x onto dir: Ry by −asin(dir.z), then Rz by the pitch.
    const glm::vec3 orientation_deg(0, glm::degrees(-std::asin(dir.z)), glm::degrees(std::atan2(dir.y, dir.x)));
    a.rigid(name + "_" + std::to_string(++k), "l_wrist", part, base_world + 0.5f * b.length_m * dir,
            {0.5f * b.length_m + kKnuckle_m, b.radius_m, b.radius_m * 1.08f}, influence, orientation_deg);
    base_world += b.length_m * dir;
  }
}

// The left hand, rigid: palm, four fingers and a thumb in a relaxed curl (the skeleton has no
// finger joints). The knuckles lie 9.5 cm beyond the wrist, the middle finger is 9.3 cm long
// (MakeHuman's base mesh: 9.6 and 8.2 cm to its last joint).
void add_left_hand(Author& a) {
  using enum Group;
  // --- hand (rigid) -------------------------------------------------------------------------------
  constexpr RigidPart kHand = RigidPart::left_hand;
  a.rigid("l_palm", "l_wrist", kHand, {0.672f, 1.342f, 0.0f}, {0.05f, 0.014f, 0.04f});
  a.rigid("l_palm_heel", "l_wrist", kHand, {0.652f, 1.332f, -0.004f}, {0.03f, 0.012f, 0.032f});
  a.rigid("l_thenar", "l_wrist", kHand, {0.657f, 1.331f, 0.025f}, {0.03f, 0.012f, 0.016f}, 1.5f, {0, -35, 0});
  a.rigid("l_hand_wrist", "l_wrist", kHand, {0.628f, 1.341f, 0.0f}, {0.022f, 0.018f, 0.027f});
  // Index, middle, ring, little: base (the knuckle), spread, phalanges (length, radius, flexion).
  finger(a, "l_index", kHand, {0.712f, 1.343f, 0.027f}, 6,
         {{0.040f, 0.0076f, 8}, {0.024f, 0.007f, 22}, {0.020f, 0.0064f, 12}});
  finger(a, "l_middle", kHand, {0.716f, 1.343f, 0.009f}, 1,
         {{0.044f, 0.0078f, 12}, {0.028f, 0.0072f, 26}, {0.021f, 0.0065f, 14}});
  finger(a, "l_ring", kHand, {0.712f, 1.342f, -0.009f}, -4,
         {{0.041f, 0.0074f, 15}, {0.027f, 0.0068f, 28}, {0.021f, 0.0062f, 15}});
  finger(a, "l_little", kHand, {0.704f, 1.341f, -0.026f}, -10,
         {{0.032f, 0.0066f, 18}, {0.019f, 0.006f, 30}, {0.018f, 0.0056f, 15}});
  // The thumb from its carpometacarpal joint: forward (+Z), out and a little down.
  finger(a, "l_thumb", kHand, {0.638f, 1.334f, 0.026f}, 42,
         {{0.040f, 0.0105f, 12}, {0.032f, 0.0085f, 14}, {0.027f, 0.0078f, 14}});
}

// The left leg, hip to ankle, with its muscles.
void add_left_leg(Author& a) {
  using enum Group;
  // --- leg (left; mirrored below) --------------------------------------------------------------
  a.add("l_thigh_upper", "l_hip", {0.1f, 0.77f, 0.015f}, {0.085f, 0.1f, 0.085f}, G({left_upper_leg, hip}));
  {
    Primitive& p = a.add("l_quadriceps", "l_hip", {0.11f, 0.62f, 0.035f}, {0.063f, 0.15f, 0.058f}, G({left_upper_leg}));
    a.muscle(p, "l_knee_flexion", {0.064f, 0.148f, 0.06f}, {0.11f, 0.62f, 0.036f}, {0.06f, 0.16f, 0.05f},
             {0.11f, 0.615f, 0.03f});
  }
  {
    Primitive& p = a.add("l_hamstring", "l_hip", {0.11f, 0.62f, -0.03f}, {0.058f, 0.14f, 0.052f}, G({left_upper_leg}));
    a.muscle(p, "l_knee_flexion", {0.058f, 0.142f, 0.051f}, {0.11f, 0.62f, -0.03f}, {0.064f, 0.12f, 0.064f},
             {0.11f, 0.6f, -0.036f}, Falloff::parabolic);
  }
  a.add("l_adductor", "l_hip", {0.07f, 0.7f, 0.0f}, {0.045f, 0.1f, 0.058f}, G({left_upper_leg}));
  a.add("l_femur", "l_hip", {0.11f, 0.58f, 0.0f}, {0.052f, 0.2f, 0.052f}, G({left_upper_leg}));
  a.add("l_knee", "l_knee", {0.11f, 0.455f, 0.01f}, {0.047f, 0.05f, 0.048f}, G({left_upper_leg, left_lower_leg}));
  a.hard("l_kneecap", "l_knee", {0.11f, 0.46f, 0.043f}, {0.025f, 0.03f, 0.015f}, G({left_upper_leg, left_lower_leg}));
  {
    Primitive& p = a.add("l_calf", "l_knee", {0.11f, 0.34f, -0.028f}, {0.05f, 0.09f, 0.05f}, G({left_lower_leg}));
    // Pointing the foot (ankle flexion < 0) contracts the gastrocnemius.
    a.muscle(p, "l_ankle_flexion", {0.055f, 0.076f, 0.058f}, {0.11f, 0.35f, -0.034f}, {0.048f, 0.095f, 0.046f},
             {0.11f, 0.335f, -0.026f});
  }
  a.add("l_shin", "l_knee", {0.11f, 0.3f, 0.01f}, {0.04f, 0.14f, 0.04f}, G({left_lower_leg}));
  a.add("l_lower_calf", "l_knee", {0.11f, 0.2f, -0.01f}, {0.034f, 0.09f, 0.034f}, G({left_lower_leg}));
  a.add("l_ankle", "l_ankle", {0.11f, 0.09f, 0.0f}, {0.03f, 0.045f, 0.034f}, G({left_lower_leg, left_ankle}));
  a.hard("l_malleolus", "l_ankle", {0.11f, 0.075f, 0.0f}, {0.032f, 0.02f, 0.022f}, G({left_ankle}));
}

// The left foot, rigid, bare: heel, arch and ball on a flat sole on the floor (y = 0 in the zero
// posture), five toes ahead of the toe joint (whose vertices bend with it, contour_layout.cpp
// bind_toes). 24.5 cm from heel to big toe, 9.5 cm across the ball (MakeHuman's base mesh).
void add_left_foot(Author& a) {
  using enum Group;
  // --- foot (rigid) -------------------------------------------------------------------------------
  constexpr RigidPart kFoot = RigidPart::left_foot;
  a.rigid("l_heel", "l_ankle", kFoot, {0.11f, 0.036f, -0.018f}, {0.03f, 0.032f, 0.036f});
  a.rigid("l_foot_ankle", "l_ankle", kFoot, {0.11f, 0.07f, 0.0f}, {0.03f, 0.032f, 0.034f});
  a.rigid("l_instep", "l_ankle", kFoot, {0.114f, 0.038f, 0.055f}, {0.034f, 0.026f, 0.06f});
  a.rigid("l_sole", "l_ankle", kFoot, {0.114f, 0.012f, 0.055f}, {0.036f, 0.011f, 0.09f});
  a.rigid("l_foot_ball", "l_ankle", kFoot, {0.116f, 0.017f, 0.118f}, {0.044f, 0.016f, 0.03f});
  // Big toe to little toe: centre, half length, radius.
  a.rigid("l_toe_1", "l_ankle", kFoot, {0.087f, 0.014f, 0.168f}, {0.0115f, 0.011f, 0.024f}, 1.4f, {0, -6, 0});
  a.rigid("l_toe_2", "l_ankle", kFoot, {0.106f, 0.012f, 0.163f}, {0.0085f, 0.0085f, 0.019f}, 1.4f, {0, -3, 0});
  a.rigid("l_toe_3", "l_ankle", kFoot, {0.122f, 0.011f, 0.156f}, {0.008f, 0.008f, 0.017f}, 1.4f);
  a.rigid("l_toe_4", "l_ankle", kFoot, {0.136f, 0.0105f, 0.148f}, {0.0075f, 0.0075f, 0.015f}, 1.4f, {0, 4, 0});
  a.rigid("l_toe_5", "l_ankle", kFoot, {0.149f, 0.01f, 0.138f}, {0.007f, 0.007f, 0.013f}, 1.4f, {0, 8, 0});
}

// The head, rigid, in the head joint's place of MakeHuman's base mesh: skull, brow, eye sockets
// with eyeballs, cheekbones, nose, lips, jaw and chin, ears. Crown 15 cm above the head joint,
// forehead 13.7 cm and nose tip 15 cm in front of it, eyes 6.2 cm apart.
void add_head(Author& a) {
  using enum Group;
  // --- head (rigid) -------------------------------------------------------------------------------
  constexpr RigidPart kHead = RigidPart::head;
  a.rigid("cranium", "head", kHead, {0, 1.58f, 0.038f}, {0.07f, 0.085f, 0.092f});
  a.rigid("forehead", "head", kHead, {0, 1.598f, 0.085f}, {0.058f, 0.04f, 0.045f});
  a.rigid("skull_base", "head", kHead, {0, 1.515f, 0.0f}, {0.05f, 0.04f, 0.045f});
  a.rigid("brow", "head", kHead, {0, 1.568f, 0.108f}, {0.06f, 0.012f, 0.022f}, 1.4f);
  a.rigid("l_eye", "head", kHead, {0.031f, 1.547f, 0.1f}, {0.0115f, 0.0115f, 0.0115f}, 1.2f);
  a.rigid("l_parietal", "head", kHead, {0.042f, 1.548f, 0.012f}, {0.032f, 0.04f, 0.05f});
  a.rigid("midface", "head", kHead, {0, 1.503f, 0.055f}, {0.062f, 0.042f, 0.062f});
  a.rigid("l_cheekbone", "head", kHead, {0.043f, 1.527f, 0.088f}, {0.017f, 0.01f, 0.02f});
  a.rigid("l_cheek", "head", kHead, {0.037f, 1.505f, 0.088f}, {0.026f, 0.025f, 0.024f});
  a.rigid("nose_bridge", "head", kHead, {0, 1.535f, 0.121f}, {0.0085f, 0.022f, 0.011f}, 1.35f, {-25, 0, 0});
  a.rigid("nose_tip", "head", kHead, {0, 1.506f, 0.139f}, {0.013f, 0.011f, 0.011f}, 1.35f);
  a.rigid("l_nostril", "head", kHead, {0.011f, 1.503f, 0.13f}, {0.0075f, 0.0065f, 0.008f}, 1.35f);
  a.rigid("muzzle", "head", kHead, {0, 1.474f, 0.1f}, {0.032f, 0.025f, 0.026f}, 1.4f);
  a.rigid("upper_lip", "head", kHead, {0, 1.479f, 0.125f}, {0.021f, 0.0065f, 0.009f}, 1.3f);
  a.rigid("lower_lip", "head", kHead, {0, 1.467f, 0.122f}, {0.018f, 0.0065f, 0.009f}, 1.3f);
  a.rigid("jaw", "head", kHead, {0, 1.468f, 0.06f}, {0.05f, 0.028f, 0.058f});
  a.rigid("l_jaw_angle", "head", kHead, {0.047f, 1.478f, 0.018f}, {0.014f, 0.028f, 0.024f}, 1.4f);
  a.rigid("chin", "head", kHead, {0, 1.447f, 0.114f}, {0.021f, 0.016f, 0.016f}, 1.4f);
  a.rigid("l_ear", "head", kHead, {0.075f, 1.537f, 0.004f}, {0.0065f, 0.029f, 0.018f}, 1.4f, {-12, 25, 0});
  a.rigid("l_ear_lobe", "head", kHead, {0.074f, 1.51f, 0.01f}, {0.006f, 0.01f, 0.008f}, 1.4f);
}

}  // namespace

BodyModel authored_body_model() {
  Author a(rig::default_skeleton_desc());
  a.model.name = "mimic-default";
  add_pelvis_and_hips(a);
  add_abdomen_and_lower_back(a);
  add_chest_back_shoulders(a);
  add_neck(a);
  add_left_arm(a);
  add_left_hand(a);
  add_left_leg(a);
  add_left_foot(a);
  add_head(a);

  // Mirror every left primitive to the right.
  std::vector<Primitive> right;
  for (const Primitive& p : a.model.primitives)
    if (p.name.rfind("l_", 0) == 0) right.push_back(mirrored(p));
  for (Primitive& p : right) a.model.primitives.push_back(std::move(p));
  return a.model;
}

}  // namespace mimic::avatar
