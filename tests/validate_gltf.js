// Validates glTF files with the Khronos glTF validator (npm gltf-validator, installed by tools/setup-deps.sh into
// .cache/gltf-validator/). Usage: node tests/validate_gltf.js FILE.gltf...
// Prints each file's errors and warnings and counts its infos; exits 1 when any file has an error or a warning
// (or the validator is not installed: run tools/setup-deps.sh).
const fs = require("fs");
const path = require("path");
let validator;
try {
  validator = require(path.join(__dirname, "..", ".cache", "gltf-validator", "node_modules", "gltf-validator"));
} catch (e) {
  console.error("validate_gltf: the Khronos glTF validator is not installed in .cache/gltf-validator (tools/setup-deps.sh installs it)");
  process.exit(1);
}

async function check(file) {
  const data = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(data, {
    uri: file,
    maxIssues: 1000,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, bytes) =>
          err ? reject(err.toString()) : resolve(new Uint8Array(bytes)));
      }),
  });
  const n = report.issues;
  console.log(`${file}: ${n.numErrors} errors, ${n.numWarnings} warnings, ${n.numInfos} infos (validator ${report.validatorVersion})`);
  for (const m of n.messages) if (m.severity <= 1) console.log(`  ${["error", "warning", "info"][m.severity]} ${m.code}: ${m.message} (${m.pointer || ""})`);
  return n.numErrors + n.numWarnings;
}

(async () => {
  let bad = 0;
  for (const f of process.argv.slice(2)) bad += await check(f);
  process.exit(bad ? 1 : 0);
})().catch((e) => {
  console.error("validate_gltf: " + e);
  process.exit(1);
});
