// Validates glTF / GLB files with the Khronos glTF validator and prints each report.
// Usage: node tools/validate-gltf.mjs FILE...
// Exits 1 if any file has an error or a warning (infos and hints are printed, not fatal),
// 2 on bad usage or an unreadable file.
import fs from "node:fs";
import path from "node:path";
import validator from "gltf-validator";

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error("usage: node tools/validate-gltf.mjs FILE...");
  process.exit(2);
}

let failed = false;
for (const file of files) {
  let bytes;
  try {
    bytes = fs.readFileSync(file);
  } catch (err) {
    console.error(`${file}: cannot read: ${err.message}`);
    process.exit(2);
  }
  const report = await validator.validateBytes(new Uint8Array(bytes), {
    uri: path.basename(file),
    maxIssues: 1000,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        const full = path.resolve(path.dirname(file), decodeURIComponent(uri));
        fs.readFile(full, (err, data) => (err ? reject(err.toString()) : resolve(data)));
      }),
  });
  const issues = report.issues;
  console.log(
    `${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ` +
      `${issues.numInfos} infos, ${issues.numHints} hints`,
  );
  for (const m of issues.messages) {
    const sev = ["error", "warning", "info", "hint"][m.severity] ?? m.severity;
    console.log(`  ${sev} ${m.code} ${m.pointer ?? ""}: ${m.message}`);
  }
  if (report.info) {
    const i = report.info;
    console.log(
      `  info: ${i.totalVertexCount ?? "?"} vertices, ${i.totalTriangleCount ?? "?"} triangles, ` +
        `${i.animationCount ?? 0} animations, ${i.materialCount ?? 0} materials`,
    );
  }
  if (issues.numErrors > 0 || issues.numWarnings > 0) failed = true;
}
process.exit(failed ? 1 : 0);
