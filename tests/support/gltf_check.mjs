// Loads glTF/VRM files with third-party readers and prints what they saw as one JSON object:
//   node gltf_check.mjs NODE_MODULES validate FILE   Khronos glTF validator (gltf-validator)
//   node gltf_check.mjs NODE_MODULES vrm FILE        three.js GLTFLoader + @pixiv/three-vrm (a plain
//                                                    glTF too: its skinned meshes and clips)
// NODE_MODULES is a folder with those packages installed (scripts/setup.sh puts them in
// build/node/node_modules). Exit 0 when the reader ran (its findings are in the output),
// 1 when it threw.
import { readFileSync } from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const [modules, mode, file] = process.argv.slice(2);
const load = (rel) => import(pathToFileURL(path.join(modules, rel)).href);
const bytes = readFileSync(file);

async function validate() {
  const validator = (await load('gltf-validator/index.js')).default;
  const report = await validator.validateBytes(new Uint8Array(bytes), { maxIssues: 100 });
  return {
    errors: report.issues.numErrors,
    warnings: report.issues.numWarnings,
    infos: report.issues.numInfos,
    messages: report.issues.messages.map((m) => `${m.severity} ${m.code} ${m.pointer || ''}: ${m.message}`),
  };
}

async function vrm() {
  const { GLTFLoader } = await load('three/examples/jsm/loaders/GLTFLoader.js');
  const { VRMLoaderPlugin } = await load('@pixiv/three-vrm/lib/three-vrm.module.js');
  const loader = new GLTFLoader();
  loader.register((parser) => new VRMLoaderPlugin(parser));
  const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const gltf = await new Promise((resolve, reject) => loader.parse(buffer, '', resolve, reject));
  let skinned = 0, vertices = 0;
  const materials = new Set(), skeletons = new Set();
  gltf.scene.traverse((o) => {
    if (o.isSkinnedMesh) {
      skinned++;
      skeletons.add(o.skeleton);
      vertices = Math.max(vertices, o.geometry.attributes.position.count);
      for (const m of [].concat(o.material)) materials.add(m.name);
    }
  });
  const scene = { skinnedMeshes: skinned, skeletons: skeletons.size, vertices, materials: [...materials],
                  clips: gltf.animations.map((a) => ({ name: a.name, tracks: a.tracks.length, duration: a.duration })) };
  const v = gltf.userData.vrm;
  if (!v) return { vrm: false, ...scene };
  const bones = {};
  for (const [name, bone] of Object.entries(v.humanoid.humanBones)) {
    if (!bone || !bone.node) continue;
    bone.node.updateWorldMatrix(true, false);
    const p = bone.node.getWorldPosition(bone.node.position.clone());
    bones[name] = { node: bone.node.name, world: [p.x, p.y, p.z] };
  }
  return { vrm: true, metaVersion: v.meta.metaVersion, name: v.meta.name, authors: v.meta.authors,
           licenseUrl: v.meta.licenseUrl, bones, ...scene };
}

try {
  const out = mode === 'validate' ? await validate() : await vrm();
  console.log(JSON.stringify(out));
} catch (e) {
  console.error(`gltf_check: ${e && e.stack ? e.stack : e}`);
  process.exit(1);
}
