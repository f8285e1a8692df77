#!/usr/bin/env bash
# Fetches the third-party reference data the tests, the benchmarks and some README examples read
# (docs/data.md): eight CMU motion clips (BVH, cgspeed's 2010 MotionBuilder-friendly conversion)
# and the MakeHuman hm08 base mesh, into ../shared/data beside the checkout (or the folder given,
# or $MIMIC_SHARED_DATA). Every clip is checked against its SHA-256; the mesh is cut down to its
# body group as the shared copy is (13,380 vertices). Needs curl (or wget) and python3.
#
#   scripts/get-data.sh                 # into ../shared/data
#   scripts/get-data.sh /data/mimic     # elsewhere; then export MIMIC_SHARED_DATA=/data/mimic
#   scripts/get-data.sh --from DIR      # copy from a folder that has bvh/ and mesh/ (checked too)
set -euo pipefail
cd "$(dirname "$0")/.."
from=""
if [ "${1:-}" = "--from" ]; then from=${2:?--from needs a folder}; shift 2; fi
dest=${1:-${MIMIC_SHARED_DATA:-../shared/data}}

# Sources pinned to commits (docs/data.md): A = chrystianosaraujo/motion-viewer, B = gazebosim/gz-common.
a=https://raw.githubusercontent.com/chrystianosaraujo/motion-viewer/6d7ca60c300f123528be0fd0939cf7a584a13f65/data
b=https://raw.githubusercontent.com/gazebosim/gz-common/f4a6dbd1f30b0a3b0c11b067a4e3596384944d8a/test/data
mh=https://raw.githubusercontent.com/makehumancommunity/makehuman/a8bc2d54ff0ac92e78ff71431b1023eda42bf482/makehuman/data/3dobjs/base.obj
clips="07_01:$a/07/07_01.bvh 09_11:$a/09/09_11.bvh 02_04:$a/02/02_04.bvh 02_05:$a/02/02_05.bvh
       02_06:$a/02/02_06.bvh 05_02:$a/05/05_02.bvh 06_04:$a/06/06_04.bvh 13_26:$b/cmu-13_26.bvh"
sums='cdfa9eb68a9e5a684a401fd8776be6a477272f9174cb80dd14e5dad6b736d82b  07_01.bvh
2d8422bfb7a06675eaf2cd1a8b73d17e0240cbeb7b1b8f1265f06075f3b7e021  09_11.bvh
49d09ed98ad70fe9ece8aa42ea17437ee73094c86398476707036cd74683a17d  02_04.bvh
7a54afb840cce9ba4c5d7b339b2a71656d35a506b05be3a619ee5fbfaba10003  02_05.bvh
76cdecad10d185984c4dd6197649da41c01ae22f64c5364b9186021d00f7dabe  02_06.bvh
bd70b2bd823fbe81d7006575e7f9a8d9811935f4042fc2812d01d3344c630694  05_02.bvh
0a64892ac97404d6b9dcc6da1d37e1f47b915c475d2973a1b72e502846ffcfbd  06_04.bvh
73ac49cfdb65ac0c85a4a931c2c408720ec7e125f2753a68d64e5f0322c3cab4  13_26.bvh'

get() {  # URL FILE
  if command -v curl >/dev/null; then curl -fsSL --retry 3 -o "$2" "$1"; else wget -q -O "$2" "$1"; fi
}

mkdir -p "$dest/bvh" "$dest/mesh"
for clip in $clips; do
  id=${clip%%:*} url=${clip#*:}
  if [ -n "$from" ]; then cp "$from/bvh/$id.bvh" "$dest/bvh/$id.bvh.part"; else get "$url" "$dest/bvh/$id.bvh.part"; fi
  mv "$dest/bvh/$id.bvh.part" "$dest/bvh/$id.bvh"
done
(cd "$dest/bvh" && echo "$sums" | sha256sum --quiet -c -) || { echo "get-data: a clip does not match its checksum" >&2; exit 1; }
echo "bvh       8 clips in $dest/bvh, checksums match"

if [ -n "$from" ]; then
  cp "$from/mesh/makehuman_base_body.obj" "$dest/mesh/makehuman_base_body.obj.part"
  [ -f "$from/mesh/makehuman_base_joints.csv" ] && cp "$from/mesh/makehuman_base_joints.csv" "$dest/mesh/"
  mv "$dest/mesh/makehuman_base_body.obj.part" "$dest/mesh/makehuman_base_body.obj"
else
  tmp=$(mktemp)
  trap 'rm -f "$tmp"' EXIT
  get "$mh" "$tmp"
  # The body group alone: its vertices are the file's first 13,380, kept in order; faces keep
  # their vertex indices (texture indices dropped); the helper groups and joint cubes go.
  python3 - "$tmp" "$dest/mesh/makehuman_base_body.obj" <<'PY'
import sys
src, out = sys.argv[1], sys.argv[2]
verts, faces, group, cubes = [], [], None, {}
for line in open(src, encoding="utf-8", errors="replace"):
    w = line.split()
    if not w: continue
    if w[0] == "v": verts.append(line.strip())
    elif w[0] == "g": group = w[1] if len(w) > 1 else None
    elif w[0] == "f" and group == "body":
        faces.append("f " + " ".join(x.split("/")[0] for x in w[1:]))
    elif w[0] == "f" and group and group.startswith("joint-"):
        cubes.setdefault(group[len("joint-"):], set()).update(int(x.split("/")[0]) for x in w[1:])
used = max(int(x) for f in faces for x in f.split()[1:])
with open(out + ".part", "w") as o:
    o.write("# MakeHuman hm08 base mesh, body group only (CC0 1.0, MakeHuman team); units: decimetres\n")
    o.write("\n".join(verts[:used]) + "\n" + "\n".join(faces) + "\n")
import os; os.replace(out + ".part", out)
# The joint centres: each "joint-<name>" helper cube's vertex centroid (measure.h reads them).
joints = out.replace("makehuman_base_body.obj", "makehuman_base_joints.csv")
with open(joints, "w") as o:
    o.write("# Joint positions of the MakeHuman hm08 base mesh, decimetres, centroids of its joint-<name> cubes (CC0)\n")
    o.write("name,x,y,z\n")
    for name, ids in cubes.items():
        c = [sum(float(verts[i - 1].split()[1 + k]) for i in ids) / len(ids) for k in range(3)]
        o.write(f"{name},{c[0]:.4f},{c[1]:.4f},{c[2]:.4f}\n")
print(f"joints    {len(cubes)} joint centres in {joints}")
print(f"mesh      {used} vertices, {len(faces)} faces in {out}")
PY
fi
echo "done: tests and examples read $dest (set MIMIC_SHARED_DATA if it is not ../shared/data)"
