// Skinning weights from the contour layout (skin_weights.h): each control point's influences
// from where its ring sits along its chain of links.
#include "mimic/avatar/skin_weights.h"

#include "contour_layout_data.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar {

namespace {

// A short weighted joint list, merged by joint, reduced to the four strongest at the end.
struct Influence {
  std::array<int, 12> joint{};
  std::array<float, 12> weight{};
  int n = 0;
  void add(int j, float w) {
    if (w <= 0.0f) return;
    for (int i = 0; i < n; ++i)
      if (joint[i] == j) {
        weight[i] += w;
        return;
      }
    if (n < 12) joint[n] = j, weight[n] = w, ++n;
  }
  void add(const Influence& o, float scale) {
    for (int i = 0; i < o.n; ++i) add(o.joint[i], scale * o.weight[i]);
  }
  JointInfluences reduced() const {
    std::array<int, 12> order{};
    for (int i = 0; i < n; ++i) order[i] = i;
    std::sort(order.begin(), order.begin() + n, [&](int a, int b) { return weight[a] > weight[b]; });
    JointInfluences out;
    float sum = 0;
    const int kept = std::min(n, JointInfluences::kMax);
    for (int i = 0; i < kept; ++i) sum += weight[order[i]];
    for (int i = 0; i < kept && sum > 0; ++i) {
      out.joint[i] = static_cast<uint16_t>(joint[order[i]]);
      out.weight[i] = weight[order[i]] / sum;
    }
    return out;
  }
};

// Weight of segment `seg` (of `segments`) at chain parameter x = segment + u: a trapezoid, 1
// inside the link, ramping over ±h around each interior joint so neighbours sum to 1.
float segment_weight(int seg, int segments, float x, float h) {
  const float lo = static_cast<float>(seg), hi = static_cast<float>(seg + 1);
  float w = 1.0f;
  if (seg > 0) w = std::min(w, std::clamp((x - (lo - h)) / (2.0f * h), 0.0f, 1.0f));
  if (seg + 1 < segments) w = std::min(w, std::clamp(((hi + h) - x) / (2.0f * h), 0.0f, 1.0f));
  return w;
}

}  // namespace

Result<std::vector<JointInfluences>> contour_skin_weights(const ImplicitSkin& skin) {
  return contour_skin_weights(skin.layout());
}

Result<std::vector<JointInfluences>> contour_skin_weights(const ContourLayout& layout) {
  const ContourLayout::Data& m = layout.data();
  if (m.options.subdivision != 0)
    return fail(Errc::invalid_argument, "contour skin weights need the realtime resolution (subdivision 0)");
  std::vector<Influence> slot(m.control_points);
  for (const Ring& r : m.rings) {
    switch (r.kind) {
      case RingKind::star: {
        const Chain& c = m.chains[r.chain];
        const int segments = static_cast<int>(c.nodes.size()) - 1;
        const float x = static_cast<float>(r.segment) + r.u;
        Influence in;
        for (int s = 0; s < segments; ++s) in.add(c.nodes[s].joint, segment_weight(s, segments, x, kBlendHalfWidth));
        for (uint32_t k : r.slots) slot[k] = in;
        break;
      }
      case RingKind::arc: {
        // Over a shoulder the bridge rides on the clavicle; under the crotch on the pelvis.
        int over = -1;
        if (r.name.rfind("l_", 0) == 0) over = m.skeleton.find_joint("l_clavicle");
        if (r.name.rfind("r_", 0) == 0) over = m.skeleton.find_joint("r_clavicle");
        const float segs = static_cast<float>(r.slots.size() + 1);
        for (size_t k = 0; k < r.slots.size(); ++k) {
          const float t = static_cast<float>(k + 1) / segs;
          const float lift = over >= 0 ? 0.5f * std::sin(kPi * t) : 0.0f;
          Influence in;
          in.add(slot[r.from], (1.0f - lift) * (1.0f - t));
          in.add(slot[r.to], (1.0f - lift) * t);
          if (over >= 0) in.add(over, lift);
          slot[r.slots[k]] = in;
        }
        break;
      }
      case RingKind::driven: {
        const Ring& s = m.rings[r.s_ring];
        for (size_t k = 0; k < r.slots.size(); ++k) {
          Influence in;
          in.add(slot[s.slots[k]], 1.0f - r.alpha);
          in.add(slot[r.goal[k]], r.alpha);
          slot[r.slots[k]] = in;
        }
        break;
      }
    }
  }
  std::vector<JointInfluences> out(m.vertex_count);
  for (size_t k = 0; k < slot.size(); ++k) out[k] = slot[k].reduced();
  for (const Surface& s : m.surfaces) {
    if (!s.cap) continue;
    Influence in;
    const auto& last = s.out_rows.back();
    for (uint32_t v : last) in.add(slot[v], 1.0f / static_cast<float>(last.size()));
    out[s.cap_vertex] = in.reduced();
  }
  for (const RigidMesh& rm : m.rigid)
    for (size_t i = 0; i < rm.local.size(); ++i) {
      JointInfluences& j = out[rm.first_vertex + i];
      j.joint[0] = static_cast<uint16_t>(rm.joint);
      j.weight[0] = 1.0f;
    }
  for (const RigidMesh& rm : m.rigid)
    for (size_t k = 0; k < rm.toe_vertex.size(); ++k) {
      // The forefoot's blend, the larger weight first.
      JointInfluences& j = out[rm.first_vertex + rm.toe_vertex[k]];
      const float w = rm.toe_weight[k];
      const bool toes_first = w > 0.5f;
      j.joint[0] = static_cast<uint16_t>(toes_first ? rm.toe_joint : rm.joint);
      j.joint[1] = static_cast<uint16_t>(toes_first ? rm.joint : rm.toe_joint);
      j.weight[0] = toes_first ? w : 1.0f - w;
      j.weight[1] = toes_first ? 1.0f - w : w;
      if (j.weight[1] <= 0.0f) j.joint[1] = 0, j.weight[1] = 0.0f;
    }
  return out;
}

}  // namespace mimic::avatar
