#include "mimic/avatar/baselines/skin_weights.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace mimic::avatar::baselines {

Status validate_weights(const SkinWeights& w, int joint_count, float tolerance) {
  if (w.joints.size() != w.weights.size() || w.weights.size() % kInfluences != 0)
    return fail(Errc::invalid_argument, "skin weights: joints and weights must both hold four entries per vertex");
  for (size_t v = 0; v < w.vertex_count(); ++v) {
    float sum = 0;
    for (int k = 0; k < kInfluences; ++k) {
      const size_t i = v * kInfluences + k;
      if (w.joints[i] >= joint_count)
        return fail(Errc::out_of_range, "skin weights: vertex " + std::to_string(v) + " names joint " +
                                            std::to_string(w.joints[i]) + " of " + std::to_string(joint_count));
      if (!std::isfinite(w.weights[i]) || w.weights[i] < 0)
        return fail(Errc::invalid_argument,
                    "skin weights: vertex " + std::to_string(v) + " has a negative or non-finite weight");
      sum += w.weights[i];
    }
    if (std::abs(sum - 1.0f) > tolerance)
      return fail(Errc::invalid_argument, "skin weights: the weights of vertex " + std::to_string(v) + " sum to " +
                                              std::to_string(sum) + ", not 1");
  }
  return {};
}

namespace {

float smoothstep01(float x) {
  x = std::clamp(x, 0.0f, 1.0f);
  return x * x * (3.0f - 2.0f * x);
}

}  // namespace

SkinWeights weights_from_links(const rig::Skeleton& s, std::span<const rig::RigidTransform> rest,
                               std::span<const glm::vec3> positions, float band_m) {
  const int n = s.joint_count();
  struct Link {
    glm::vec3 a, b;
    float length;
    int nearest_child;  // a child joint whose origin is this link's tip, -1 if none
  };
  std::vector<Link> links(n);
  for (int j = 0; j < n; ++j) {
    links[j] = {rest[j].translation, rest[j].apply(s.tip_m(j)), glm::length(s.tip_m(j)), -1};
  }
  for (int c = 0; c < n; ++c) {
    const int p = s.parent(c);
    if (p >= 0 && glm::distance(rest[c].translation, links[p].b) < 0.01f && links[p].nearest_child < 0)
      links[p].nearest_child = c;
  }
  SkinWeights out;
  out.joints.assign(positions.size() * kInfluences, 0);
  out.weights.assign(positions.size() * kInfluences, 0.0f);
  for (size_t v = 0; v < positions.size(); ++v) {
    const glm::vec3 p = positions[v];
    int best = 0;
    float best_d = INFINITY, best_t = 0;
    for (int j = 0; j < n; ++j) {
      if (links[j].length < 1e-4f) continue;
      const glm::vec3 ab = links[j].b - links[j].a;
      const float t = glm::dot(p - links[j].a, ab) / glm::dot(ab, ab);
      const float d = glm::distance(p, links[j].a + std::clamp(t, 0.0f, 1.0f) * ab);
      if (d < best_d) best_d = d, best = j, best_t = t;
    }
    const float along_m = best_t * links[best].length;            // from the link's start
    const float to_end_m = (1.0f - best_t) * links[best].length;  // to the link's tip
    int other = -1;
    float other_w = 0;
    if (s.parent(best) >= 0 && along_m < band_m) {
      other = s.parent(best);
      other_w = 0.5f * (1.0f - smoothstep01(along_m / band_m));
    } else if (links[best].nearest_child >= 0 && to_end_m < band_m) {
      other = links[best].nearest_child;
      other_w = 0.5f * (1.0f - smoothstep01(to_end_m / band_m));
    }
    out.joints[v * kInfluences] = static_cast<uint16_t>(best);
    out.weights[v * kInfluences] = 1.0f - other_w;
    if (other >= 0 && other_w > 0) {
      out.joints[v * kInfluences + 1] = static_cast<uint16_t>(other);
      out.weights[v * kInfluences + 1] = other_w;
    }
  }
  return out;
}

SkinWeights from_influences(std::span<const JointInfluences> influences) {
  static_assert(JointInfluences::kMax == kInfluences);
  SkinWeights out;
  out.joints.reserve(influences.size() * kInfluences);
  out.weights.reserve(influences.size() * kInfluences);
  for (const JointInfluences& v : influences) {
    out.joints.insert(out.joints.end(), v.joint.begin(), v.joint.end());
    out.weights.insert(out.weights.end(), v.weight.begin(), v.weight.end());
  }
  return out;
}

}  // namespace mimic::avatar::baselines
