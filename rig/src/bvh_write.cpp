// Mimic poses -> BVH text (Mimic's hierarchy, one rotation channel per DOF).
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "mimic/rig/bvh.h"
#include "mimic/rig/joint_angles.h"

namespace mimic::rig {

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

struct AxisChannel {
  char letter;  // 'X', 'Y' or 'Z'
  double sign;
};

bool axis_channel(const glm::vec3& axis, AxisChannel& out) {
  for (int k = 0; k < 3; ++k) {
    if (std::abs(std::abs(axis[k]) - 1.0f) < 1e-5f && std::abs(axis[(k + 1) % 3]) < 1e-5f &&
        std::abs(axis[(k + 2) % 3]) < 1e-5f) {
      out = {static_cast<char>('X' + k), axis[k] > 0 ? 1.0 : -1.0};
      return true;
    }
  }
  return false;
}

void append_number(std::string& s, double v) {
  char buf[32];
  if (std::abs(v) < 5e-7) v = 0;  // no "-0.000000"
  const int n = std::snprintf(buf, sizeof buf, "%.6f", v);
  s.append(buf, static_cast<size_t>(n));
}

void append_vec(std::string& s, const glm::vec3& v, double scale) {
  for (int k = 0; k < 3; ++k) {
    s += ' ';
    append_number(s, v[k] * scale);
  }
}

}  // namespace

Result<std::string> write_bvh(const Skeleton& skeleton, std::span<const Pose> poses, double frame_time_s,
                              double metres_per_unit) {
  if (!(frame_time_s > 0) || !std::isfinite(frame_time_s))
    return fail(Errc::invalid_argument, "BVH export: frame time must be positive");
  if (!(metres_per_unit > 0) || !std::isfinite(metres_per_unit))
    return fail(Errc::invalid_argument, "BVH export: metres_per_unit must be positive");
  const int n = skeleton.joint_count();
  std::vector<AxisChannel> channel(skeleton.dof_count());
  for (int i = 0; i < skeleton.dof_count(); ++i)
    if (!axis_channel(skeleton.dof(i).axis, channel[i]))
      return fail(Errc::unsupported, "BVH export: DOF '" + skeleton.dof(i).name +
                                         "' does not turn about a coordinate axis (BVH has only X/Y/Zrotation)");
  for (size_t f = 0; f < poses.size(); ++f)
    if (static_cast<int>(poses[f].dof_rad.size()) != skeleton.dof_count())
      return fail(Errc::invalid_argument, "BVH export: pose " + std::to_string(f) + " has " +
                                              std::to_string(poses[f].dof_rad.size()) + " DOF values, the skeleton " +
                                              std::to_string(skeleton.dof_count()));

  std::vector<std::vector<int>> children(n);
  for (int j = 1; j < n; ++j) children[skeleton.parent(j)].push_back(j);
  const double inv = 1.0 / metres_per_unit;

  // Hierarchy, depth first; `order` is the column order of the motion rows.
  std::string s = "HIERARCHY\n";
  std::vector<int> order;
  struct Item {
    int joint;
    size_t next_child;
  };
  std::vector<Item> stack{{0, 0}};
  auto indent = [&](size_t depth) { s.append(depth, '\t'); };
  while (!stack.empty()) {
    Item& it = stack.back();
    const int j = it.joint;
    const size_t depth = stack.size() - 1;
    if (it.next_child == 0) {
      order.push_back(j);
      indent(depth);
      s += (j == 0 ? "ROOT " : "JOINT ") + skeleton.joint_name(j) + "\n";
      indent(depth);
      s += "{\n";
      indent(depth + 1);
      s += "OFFSET";
      append_vec(s, skeleton.offset_m(j), inv);
      s += "\n";
      indent(depth + 1);
      const int dofs = skeleton.dof_end(j) - skeleton.dof_begin(j);
      s += "CHANNELS " + std::to_string(dofs + (j == 0 ? 6 : 0));
      if (j == 0) s += " Xposition Yposition Zposition Zrotation Yrotation Xrotation";
      for (int i = skeleton.dof_begin(j); i < skeleton.dof_end(j); ++i) {
        s += ' ';
        s += channel[i].letter;
        s += "rotation";
      }
      s += "\n";
      if (children[j].empty()) {
        indent(depth + 1);
        s += "End Site\n";
        indent(depth + 1);
        s += "{\n";
        indent(depth + 2);
        s += "OFFSET";
        append_vec(s, skeleton.tip_m(j), inv);
        s += "\n";
        indent(depth + 1);
        s += "}\n";
      }
    }
    if (it.next_child < children[j].size()) {
      const int c = children[j][it.next_child++];
      stack.push_back({c, 0});
      continue;
    }
    indent(depth);
    s += "}\n";
    stack.pop_back();
  }

  s += "MOTION\nFrames: " + std::to_string(poses.size()) + "\nFrame Time: ";
  {
    char buf[32];
    const int len = std::snprintf(buf, sizeof buf, "%.9g", frame_time_s);
    s.append(buf, static_cast<size_t>(len));
  }
  s += "\n";
  const glm::dvec3 zyx[3] = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}};
  double euler_prev[3] = {0, 0, 0};
  for (const Pose& pose : poses) {
    // BVH root: T(offset + position) · R(euler), Mimic root: position + R · offset.
    const glm::vec3 offset = skeleton.offset_m(0);
    const glm::vec3 position = pose.root_position_m + pose.root_orientation * offset - offset;
    for (int k = 0; k < 3; ++k) {
      if (k) s += ' ';
      append_number(s, position[k] * inv);
    }
    double euler[3];
    dofs_from_rotation(zyx, glm::dquat(pose.root_orientation), euler_prev, euler);
    for (int k = 0; k < 3; ++k) {
      euler_prev[k] = euler[k];
      s += ' ';
      append_number(s, euler[k] * kRadToDeg);
    }
    for (int j : order)
      for (int i = skeleton.dof_begin(j); i < skeleton.dof_end(j); ++i) {
        s += ' ';
        append_number(s, channel[i].sign * pose.dof_rad[i] * kRadToDeg);
      }
    s += "\n";
  }
  return s;
}

}  // namespace mimic::rig
