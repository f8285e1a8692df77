// The joint positions a calibration's sensors mark: a mark nobody set is an error when read,
// never a zero (a zero would put a joint at the tracker's origin and fit the body to it).
#include <gtest/gtest.h>

#include <stdexcept>

#include "../../solver/src/calibration_fit.h"

namespace mimic::solver::detail::calibration_marks_test {
namespace {

TEST(JointMarks, AMissingMarkIsAnErrorNotAZero) {
  const rig::Skeleton s = *rig::Skeleton::build(tracking_skeleton_desc());
  JointMarks marks(s);
  EXPECT_FALSE(marks.has(Landmark::head));
  EXPECT_THROW(marks.at(Landmark::head), std::logic_error);
  EXPECT_THROW(marks.at_joint(s.find_joint("l_toes")), std::logic_error);
  // Reading does not create the mark.
  EXPECT_FALSE(marks.has(Landmark::head));
  EXPECT_FALSE(marks.has_joint(s.find_joint("head")));
}

TEST(JointMarks, LandmarksAndJointsNameTheSameSlots) {
  const rig::Skeleton s = *rig::Skeleton::build(tracking_skeleton_desc());
  JointMarks marks(s);
  marks.set(Landmark::r_wrist, {0.7f, 1.4f, 0.1f});
  EXPECT_TRUE(marks.has_joint(s.find_joint("r_wrist")));
  EXPECT_EQ(marks.at_joint(s.find_joint("r_wrist")), glm::vec3(0.7f, 1.4f, 0.1f));
  marks.set_joint(s.find_joint("l_knee"), {0.1f, 0.5f, 0.0f});
  EXPECT_TRUE(marks.has(Landmark::l_knee));
  EXPECT_EQ(marks.at(Landmark::l_knee), glm::vec3(0.1f, 0.5f, 0.0f));
  EXPECT_FALSE(marks.has(Landmark::r_knee));
  EXPECT_EQ(sided(1, Landmark::l_knee), Landmark::r_knee);
  EXPECT_STREQ(landmark_name(sided(1, Landmark::l_shoulder)), "r_shoulder");
}

TEST(JointMarks, ALandmarkTheSkeletonLacksCannotBeSet) {
  rig::SkeletonDesc desc = tracking_skeleton_desc();
  for (auto& j : desc.joints) {
    if (j.name == "spine_mid") j.name = "chest_lower";
    if (j.parent == "spine_mid") j.parent = "chest_lower";
  }
  const rig::Skeleton s = *rig::Skeleton::build(desc);
  JointMarks marks(s);
  EXPECT_FALSE(marks.has(Landmark::spine_mid));
  EXPECT_THROW(marks.set(Landmark::spine_mid, glm::vec3(0.0f, 1.2f, 0.0f)), std::logic_error);
  EXPECT_THROW(marks.set_joint(-1, glm::vec3(0.0f)), std::logic_error);
  EXPECT_THROW(marks.set_joint(s.joint_count(), glm::vec3(0.0f)), std::logic_error);
}

}  // namespace
}  // namespace mimic::solver::detail::calibration_marks_test
