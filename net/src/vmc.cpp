#include <utility>

#include "mimic/net/vmc.h"

#include <bit>
#include <boost/asio.hpp>
#include <cstring>

#include "mimic/net/server.h"

namespace mimic::net {

namespace asio = boost::asio;

void OscWriter::put32(uint32_t v) {
  const uint8_t b[4] = {uint8_t(v >> 24), uint8_t(v >> 16), uint8_t(v >> 8), uint8_t(v)};
  out_.insert(out_.end(), b, b + 4);
}

void OscWriter::pad() {
  while (out_.size() % 4 != 0) out_.push_back(0);
}

void OscWriter::begin_bundle(uint64_t timetag) {
  static const char kTag[8] = {'#', 'b', 'u', 'n', 'd', 'l', 'e', 0};
  out_.insert(out_.end(), kTag, kTag + 8);
  put32(uint32_t(timetag >> 32));
  put32(uint32_t(timetag));
  in_bundle_ = true;
}

void OscWriter::begin_message(std::string_view address, std::string_view type_tags) {
  if (in_bundle_) put32(0);  // element size, patched by end_message
  message_start_ = out_.size();
  arg_string(address);
  out_.push_back(',');
  out_.insert(out_.end(), type_tags.begin(), type_tags.end());
  out_.push_back(0);
  pad();
}

void OscWriter::arg_string(std::string_view s) {
  out_.insert(out_.end(), s.begin(), s.end());
  out_.push_back(0);
  pad();
}

void OscWriter::arg_float(float f) { put32(std::bit_cast<uint32_t>(f)); }
void OscWriter::arg_int(int32_t i) { put32(static_cast<uint32_t>(i)); }

void OscWriter::end_message() {
  if (!in_bundle_) return;
  const uint32_t size = static_cast<uint32_t>(out_.size() - message_start_);
  uint8_t* p = out_.data() + message_start_ - 4;
  p[0] = uint8_t(size >> 24);
  p[1] = uint8_t(size >> 16);
  p[2] = uint8_t(size >> 8);
  p[3] = uint8_t(size);
}

std::vector<VmcBone> vmc_bone_map(const rig::Skeleton& s) {
  struct Entry {
    const char* joint;
    const char* fold;
    const char* unity;
  };
  static const Entry kMap[] = {
      {"pelvis", nullptr, "Hips"},
      {"spine_lower", nullptr, "Spine"},
      {"spine_mid", nullptr, "Chest"},
      {"spine_upper", nullptr, "UpperChest"},
      {"neck", "neck_upper", "Neck"},
      {"head", nullptr, "Head"},
      {"l_clavicle", nullptr, "LeftShoulder"},
      {"l_shoulder", nullptr, "LeftUpperArm"},
      {"l_elbow", nullptr, "LeftLowerArm"},
      {"l_wrist", nullptr, "LeftHand"},
      {"r_clavicle", nullptr, "RightShoulder"},
      {"r_shoulder", nullptr, "RightUpperArm"},
      {"r_elbow", nullptr, "RightLowerArm"},
      {"r_wrist", nullptr, "RightHand"},
      {"l_hip", nullptr, "LeftUpperLeg"},
      {"l_knee", nullptr, "LeftLowerLeg"},
      {"l_ankle", nullptr, "LeftFoot"},
      {"l_toes", nullptr, "LeftToes"},
      {"r_hip", nullptr, "RightUpperLeg"},
      {"r_knee", nullptr, "RightLowerLeg"},
      {"r_ankle", nullptr, "RightFoot"},
      {"r_toes", nullptr, "RightToes"},
  };
  std::vector<VmcBone> bones;
  for (const auto& e : kMap) {
    const int j = s.find_joint(e.joint);
    if (j < 0) continue;
    bones.push_back({j, e.fold ? s.find_joint(e.fold) : -1, e.unity});
  }
  return bones;
}

VmcEncoder::VmcEncoder(const rig::Skeleton& skeleton) : skeleton_(skeleton), bones_(vmc_bone_map(skeleton)) {}

namespace {

// Mimic (right-handed, left = +X) to Unity (left-handed, right = +X): mirror x.
glm::vec3 to_unity(glm::vec3 p) { return {-p.x, p.y, p.z}; }
glm::quat to_unity(glm::quat q) { return glm::quat(q.w, q.x, -q.y, -q.z); }

void bone_message(OscWriter& w, std::string_view address, std::string_view name, glm::vec3 p, glm::quat q) {
  w.begin_message(address, "sfffffff");
  w.arg_string(name);
  w.arg_float(p.x);
  w.arg_float(p.y);
  w.arg_float(p.z);
  w.arg_float(q.x);
  w.arg_float(q.y);
  w.arg_float(q.z);
  w.arg_float(q.w);
  w.end_message();
}

// Bytes a message takes inside a bundle: its size word, the padded address and type tags
// (with the leading ','), and the arguments.
size_t osc_string_bytes(size_t len) { return (len + 4) & ~size_t(3); }
size_t message_bytes(std::string_view address, size_t tag_count, size_t args_bytes) {
  return 4 + osc_string_bytes(address.size()) + osc_string_bytes(1 + tag_count) + args_bytes;
}
size_t bone_message_bytes(std::string_view address, std::string_view name) {
  return message_bytes(address, 8, osc_string_bytes(name.size()) + 7 * 4);
}

}  // namespace

VmcBundles VmcEncoder::encode(const rig::Pose& pose, double stream_time_s, std::vector<uint8_t>& out,
                              size_t max_bundle_bytes) const {
  out.clear();
  OscWriter w(out);
  VmcBundles bundles;
  size_t bundle_start = 0;
  // Closes the bundle in progress when `next` more bytes would take it over the limit.
  auto room_for = [&](size_t next) {
    if (out.size() - bundle_start + next <= max_bundle_bytes || bundles.count + 1 >= kVmcMaxBundles) return;
    bundles.end[bundles.count++] = static_cast<uint32_t>(out.size());
    bundle_start = out.size();
    w.begin_bundle();
  };
  w.begin_bundle();
  bone_message(w, "/VMC/Ext/Root/Pos", "root", glm::vec3(0), glm::quat(1, 0, 0, 0));
  const std::span<const float> dofs(pose.dof_rad);
  for (const auto& b : bones_) {
    glm::vec3 p = skeleton_.offset_m(b.joint);
    glm::quat q = skeleton_.local_rotation(b.joint, dofs);
    if (b.fold_joint >= 0) q = q * skeleton_.local_rotation(b.fold_joint, dofs);
    if (skeleton_.parent(b.joint) < 0) {
      // The root bone carries the body's world placement.
      p = pose.root_position_m;
      q = pose.root_orientation * q;
    } else if (skeleton_.joint_name(b.joint) == "head") {
      // Head hangs off neck_upper in Mimic; VMC's Neck already includes neck_upper's rotation.
      const int nu = skeleton_.parent(b.joint);
      p = skeleton_.offset_m(nu) + skeleton_.offset_m(b.joint);
    }
    room_for(bone_message_bytes("/VMC/Ext/Bone/Pos", b.unity_name));
    bone_message(w, "/VMC/Ext/Bone/Pos", b.unity_name, to_unity(p), to_unity(q));
  }
  // OK and T together close the frame.
  room_for(message_bytes("/VMC/Ext/OK", 1, 4) + message_bytes("/VMC/Ext/T", 1, 4));
  w.begin_message("/VMC/Ext/OK", "i");
  w.arg_int(1);
  w.end_message();
  w.begin_message("/VMC/Ext/T", "f");
  w.arg_float(static_cast<float>(stream_time_s));
  w.end_message();
  bundles.end[bundles.count++] = static_cast<uint32_t>(out.size());
  return bundles;
}

struct VmcSender::Impl {
  struct Avatar {
    std::unique_ptr<VmcEncoder> encoder;
    asio::ip::udp::endpoint dest;
    double first_time_s = 0;
    bool started = false;
  };
  asio::io_context io{1};
  asio::ip::udp::socket sock{io};
  asio::ip::address addr;
  uint16_t base_port = 0;
  std::vector<Avatar> avatars;
  std::vector<uint8_t> buf;
};

VmcSender::VmcSender(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VmcSender::~VmcSender() = default;

Result<std::unique_ptr<VmcSender>> VmcSender::open(const std::string& host_port) {
  auto hp = split_host_port(host_port);
  if (!hp) return tl::unexpected(hp.error());
  auto impl = std::make_unique<Impl>();
  boost::system::error_code ec;
  auto addr = asio::ip::make_address(hp->first, ec);
  if (ec) {
    asio::ip::udp::resolver resolver(impl->io);
    auto results = resolver.resolve(hp->first, std::to_string(hp->second), ec);
    if (ec || results.empty()) return fail(Errc::not_found, "cannot resolve '" + hp->first + "'");
    addr = results.begin()->endpoint().address();
  }
  impl->addr = addr;
  impl->base_port = hp->second;
  impl->sock.open(addr.is_v4() ? asio::ip::udp::v4() : asio::ip::udp::v6(), ec);
  if (ec) return fail(Errc::io_error, "cannot open a UDP socket: " + ec.message());
  impl->sock.non_blocking(true, ec);
  impl->buf.reserve(4096);
  impl->avatars.reserve(64);
  return std::unique_ptr<VmcSender>(new VmcSender(std::move(impl)));
}

Status VmcSender::add_avatar(const rig::Skeleton& skeleton) {
  const size_t i = impl_->avatars.size();
  if (i >= 64) return fail(Errc::out_of_range, "VMC: at most 64 avatars");
  if (impl_->base_port + i > 65535)
    return fail(Errc::out_of_range, "VMC: avatar " + std::to_string(i) + " would need port " +
                                        std::to_string(impl_->base_port + i) + " (avatar i goes to port + i)");
  Impl::Avatar a;
  a.encoder = std::make_unique<VmcEncoder>(skeleton);
  a.dest = asio::ip::udp::endpoint(impl_->addr, static_cast<uint16_t>(impl_->base_port + i));
  impl_->avatars.push_back(std::move(a));
  return {};
}

size_t VmcSender::avatar_count() const { return impl_->avatars.size(); }

size_t VmcSender::send(size_t avatar, const rig::Pose& pose, double capture_time_s) {
  if (avatar >= impl_->avatars.size()) return 0;
  Impl::Avatar& a = impl_->avatars[avatar];
  if (!a.started) {
    a.started = true;
    a.first_time_s = capture_time_s;
  }
  const VmcBundles b = a.encoder->encode(pose, capture_time_s - a.first_time_s, impl_->buf);
  size_t sent = 0, begin = 0;
  for (size_t i = 0; i < b.count; ++i) {
    boost::system::error_code ec;
    const size_t n = impl_->sock.send_to(asio::buffer(impl_->buf.data() + begin, b.end[i] - begin), a.dest, 0, ec);
    if (ec) return 0;
    sent += n;
    begin = b.end[i];
  }
  return sent;
}

}  // namespace mimic::net
