// mimic inspect: joint-zone volume and cross-sections while joints sweep, for the contour skin
// (full and realtime) and the LBS, DQS and CoR baselines on the same rest mesh.
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "body_posing.h"
#include "cli.h"
#include "command.h"
#include "mimic/avatar/skin_inspection.h"
#include "mimic/avatar/skin_lod.h"

namespace mimic::app::cmd_inspect {
namespace {

constexpr const char* kName = "inspect";
constexpr const char* kAbout =
    "Sweeps the left elbow and knee through 0-150 deg of flexion and the left forearm through\n"
    "-90..+90 deg of twist, and measures the skin around the joint at every step: the volume of\n"
    "the joint zone (the skin between two planes riding on the two links, 35% of the shorter link\n"
    "from the joint) as a % change from the relaxed pose, the smallest of five cross-sections\n"
    "across the zone as a fraction of the same section at rest, and how far the zone's skin\n"
    "stands off the bones beyond its rest distance, mm (\"out\": a mitred joint's beak or\n"
    "needle; docs/skin.md, \"Joint quality\").\n"
    "Methods, on the same rest mesh (the realtime resolution): full (contours ray-cast every\n"
    "frame), realtime (contours moved, muscle terms kept), and linear blend (lbs), dual\n"
    "quaternion (dqs) and optimized centres of rotation (cor) skinning bound with the\n"
    "contour-derived weights. Targets for the realtime method: |dV| <= 2% at 150 deg flexion,\n"
    "<= 3% at +-90 deg twist, every section >= 90% of rest.";

const char* kMethods[] = {"full", "realtime", "lbs", "dqs", "cor"};

// Worst figures per method: |dV| at the extreme angles (150 deg flexion, +-90 deg twist) and
// the smallest section anywhere in the sweep.
struct Summary {
  double flexion_150_abs_dv = 0, twist_90_abs_dv = 0, min_section = INFINITY, stand_off_mm = 0;
};

int run_inspect(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  p->footer("exit status: 0 measured, 1 failure, 2 usage error");
  std::string body_path, only;
  int lod = 0;
  bool no_muscles = false, json = false;
  p->add_option("--body", body_path, "body model (default: the built-in body)")->type_name("FILE");
  p->add_option("--lod", lod, "skin level of detail, 0 finest")->check(CLI::Range(0, avatar::kSkinLodCount - 1));
  p->add_option("--sweep", only, "only this sweep")
      ->check(CLI::IsMember({"elbow_flexion", "knee_flexion", "forearm_twist"}));
  p->add_flag("--no-muscles", no_muscles, "the realtime method without its muscle terms");
  p->add_flag("--json", json, "one JSON object: every sample of every sweep and method, and a summary");
  if (auto exit_code = p.parse(argv)) return *exit_code;
  auto body = body_from_path(body_path);
  if (!body) return failure(kName, body.error().what());
  auto sweeps = avatar::standard_joint_sweeps(*body);
  if (!only.empty()) {
    std::erase_if(sweeps, [&](const avatar::JointSweep& s) { return s.name != only; });
    if (sweeps.empty()) return failure(kName, "the body has no sweep '" + only + "'");
  }
  avatar::InspectOptions options;
  options.lod = lod;
  options.muscles = !no_muscles;
  auto results = avatar::inspect_joint_zones(*body, sweeps, options);
  if (!results) return failure(kName, results.error().what());

  std::map<std::string, Summary> summary;
  for (const auto& r : *results)
    for (const auto& m : r.methods)
      for (const auto& s : m.samples) {
        Summary& sum = summary[m.method];
        sum.min_section = std::min(sum.min_section, s.min_section_fraction);
        sum.stand_off_mm = std::max(sum.stand_off_mm, s.stand_off_mm);
        const bool twist = r.sweep.name.find("twist") != std::string::npos;
        if (!twist && std::abs(s.angle_deg - 150.0f) < 0.5f)
          sum.flexion_150_abs_dv = std::max(sum.flexion_150_abs_dv, std::abs(s.volume_change_pct));
        if (twist && std::abs(std::abs(s.angle_deg) - 90.0f) < 0.5f)
          sum.twist_90_abs_dv = std::max(sum.twist_90_abs_dv, std::abs(s.volume_change_pct));
      }

  if (json) {
    nlohmann::ordered_json j;
    j["body"] = body->name;
    j["lod"] = lod;
    j["muscles"] = options.muscles;
    j["targets"] = {{"flexion_150_abs_volume_change_pct", 2.0},
                    {"twist_90_abs_volume_change_pct", 3.0},
                    {"min_section_fraction", 0.9}};
    for (const auto& r : *results) {
      nlohmann::ordered_json sj;
      sj["name"] = r.sweep.name;
      sj["dof"] = r.sweep.dof;
      sj["joint"] = r.sweep.joint;
      sj["parts"] = r.sweep.parts;
      sj["half_length_m"] = r.sweep.half_length_m;
      sj["angles_deg"] = r.sweep.angles_deg;
      for (const auto& m : r.methods) {
        nlohmann::ordered_json dv = nlohmann::ordered_json::array(), sec = nlohmann::ordered_json::array(),
                               off = nlohmann::ordered_json::array();
        for (const auto& s : m.samples)
          dv.push_back(s.volume_change_pct), sec.push_back(s.min_section_fraction), off.push_back(s.stand_off_mm);
        sj["methods"][m.method] = {{"volume_change_pct", dv}, {"min_section_fraction", sec}, {"stand_off_mm", off}};
      }
      j["sweeps"].push_back(sj);
    }
    for (const char* m : kMethods) {
      const Summary& s = summary[m];
      j["summary"][m] = {{"flexion_150_abs_volume_change_pct", s.flexion_150_abs_dv},
                         {"twist_90_abs_volume_change_pct", s.twist_90_abs_dv},
                         {"min_section_fraction", s.min_section},
                         {"stand_off_mm", s.stand_off_mm}};
    }
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("body %s, LOD %d, realtime muscles %s\n", body->name.c_str(), lod, options.muscles ? "on" : "off");
  for (const auto& r : *results) {
    std::printf("\n%s (%s; zone: %s", r.sweep.name.c_str(), r.sweep.dof.c_str(), r.sweep.parts[0].c_str());
    for (size_t i = 1; i < r.sweep.parts.size(); ++i) std::printf(" + %s", r.sweep.parts[i].c_str());
    std::printf(", %.1f cm either side of %s)\n", 100 * r.sweep.half_length_m, r.sweep.joint.c_str());
    std::printf("%7s", "deg");
    for (const auto& m : r.methods) std::printf(" | %-8s dV%%  sec  out", m.method.c_str());
    std::printf("\n");
    for (size_t k = 0; k < r.sweep.angles_deg.size(); ++k) {
      std::printf("%7.0f", r.sweep.angles_deg[k]);
      for (const auto& m : r.methods)
        std::printf(" | %+12.1f %4.2f %4.0f", m.samples[k].volume_change_pct, m.samples[k].min_section_fraction,
                    m.samples[k].stand_off_mm);
      std::printf("\n");
    }
  }
  std::printf(
      "\nsummary          |dV| at 150 deg flexion   |dV| at +-90 deg twist   smallest section   stand-off, mm\n");
  for (const char* m : kMethods) {
    const Summary& s = summary[m];
    std::printf("%-16s %17.1f %% %23.1f %% %18.2f %15.0f\n", m, s.flexion_150_abs_dv, s.twist_90_abs_dv, s.min_section,
                s.stand_off_mm);
  }
  std::printf("target realtime  %17.1f %% %23.1f %% %18.2f\n", 2.0, 3.0, 0.90);
  return 0;
}

}  // namespace

MIMIC_COMMAND(inspect, kName, "joint-zone volume and sections as joints bend and twist: contour skin vs LBS/DQS/CoR",
              run_inspect);

}  // namespace mimic::app::cmd_inspect
