#!/bin/sh
# Meshes the built-in body's head, left hand and left foot from their primitives' field and writes
# the table the program ships (avatar/src/skin/rigid_mesh_table.cpp). Run it after changing a
# rigid part's primitives or the meshing (iso_mesh.h); RigidMesh.TheShippedMeshesAreTheBodysOwn
# fails until then. Usage: scripts/regen_rigid_meshes.sh [path/to/mimic]
set -eu
cd "$(dirname "$0")/.."
mimic=${1:-build/bin/mimic}
out=avatar/src/skin/rigid_mesh_table.cpp
"$mimic" mesh --emit-rigid-meshes "$out"
clang-format -i "$out"
echo "now rebuild: the program ships the new meshes"
