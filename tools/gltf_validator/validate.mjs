// Validates one glTF 2.0 file (.glb or .gltf) with the Khronos glTF
// validator and prints its report as JSON on stdout.
// Exit status: 0 no errors (warnings and infos allowed), 1 errors found,
// 2 the file could not be read or the validator failed.
// Usage: node validate.mjs FILE
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: validate.mjs FILE.glb|FILE.gltf');
  process.exit(2);
}
try {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 200,
    // External resources (textures beside a .glb) resolve next to the file.
    externalResourceFunction: async (uri) =>
      new Uint8Array(await readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)))),
  });
  console.log(JSON.stringify(report, null, 2));
  process.exit(report.issues.numErrors === 0 ? 0 : 1);
} catch (e) {
  console.error(`validate.mjs: ${file}: ${e.message ?? e}`);
  process.exit(2);
}
